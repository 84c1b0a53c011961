#include "measurement/band_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "engines/engine_factory.hpp"

namespace rutd {
namespace {

constexpr int kMaxCoarseSpan = 128;       // coarse-pass band, coarse px
constexpr double kMinCoarseValid = 0.05;  // fraction of coarse pixels that must get a disparity
constexpr double kLowPercentile = 0.02;
constexpr double kHighPercentile = 0.98;
constexpr double kMinMarginPx = 4.0;
constexpr double kSpreadMargin = 0.25;  // of the 2..98 percentile spread
// Mean |Sobel x| over 5x5 below which a coarse pixel counts as untextured: about 2 grey levels per px
// (3x3 Sobel reads 8x the gradient). SGBM returns confident-looking values on flat images.
constexpr double kMinTexture = 16.0;
// A band of the working range that leaves less than this share of the coarse strip's columns matchable
// (StereoSGBM gives no disparity left of min + num disparities) is narrowed around the terrain's dominant
// disparity first: a wide baseline with a near working range can leave only a margin of the image, which
// may hold no texture (plain snow) or miss the rut.
constexpr double kMinMatchableShare = 0.5;
// The narrowed band: the dominant disparity times 1 -/+ this, which holds terrain from a third nearer
// (piles, a pitched rig's near rows) to twice as far (ruts as deep as the camera is high).
constexpr double kDominantSpread = 0.5;
// The least correlation of the strips' gradients at the dominant disparity: at least a sixth of the
// gradient energy must line up (chance alone gives a few hundredths on a coarse strip).
constexpr double kMinDominantNcc = 0.15;

int round_up16(int n) { return std::max(16, (n + 15) / 16 * 16); }

int last_disparity(const DisparityBand& b) { return b.min_disparity + b.num_disparities - 1; }

DisparityBand band_between(int lo, int hi) {  // inclusive disparities, lo >= 0
  return DisparityBand{lo, round_up16(hi - lo + 1)};
}

double percentile(std::vector<float>& values, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

double matchable_share(const DisparityBand& coarse_band, int coarse_width) {
  const int blind = coarse_band.min_disparity + coarse_band.num_disparities;
  return coarse_width > 0 ? std::max(0.0, double(coarse_width - blind) / double(coarse_width)) : 0.0;
}

}  // namespace

int dominant_disparity(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& grad_left,
                       cv::Mat& grad_right) {
  cv::Sobel(left, grad_left, CV_32F, 1, 0, 3);
  cv::Sobel(right, grad_right, CV_32F, 1, 0, 3);
  const int width = left.cols;
  const int hi = std::min(last_disparity(band), width - width / 4);
  int best = -1;
  double best_ncc = 0.0, best_floor = 1.0;
  for (int d = std::max(0, band.min_disparity); d <= hi; ++d) {
    double lr = 0.0, ll = 0.0, rr = 0.0;
    for (int r = 0; r < left.rows; ++r) {
      const float* gl = grad_left.ptr<float>(r);
      const float* gr = grad_right.ptr<float>(r);
      for (int x = d; x < width; ++x) {
        lr += double(gl[x]) * gr[x - d];
        ll += double(gl[x]) * gl[x];
        rr += double(gr[x - d]) * gr[x - d];
      }
    }
    if (ll <= 0.0 || rr <= 0.0) continue;
    const double ncc = lr / std::sqrt(ll * rr);
    if (ncc > best_ncc) {
      best_ncc = ncc;
      best = d;
      // Unrelated gradients correlate about 1/sqrt(samples) by chance (neighbours share a Sobel kernel,
      // so a third of the pixels count as independent).
      best_floor = 6.0 / std::sqrt(double(left.rows) * double(width - d) / 3.0);
    }
  }
  return best_ncc >= std::max(kMinDominantNcc, best_floor) ? best : -1;
}

DisparityBand band_for_range(const StereoGeometry& g, WorkingRange range) {
  const double d_far = g.disparity_at(std::max(range.near_mm, range.far_mm));
  const double d_near = g.disparity_at(std::min(range.near_mm, range.far_mm));
  const int lo = std::max(0, static_cast<int>(std::floor(d_far)));
  const int hi = std::max(lo, static_cast<int>(std::ceil(d_near)));
  return band_between(lo, hi);
}

BandEstimator::Plan BandEstimator::plan(const StereoGeometry& g, WorkingRange range, cv::Size strip) {
  Plan p;
  p.full = band_for_range(g, range);
  p.fallback = p.full;
  const int full_hi = last_disparity(p.full);
  while (p.full.num_disparities / p.scale > kMaxCoarseSpan) p.scale *= 2;  // along x only: rows are few already
  const int coarse_width = strip.width / p.scale;
  const int coarse_lo = p.full.min_disparity / p.scale;
  // Keep a quarter of the coarse strip as overlap between the views, or nothing can match.
  const int coarse_hi = std::min((full_hi + p.scale - 1) / p.scale, coarse_width - coarse_width / 4);
  p.coarse = coarse_hi - coarse_lo >= 1 && strip.height >= 3;
  if (p.coarse) p.coarse_band = band_between(coarse_lo, coarse_hi);
  p.narrow = p.coarse && matchable_share(p.coarse_band, coarse_width) < kMinMatchableShare;
  // Rows halved too: the band is a percentile over the whole strip, which every second row gives as well.
  p.coarse_size = cv::Size(coarse_width, strip.height >= 10 ? strip.height / 2 : strip.height);
  return p;
}

DisparityBand BandEstimator::estimate(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                                      WorkingRange range) {
  Plan p = plan(g, range, left_strip.size());
  if (!p.coarse) return p.full;
  cv::resize(left_strip, left_, p.coarse_size, 0, 0, cv::INTER_AREA);
  cv::resize(right_strip, right_, p.coarse_size, 0, 0, cv::INTER_AREA);
  const int block = p.coarse_size.height >= 5 ? 5 : 3;
  if (!engine_ || engine_block_ != block) {
    EngineConfig params;
    params.block_size = block;
    engine_ = make_cpu_engine(EngineKind::Sgbm3Way, params);
    engine_block_ = block;
  }
  if (p.narrow) narrow_to_dominant(p);
  engine_->compute(left_, right_, p.coarse_band, coarse_);
  return band_from_coarse(p);
}

void BandEstimator::narrow_to_dominant(Plan& p) {
  const int d = dominant_disparity(left_, right_, p.coarse_band, grad_left_, grad_right_);
  if (d < 0) return;
  const int coarse_hi = last_disparity(p.coarse_band);
  const int spread = std::max(4, static_cast<int>(std::ceil(kDominantSpread * d)));
  const int lo = std::max(p.coarse_band.min_disparity, d - spread);
  const int hi = std::min(coarse_hi, d + spread);
  p.coarse_band = band_between(lo, hi);
  const int full_hi = last_disparity(p.full);
  p.fallback =
      band_between(std::max(p.full.min_disparity, lo * p.scale), std::min(full_hi, hi * p.scale + p.scale - 1));
}

std::optional<DisparityBand> BandEstimator::estimate_on_device(DisparityEngine& engine, const cv::Mat& left_raw,
                                                               const cv::Mat& right_raw, const StereoGeometry& g,
                                                               WorkingRange range, cv::Mat& left_strip,
                                                               cv::Mat& right_strip) {
  const Plan p = plan(g, range, cv::Size(g.rectified_size().width, g.roi().rows));
  // A band to narrow first is narrowed on the CPU (estimate(), from strips the caller rectifies).
  if (!p.coarse || p.narrow ||
      !engine.coarse_match(left_raw, right_raw, g, p.scale, p.coarse_band, left_strip, right_strip, left_, coarse_))
    return std::nullopt;
  return band_from_coarse(p);
}

DisparityBand BandEstimator::band_from_coarse(const Plan& p) {
  const int scale = p.scale;
  const int full_hi = last_disparity(p.full);
  cv::Sobel(left_, texture_, CV_32F, 1, 0, 3);
  texture_ = cv::abs(texture_);
  cv::blur(texture_, texture_, cv::Size(5, 5));
  found_.clear();
  found_.reserve(coarse_.total());
  for (int r = 0; r < coarse_.rows; ++r) {
    const float* row = coarse_.ptr<float>(r);
    const float* tex = texture_.ptr<float>(r);
    for (int x = 0; x < coarse_.cols; ++x) {
      if (std::isfinite(row[x]) && tex[x] >= kMinTexture) found_.push_back(row[x] * static_cast<float>(scale));
    }
  }
  if (static_cast<double>(found_.size()) < kMinCoarseValid * static_cast<double>(coarse_.total())) return p.fallback;
  const double lo = percentile(found_, kLowPercentile);
  const double hi = percentile(found_, kHighPercentile);
  const double margin = std::max({kMinMarginPx, 2.0 * scale, kSpreadMargin * (hi - lo)});
  const int band_lo = std::clamp(static_cast<int>(std::floor(lo - margin)), p.full.min_disparity, full_hi);
  const int band_hi = std::clamp(static_cast<int>(std::ceil(hi + margin)), band_lo, full_hi);
  return band_between(band_lo, band_hi);
}

std::optional<DisparityBand> BandTracker::band() const {
  if (frames_ <= 0 || frames_ >= kMaxFrames) return std::nullopt;
  return band_;
}

void BandTracker::update(DisparityBand band, bool estimated, const cv::Mat& disparity, int row_begin, int row_end) {
  // Every second row and column: a percentile and a share, which a quarter of the pixels give as well.
  values_.clear();
  std::size_t seen = 0;
  for (int r = row_begin; r < row_end; r += 2) {
    const float* row = disparity.ptr<float>(r);
    for (int x = 0; x < disparity.cols; x += 2, ++seen)
      if (std::isfinite(row[x])) values_.push_back(row[x]);
  }
  const double valid = seen > 0 ? static_cast<double>(values_.size()) / static_cast<double>(seen) : 0.0;
  if (estimated) {
    band_ = band;
    frames_ = 0;
    first_valid_ = valid;
  }
  if (values_.empty() || valid < 0.25 || valid < 0.8 * first_valid_) {
    frames_ = 0;
    return;
  }
  const double lo = percentile(values_, kLowPercentile), hi = percentile(values_, kHighPercentile);
  const double band_hi = last_disparity(band_);
  const bool inside = lo >= band_.min_disparity + kEdgePx && hi <= band_hi - kEdgePx;
  frames_ = inside ? frames_ + 1 : 0;
}

DisparityBand estimate_band(const cv::Mat& left_strip, const cv::Mat& right_strip, const StereoGeometry& g,
                            WorkingRange range) {
  BandEstimator estimator;
  return estimator.estimate(left_strip, right_strip, g, range);
}

}  // namespace rutd
