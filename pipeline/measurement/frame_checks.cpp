// Per-frame condition checks (measurement/frame_checks.hpp).
#include "measurement/frame_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "core/stereo_frame.hpp"

namespace rutd {

void normalized_correlation(const cv::Mat& area, const cv::Mat& templ, cv::Mat& result) {
  CV_Assert(area.type() == CV_8UC1 && templ.type() == CV_8UC1);
  result.create(area.rows - templ.rows + 1, area.cols - templ.cols + 1, CV_32F);
  const double n = static_cast<double>(templ.rows) * templ.cols;
  double st = 0.0, stt = 0.0;
  for (int y = 0; y < templ.rows; ++y) {
    const std::uint8_t* t = templ.ptr<std::uint8_t>(y);
    for (int x = 0; x < templ.cols; ++x) {
      st += t[x];
      stt += double(t[x]) * t[x];
    }
  }
  const double var_t = stt - st * st / n;
  for (int dy = 0; dy < result.rows; ++dy) {
    float* out = result.ptr<float>(dy);
    for (int dx = 0; dx < result.cols; ++dx) {
      std::int64_t sp = 0, spp = 0, stp = 0;  // exact: 255^2 * pixels fits many times over
      for (int y = 0; y < templ.rows; ++y) {
        const std::uint8_t* t = templ.ptr<std::uint8_t>(y);
        const std::uint8_t* a = area.ptr<std::uint8_t>(dy + y) + dx;
        for (int x = 0; x < templ.cols; ++x) {
          sp += a[x];
          spp += a[x] * a[x];
          stp += a[x] * t[x];
        }
      }
      const double var_p = double(spp) - double(sp) * double(sp) / n;
      const double cov = double(stp) - st * double(sp) / n;
      out[dx] = var_p > 0.0 && var_t > 0.0 ? static_cast<float>(cov / std::sqrt(var_p * var_t)) : 0.0f;
    }
  }
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kFullScale = 255.0;

void require(bool ok, const char* field, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("conditions: ") + field + ": " + what);
}

// Block sums over every second measured row of one strip; returns the histogram's median grey level
// and counts saturated pixels.
struct StripStats {
  int median = 0;
  double saturated = 0.0;  // fraction
};

StripStats block_stats(const cv::Mat& strip, int row_begin, int row_end, int block, double saturated_level,
                       std::vector<double>& sum, std::vector<double>& grad2, std::vector<int>& count) {
  const int blocks = strip.cols / block;
  sum.assign(static_cast<std::size_t>(blocks), 0.0);
  grad2.assign(static_cast<std::size_t>(blocks), 0.0);
  count.assign(static_cast<std::size_t>(blocks), 0);
  std::array<int, 256> histogram{};
  const int saturated_from = static_cast<int>(std::ceil(saturated_level * kFullScale));
  int saturated = 0, total = 0;
  for (int y = row_begin; y < row_end; y += 2) {
    const std::uint8_t* p = strip.ptr<std::uint8_t>(y);
    for (int b = 0; b < blocks; ++b) {
      const int x0 = b * block, x1 = x0 + block;
      int s = 0, g = 0, sat = 0;
      for (int x = x0; x < x1; ++x) {
        s += p[x];
        sat += p[x] >= saturated_from;
        ++histogram[p[x]];
        if (x + 1 < strip.cols) {
          const int d = int(p[x + 1]) - int(p[x]);
          g += d * d;
        }
      }
      sum[static_cast<std::size_t>(b)] += s;
      grad2[static_cast<std::size_t>(b)] += g;
      count[static_cast<std::size_t>(b)] += block;
      saturated += sat;
      total += block;
    }
  }
  StripStats out;
  out.saturated = total > 0 ? double(saturated) / total : 0.0;
  int seen = 0;
  for (int v = 0; v < 256; ++v) {
    seen += histogram[static_cast<std::size_t>(v)];
    if (2 * seen >= total) {
      out.median = v;
      break;
    }
  }
  return out;
}

// Prefix sums over columns of one strip, over every second row of [row_begin, row_end) (the rows
// block_stats samples): sum[x] of the grey levels and grad2[x] of the squared horizontal differences of
// columns [0, x).
void column_prefix_sums(const cv::Mat& strip, int row_begin, int row_end, std::vector<double>& sum,
                        std::vector<double>& grad2) {
  sum.assign(static_cast<std::size_t>(strip.cols) + 1, 0.0);
  grad2.assign(static_cast<std::size_t>(strip.cols) + 1, 0.0);
  for (int y = row_begin; y < row_end; y += 2) {
    const std::uint8_t* p = strip.ptr<std::uint8_t>(y);
    for (int x = 0; x < strip.cols; ++x) {
      sum[static_cast<std::size_t>(x) + 1] += p[x];
      if (x + 1 < strip.cols) {
        const int d = int(p[x + 1]) - int(p[x]);
        grad2[static_cast<std::size_t>(x) + 1] += d * d;
      }
    }
  }
  for (std::size_t x = 1; x < sum.size(); ++x) {
    sum[x] += sum[x - 1];
    grad2[x] += grad2[x - 1];
  }
}

double median_of(std::vector<float>& values) {
  if (values.empty()) return kNaN;
  const auto mid = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// Median valid disparity of columns [x0, x1) of the measured rows (every fourth row); NaN if none.
double median_disparity(const cv::Mat& disparity, int row_begin, int row_end, int x0, int x1,
                        std::vector<float>& values) {
  values.clear();
  for (int y = row_begin; y < row_end; y += 4) {
    const float* d = disparity.ptr<float>(y);
    for (int x = std::max(0, x0); x < std::min(disparity.cols, x1); ++x) {
      if (std::isfinite(d[x])) values.push_back(d[x]);
    }
  }
  return median_of(values);
}

// Vertical offsets (px, right row - left row) of the right strip's features in the blocks that
// correlate. A turned camera moves rows by different amounts across the strip (a roll changes sign at
// the principal point), so the largest offset is reported and the count beyond the limit kept. An
// offset at the end of the search range is reported there (a lower bound of the real one).
struct VerticalOffsets {
  double largest = kNaN;  // signed offset of largest magnitude; NaN when no block correlates
  int found = 0;
  int beyond = 0;    // blocks whose |offset| exceeds max_vertical_disparity_px
  int over_rut = 0;  // blocks not correlated because they lie over the rut opening
};

VerticalOffsets vertical_disparity(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity, int row_begin,
                                   int row_end, double strip_disparity, DisparityBand band, double rut_u0,
                                   double rut_u1, const ConditionConfig& c, FrameCheckScratch& s) {
  const int search = std::min(c.vertical_search_px, left.rows / 4);
  const int width = c.vertical_block_px;
  // Nothing matched (a calibration far off loses every match): search the whole band.
  const bool known = std::isfinite(strip_disparity);
  const int slack = known ? 2 : band.num_disparities / 2 + 2;
  if (!known) strip_disparity = band.min_disparity + 0.5 * band.num_disparities;
  VerticalOffsets out;
  if (search < 1 || left.rows - 2 * search < 4) return out;
  const int blocks = c.vertical_blocks;
  for (int k = 0; k < blocks; ++k) {
    // Blocks spread over the middle of the strip, where the right camera sees the same ground.
    const int x0 = static_cast<int>((0.2 + 0.6 * (k + 0.5) / blocks) * left.cols) - width / 2;
    // Not over the rut: its walls' disparity changes across a block (by several pixels on a steep one),
    // which a rigid block cannot follow; it trades the misfit for a vertical offset (measured: -0.88 px on
    // a clean sand rut in dim light, -8 px at a steep snow wall's edge, where the rows slide along it).
    if (x0 + width > rut_u0 && x0 < rut_u1) {
      ++out.over_rut;
      continue;
    }
    double d = known ? median_disparity(disparity, row_begin, row_end, x0, x0 + width, s.values) : kNaN;
    if (!std::isfinite(d)) d = strip_disparity;
    const int rx0 = x0 - static_cast<int>(std::lround(d)) - slack;
    if (x0 < 0 || x0 + width > left.cols || rx0 < 0 || rx0 + width + 2 * slack > right.cols) continue;
    const cv::Mat templ = left(cv::Rect(x0, search, width, left.rows - 2 * search));
    // A flat block correlates equally well everywhere (a covered lens, a featureless scene).
    cv::Scalar mean, deviation;
    cv::meanStdDev(templ, mean, deviation);
    if (deviation[0] < c.min_texture) continue;
    const cv::Mat area = right(cv::Rect(rx0, 0, width + 2 * slack, right.rows));
    normalized_correlation(area, templ, s.result);
    cv::Point best;
    double peak = 0.0;
    cv::minMaxLoc(s.result, nullptr, &peak, nullptr, &best);
    if (!(peak >= c.min_vertical_correlation)) continue;
    // Texture that varies along the columns only (a rut's edge or a shadow's, running along travel: the
    // rows slide along it) correlates about as well at every row searched, and its peak is chance.
    double lowest = peak;
    for (int y = 0; y < s.result.rows; ++y) lowest = std::min(lowest, double(s.result.at<float>(y, best.x)));
    if (peak - lowest < c.min_vertical_contrast) continue;
    double dy = best.y;
    if (best.y > 0 && best.y + 1 < s.result.rows) {
      const float a = s.result.at<float>(best.y - 1, best.x), b = s.result.at<float>(best.y, best.x),
                  e = s.result.at<float>(best.y + 1, best.x);
      const double den = a - 2.0 * b + e;
      if (den < 0.0) dy += 0.5 * (a - e) / den;
    }
    const double offset = dy - search;
    ++out.found;
    out.beyond += std::abs(offset) > c.max_vertical_disparity_px;
    if (!(std::abs(offset) <= std::abs(out.largest))) out.largest = offset;
  }
  return out;
}

// Longest run (px) of blocks inside columns [u0, u1] where the surface was not seen: flat in both
// cameras (texture below `threshold`) and unmatched (under half of the sampled pixels have a disparity).
// `shift` maps a left block to the right block seeing the same ground. A dark but textured surface (a
// rut wall in shadow) may be as flat by this threshold, but DIC matches it: it is seen, and not counted.
double unseen_flat_run_px(const FrameCheckScratch& s, int block, double u0, double u1, int shift, double threshold) {
  const auto& tl = s.texture[0];
  const auto& tr = s.texture[1];
  const int blocks = static_cast<int>(tl.size());
  int run = 0, longest = 0;
  for (int b = 0; b < blocks; ++b) {
    const double x0 = b * block, x1 = x0 + block;
    const int rb = b - shift;
    const auto k = static_cast<std::size_t>(b);
    const bool inside = x0 >= u0 && x1 <= u1 && rb >= 0 && rb < blocks;
    const bool flat =
        inside && tl[k] < threshold && tr[static_cast<std::size_t>(rb)] < threshold && 2 * s.matched[k] < s.sampled[k];
    run = flat ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  return double(longest) * block;
}

// The median of a left-strip block figure over the blocks wholly outside the rut opening [u0, u1]
// (columns); NaN when there are none. `values` is scratch.
double outside_median(const std::vector<double>& figure, int block, double u0, double u1, std::vector<float>& values) {
  values.clear();
  for (std::size_t b = 0; b < figure.size(); ++b) {
    const double x0 = double(b) * block, x1 = x0 + block;
    if (x1 < u0 || x0 > u1) values.push_back(static_cast<float>(figure[b]));
  }
  return median_of(values);
}

// The unmatched blocks inside the rut opening, each left block against the right strip's window at the
// ground's disparity and at the same columns (ConditionConfig::specular_coherence).
struct SpecularSums {
  int blocks = 0;
  double at_ground = 0, at_ground_sum = 0;  // sum of |left - right| and of left + right, brightness
  double at_zero = 0, at_zero_sum = 0;
  double brightest = -1, brightest_texture = 0;  // the block both views see brightest at the same columns

  void add(double left, double right_ground, double right_zero, double left_texture, double right_zero_texture) {
    ++blocks;
    at_ground += std::abs(left - right_ground);
    at_ground_sum += left + right_ground;
    at_zero += std::abs(left - right_zero);
    at_zero_sum += left + right_zero;
    const double both = std::min(left, right_zero);
    if (both > brightest) {
      brightest = both;
      brightest_texture = std::max(left_texture, right_zero_texture);
    }
  }

  // ground_brightness, ground_texture: the left strip's medians outside the opening.
  bool reflects(const ConditionConfig& c, double ground_brightness, double ground_texture) const {
    if (blocks < c.specular_min_blocks || at_ground_sum <= 0 || at_zero_sum <= 0) return false;
    const double apart = at_ground / at_ground_sum, together = at_zero / at_zero_sum;
    return apart >= c.specular_min_disagreement && together < c.specular_coherence * apart &&
           brightest >= (1.0 + c.specular_brightening) * ground_brightness && brightest_texture >= ground_texture;
  }
};

bool depth_found(RutStatus status) {
  return status == RutStatus::Ok || status == RutStatus::Uncertain || status == RutStatus::Vegetation;
}

// The least texture (RMS horizontal neighbour difference, grey levels of the 8-bit strip) of a block the
// vegetation check counts as textured in a camera whose raw image has the signal `g`: twice what its
// noise alone gives, in an image whose texture does not exceed its noise (texture_to_noise < 1). Where
// the texture dominates, the noise figure (a Laplacian's median) takes fine texture for noise: on grass
// blades it came out high enough to hide the blades themselves. Unknown figures leave min_texture.
double textured_from(const ImageSignal& g, const ConditionConfig& c) {
  if (!(g.texture_to_noise < 1.0) || !std::isfinite(g.noise)) return c.min_texture;
  return std::max(c.min_texture, 2.0 * std::sqrt(2.0) * g.noise * kFullScale);
}

}  // namespace

ImageSignal image_signal(const cv::Mat& raw, int row_begin, int row_end, int max_rows,
                         std::vector<std::uint32_t>& histogram) noexcept {
  ImageSignal out;
  if (raw.empty() || raw.channels() != 1 || (raw.depth() != CV_8U && raw.depth() != CV_16U) || raw.cols < 8 ||
      raw.rows < 3 || max_rows < 1)
    return out;
  row_begin = std::clamp(row_begin, 1, raw.rows - 1);
  row_end = std::clamp(row_end, row_begin, raw.rows - 1);
  if (row_end - row_begin < 1) return out;
  const int step = std::max(1, (row_end - row_begin) / max_rows);
  // Full scale: the sensor's (core/stereo_frame.hpp), from the brightest pixel of the rows read.
  int brightest = 0;
  if (raw.depth() == CV_16U) {
    for (int y = row_begin; y < row_end; y += step) {
      const std::uint16_t* p = raw.ptr<std::uint16_t>(y);
      for (int x = 0; x < raw.cols; ++x) brightest = std::max<int>(brightest, p[x]);
    }
  }
  const double full_scale = sensor_full_scale(raw.depth(), brightest);
  // |Laplacian| into a histogram of quarter grey levels of an 8-bit scale (4096 bins: up to 4 full
  // scales); its median gives the noise. Integer arithmetic in the loop: 8-bit values are in quarters
  // by a shift, 16-bit ones by one multiplication.
  constexpr std::size_t kBins = 4096;
  const double unit = full_scale / (4.0 * 255.0);
  histogram.assign(kBins, 0);
  std::int64_t gradient2 = 0;
  long count = 0;
  const auto pass = [&](auto pixel_type, auto to_bin) {
    using P = decltype(pixel_type);
    for (int y = row_begin; y < row_end; y += step) {
      const P* a = raw.ptr<P>(y - 1);
      const P* b = raw.ptr<P>(y);
      const P* c = raw.ptr<P>(y + 1);
      for (int x = 1; x + 1 < raw.cols; x += 2) {  // every second column: plenty for a median
        const int lap = int(a[x - 1]) - 2 * int(a[x]) + int(a[x + 1]) - 2 * int(b[x - 1]) + 4 * int(b[x]) -
                        2 * int(b[x + 1]) + int(c[x - 1]) - 2 * int(c[x]) + int(c[x + 1]);
        ++histogram[std::min<std::size_t>(to_bin(lap < 0 ? -lap : lap), kBins - 1)];
        const std::int64_t d = std::int64_t(b[x + 1]) - std::int64_t(b[x]);
        gradient2 += d * d;
      }
      count += (raw.cols - 1) / 2;
    }
  };
  if (raw.depth() == CV_8U) {
    pass(std::uint8_t{}, [](int v) { return static_cast<std::size_t>(v) << 2; });
  } else {
    const double per_unit = 1.0 / unit;
    pass(std::uint16_t{}, [per_unit](int v) { return static_cast<std::size_t>(v * per_unit); });
  }
  if (count == 0) return out;
  std::uint64_t below = 0;
  std::size_t median = 0;
  while (median + 1 < kBins && 2 * (below + histogram[median]) < static_cast<std::uint64_t>(count))
    below += histogram[median++];
  // The kernel's weights square-sum to 36: white noise of deviation s gives a Laplacian of deviation 6 s,
  // whose absolute value has its median at 0.6745 of that. The median keeps the texture's edges out.
  const double median_abs = (double(median) + 0.5) * unit;
  out.noise = median_abs / (0.6745 * 6.0) / full_scale;
  out.texture = std::sqrt(double(gradient2) / double(count)) / full_scale;
  const double signal2 = out.texture * out.texture - 2.0 * out.noise * out.noise;
  out.texture_to_noise = signal2 > 0.0 ? std::sqrt(signal2) / (std::sqrt(2.0) * out.noise) : 0.0;
  return out;
}

void validate(const ConditionConfig& c) {
  require(c.block_px >= 4 && c.block_px <= 256, "block_px", "must be within [4, 256]");
  require(c.obstruction_ratio > 0 && c.obstruction_ratio < 1, "obstruction_ratio", "must be within (0, 1)");
  require(c.min_texture >= 0, "min_texture", "must be >= 0");
  require(c.obstruction_min_fraction > 0 && c.obstruction_min_fraction <= 1, "obstruction_min_fraction",
          "must be within (0, 1]");
  require(c.veil_brightening >= 0, "veil_brightening", "must be >= 0");
  require(c.low_light_level >= 0 && c.low_light_level < 1, "low_light_level", "must be within [0, 1)");
  require(c.low_light_texture_to_noise >= 0, "low_light_texture_to_noise", "must be >= 0");
  require(c.low_light_noise > 0 && c.low_light_noise < 1, "low_light_noise", "must be within (0, 1)");
  require(c.saturated_level > 0 && c.saturated_level <= 1, "saturated_level", "must be within (0, 1]");
  require(c.overexposed_fraction > 0 && c.overexposed_fraction <= 1, "overexposed_fraction", "must be within (0, 1]");
  require(c.flat_ratio > 0 && c.flat_ratio < 1, "flat_ratio", "must be within (0, 1)");
  require(c.flat_min_width_mm > 0, "flat_min_width_mm", "must be > 0");
  require(c.flat_min_unseen_mm >= 0, "flat_min_unseen_mm", "must be >= 0");
  require(c.specular_coherence > 0 && c.specular_coherence <= 1, "specular_coherence", "must be in (0, 1]");
  require(c.specular_min_disagreement >= 0 && c.specular_min_disagreement < 1, "specular_min_disagreement",
          "must be in [0, 1)");
  require(c.specular_brightening >= 0, "specular_brightening", "must be >= 0");
  require(c.specular_min_blocks >= 1, "specular_min_blocks", "must be >= 1");
  require(c.max_vertical_disparity_px > 0, "max_vertical_disparity_px", "must be > 0");
  require(c.vertical_search_px >= 1 && c.vertical_search_px <= 32, "vertical_search_px", "must be within [1, 32]");
  require(c.vertical_blocks >= 1 && c.vertical_blocks <= 16, "vertical_blocks", "must be within [1, 16]");
  require(c.vertical_block_px >= 8 && c.vertical_block_px <= 256, "vertical_block_px", "must be within [8, 256]");
  require(c.min_vertical_correlation > 0 && c.min_vertical_correlation < 1, "min_vertical_correlation",
          "must be within (0, 1)");
  require(c.min_vertical_contrast >= 0 && c.min_vertical_contrast < 2, "min_vertical_contrast",
          "must be within [0, 2)");
  require(c.vegetation_unmatched_share > 0 && c.vegetation_unmatched_share <= 1, "vegetation_unmatched_share",
          "must be within (0, 1]");
  require(c.vegetation_min_blocks >= 1, "vegetation_min_blocks", "must be >= 1");
  require(c.unsynchronised_skew_ms >= 0, "unsynchronised_skew_ms", "must be >= 0");
}

void check_frame(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity, int row_begin, int row_end,
                 const StereoGeometry& geometry, const RutGeometry& rut, DisparityBand band, std::int64_t skew_ns,
                 const PairSignal& signal, const ConditionConfig& c, FrameCheckScratch& s, RutMeasurement& m) noexcept {
  if (!c.enabled || left.empty() || left.size() != right.size() || left.type() != CV_8UC1 || right.type() != CV_8UC1 ||
      row_end <= row_begin || left.cols < 2 * c.block_px)
    return;
  bool bottom_hidden = false;   // this check's own water finding (a waterline read through is not one)
  bool unsynchronised = false;  // a known skew explains the views' disagreement (ConditionConfig)
  // A camera that sees no texture anywhere while the other does: covered whole. No skew explains that
  // (motion moves the texture, it does not erase it), so it stands beside UNSYNCHRONISED.
  bool covered_left = false, covered_right = false;
  try {
    const cv::Mat* strips[2] = {&left, &right};
    StripStats stats[2];
    for (int k = 0; k < 2; ++k) {
      stats[k] =
          block_stats(*strips[k], row_begin, row_end, c.block_px, c.saturated_level, s.sum[k], s.grad2[k], s.count[k]);
      const std::size_t blocks = s.sum[k].size();
      s.texture[k].resize(blocks);
      s.brightness[k].resize(blocks);
      for (std::size_t b = 0; b < blocks; ++b) {
        const double n = std::max(1, s.count[k][b]);
        s.texture[k][b] = std::sqrt(s.grad2[k][b] / n);
        s.brightness[k][b] = s.sum[k][b] / n;
      }
    }

    // Exposure.
    const int median = std::max(stats[0].median, stats[1].median);
    if (median < c.low_light_level * kFullScale) m.conditions |= kConditionLowLight;
    // fmax and fmin skip an unknown (NaN) camera; comparisons with NaN are false: none known raises nothing.
    const double best_ratio = std::fmax(signal.left.texture_to_noise, signal.right.texture_to_noise);
    const double least_noise = std::fmin(signal.left.noise, signal.right.noise);
    if (best_ratio < c.low_light_texture_to_noise && least_noise >= c.low_light_noise)
      m.conditions |= kConditionLowLight;
    if (std::max(stats[0].saturated, stats[1].saturated) > c.overexposed_fraction)
      m.conditions |= kConditionOverexposed;

    // The rut opening's columns in the left strip, where extract_rut found one (else an empty range).
    const bool has_opening = rut.has_rut && rut.has_line;
    const cv::Matx44d& q = geometry.Q();
    const double f = geometry.focal_px(), cx = -q(0, 3);
    const auto column = [&](double x) { return cx + f * x / (rut.line_m * x + rut.line_c); };
    const double u0 = has_opening ? column(rut.left_x_mm) : 0.0, u1 = has_opening ? column(rut.right_x_mm) : -1.0;

    // Obstruction: each left block against the right block that sees the same ground.
    const double strip_disparity = median_disparity(disparity, row_begin, row_end, 0, disparity.cols, s.values);
    const double d0 = std::isfinite(strip_disparity)     ? strip_disparity
                      : rut.has_line && rut.line_c > 0.0 ? geometry.disparity_at(rut.line_c)
                                                         : kNaN;
    const int shift = std::isfinite(d0) ? static_cast<int>(std::lround(d0 / c.block_px)) : 0;
    const int blocks = static_cast<int>(s.texture[0].size());
    s.matched.assign(static_cast<std::size_t>(blocks), 0);
    s.sampled.assign(static_cast<std::size_t>(blocks), 0);
    for (int y = row_begin; y < row_end; y += 4) {
      const float* d = disparity.ptr<float>(y);
      for (int x = 0; x < blocks * c.block_px; ++x) {
        s.matched[static_cast<std::size_t>(x / c.block_px)] += std::isfinite(d[x]) ? 1 : 0;
        s.sampled[static_cast<std::size_t>(x / c.block_px)] += 1;
      }
    }
    // The right strip's brightness and texture over any window of columns: prefix sums of its columns
    // over the rows block_stats sampled.
    column_prefix_sums(right, row_begin, row_end, s.column_sum, s.column_grad2);
    const double window_pixels = double(std::max(1, s.count[1].empty() ? 0 : s.count[1][0]));
    const auto at = [](const std::vector<double>& v, int i) { return v[static_cast<std::size_t>(i)]; };
    // The right strip's mean brightness and texture over the block-wide window from column x.
    const auto right_window = [&](int x) {
      return std::pair{(at(s.column_sum, x + c.block_px) - at(s.column_sum, x)) / window_pixels,
                       std::sqrt((at(s.column_grad2, x + c.block_px) - at(s.column_grad2, x)) / window_pixels)};
    };
    // The ground's texture outside the rut opening (NaN without one): the reflection's and the water's.
    const double ground_texture = has_opening ? outside_median(s.texture[0], c.block_px, u0, u1, s.values) : kNaN;
    int compared = 0, left_blocked = 0, right_blocked = 0;
    int outside_blocked = 0;  // blocks outside the rut opening obstructed in either view
    SpecularSums specular;
    for (int b = 0; b < blocks; ++b) {
      // The ground this block sees lies at its own disparity in the right strip (a scene in depth moves
      // each part by its own; the strip's median puts a near object's block beside other ground), at
      // the strip's where the block matched nothing (an obstructed view matches nothing).
      const int x0 = b * c.block_px;
      double d = median_disparity(disparity, row_begin, row_end, x0, x0 + c.block_px, s.values);
      if (!std::isfinite(d)) d = std::isfinite(d0) ? d0 : 0.0;
      const int rx0 = x0 - static_cast<int>(std::lround(d));
      if (rx0 < 0 || rx0 + c.block_px > right.cols) continue;
      ++compared;
      const double tl = s.texture[0][static_cast<std::size_t>(b)], bl = s.brightness[0][static_cast<std::size_t>(b)];
      const auto [br, tr] = right_window(rx0);
      // A block that matched saw the same texture through both lenses: no blob covers it (what differs
      // then is mostly the scene: a surface lit or seen differently from the two viewpoints). Only a veil
      // (frost, snow, a film lit from the side) lets the ground through to be matched, and the camera
      // behind it sees the ground brighter and with a fraction of its texture.
      const auto veiled = [&](double t_self, double t_other, double b_self, double b_other) {
        return t_other >= c.min_texture && t_self < c.obstruction_ratio * t_other &&
               b_self >= (1.0 + c.veil_brightening) * b_other;
      };
      const bool inside = (b + 1) * c.block_px > u0 && b * c.block_px < u1;
      const auto count = [&](bool left_obstructed, bool right_obstructed) {
        left_blocked += left_obstructed;
        right_blocked += right_obstructed;
        outside_blocked += !inside && (left_obstructed || right_obstructed);
      };
      if (2 * s.matched[static_cast<std::size_t>(b)] >= s.sampled[static_cast<std::size_t>(b)]) {
        count(veiled(tl, tr, bl, br), veiled(tr, tl, br, bl));
        continue;
      }
      if (inside) {
        // The right strip's window at the very columns of this block: where a reflection of the sky
        // would be (disparity 0).
        const auto [b0, t0] = right_window(x0);
        specular.add(bl, br, b0, tl, t0);
      }
      // The texture test only for the dimmer view: the other camera's own blob edge (a steep dark-to-lit
      // step inside its block) must not make this camera's ground look flat by comparison.
      const auto blocked = [&](double t_self, double t_other, double b_self, double b_other) {
        return b_self < c.obstruction_ratio * b_other ||
               (b_self <= b_other && t_other >= c.min_texture && t_self < c.obstruction_ratio * t_other);
      };
      count(blocked(tl, tr, bl, br), blocked(tr, tl, br, bl));
    }
    // A reflection in a level water surface: the views' disagreement is all inside the rut opening, and
    // what one camera sees bright there the other sees at the same columns, not at the ground's
    // disparity. Those blocks are the water's, not a lens's.
    const bool reflection =
        has_opening && left_blocked + right_blocked > 0 && outside_blocked == 0 &&
        specular.reflects(c, outside_median(s.brightness[0], c.block_px, u0, u1, s.values), ground_texture);
    if (reflection) {
      left_blocked = right_blocked = 0;
      m.conditions |= kConditionWater;
      bottom_hidden = rut.unseen_depth_mm > c.flat_min_unseen_mm;
    }
    if (compared > 0) {
      m.obstructed_left = double(left_blocked) / compared;
      m.obstructed_right = double(right_blocked) / compared;
    }
    // A camera that sees no texture anywhere while the other does is covered whole, unless DIC matched
    // most of the strip: then both saw the same texture, only a faint one (snow under read noise).
    long matched_pixels = 0, sampled_pixels = 0;
    for (int b = 0; b < blocks; ++b) {
      matched_pixels += s.matched[static_cast<std::size_t>(b)];
      sampled_pixels += s.sampled[static_cast<std::size_t>(b)];
    }
    const bool mostly_matched = 2 * matched_pixels >= sampled_pixels;
    const auto flat_everywhere = [&](int k) {
      int flat = 0;
      for (double t : s.texture[static_cast<std::size_t>(k)]) flat += t < c.min_texture;
      return flat >= 0.9 * double(s.texture[static_cast<std::size_t>(k)].size());
    };
    const bool flat_left = flat_everywhere(0), flat_right = flat_everywhere(1);
    covered_left = !mostly_matched && flat_left && !flat_right;
    covered_right = !mostly_matched && flat_right && !flat_left;
    if (covered_left) m.obstructed_left = 1.0;
    if (covered_right) m.obstructed_right = 1.0;
    if (m.obstructed_left >= c.obstruction_min_fraction) m.conditions |= kConditionLeftObstructed;
    if (m.obstructed_right >= c.obstruction_min_fraction) m.conditions |= kConditionRightObstructed;

    // Vegetation: textured in both cameras, yet unmatched; judged outside the rut opening, where the
    // tyre has not flattened it (inside, DIC also loses steep rut walls, foreshortened differently in
    // the two views, which would pass for blades on a ground with few textured blocks, as snow).
    // Textured: textured_from's least texture in each camera (under gain, snow's noise alone passes
    // min_texture, and blocks of noise that DIC leaves unconverged are no blades).
    const double textured_left = textured_from(signal.left, c), textured_right = textured_from(signal.right, c);
    int textured = 0, unmatched = 0;
    for (int b = 0; b < blocks; ++b) {
      const int rb = b - shift;
      if (rb < 0 || rb >= blocks || ((b + 1) * c.block_px > u0 && b * c.block_px < u1)) continue;
      if (s.texture[0][static_cast<std::size_t>(b)] < textured_left ||
          s.texture[1][static_cast<std::size_t>(rb)] < textured_right)
        continue;
      ++textured;
      unmatched += 2 * s.matched[static_cast<std::size_t>(b)] < s.sampled[static_cast<std::size_t>(b)];
    }
    if (unmatched >= c.vegetation_min_blocks && unmatched > c.vegetation_unmatched_share * textured)
      m.conditions |= kConditionVegetation;

    // Calibration.
    // Drift when at least a third of the correlating blocks are beyond the limit, and two of them unless
    // only one correlates: one block's chance match cannot raise it (a block on a pile's slope beside the
    // rut, 0.74 px, when the two over the rut are left out), a roll that moves only the strip's ends can.
    const VerticalOffsets v = vertical_disparity(left, right, disparity, row_begin, row_end, d0, band, u0, u1, c, s);
    m.vertical_disparity_px = v.largest;
    const bool offset = v.found > 0 && 3 * v.beyond >= v.found && (v.beyond >= 2 || v.found == 1);
    // A known skew explains offsets beyond the limit, or views too far apart to correlate at all; not a
    // view with nothing to correlate (no texture in one or both: a covered lens, a featureless scene).
    unsynchronised = std::abs(static_cast<double>(skew_ns)) * 1e-6 >= c.unsynchronised_skew_ms &&
                     c.unsynchronised_skew_ms > 0 &&
                     (offset || (v.found == 0 && v.over_rut < c.vertical_blocks && !flat_left && !flat_right));
    if (offset && !unsynchronised) m.conditions |= kConditionCalibrationDrift;

    // Water / flat patch inside the rut opening, against the texture of the ground outside it.
    if (has_opening) {
      const double z = rut.line_m * 0.5 * (rut.left_x_mm + rut.right_x_mm) + rut.line_c;
      if (std::isfinite(ground_texture) && z > 0) {
        const double run_mm = unseen_flat_run_px(s, c.block_px, u0, u1, shift, c.flat_ratio * ground_texture) * z / f;
        // The patch hides the bottom only where the profile's walls still descend into it; flanked by
        // bottom seen level on both sides (a smooth patch of mud, tread marks), the bottom is measured.
        if (run_mm >= c.flat_min_width_mm && rut.unseen_depth_mm > c.flat_min_unseen_mm) {
          m.conditions |= kConditionWater;
          bottom_hidden = true;
        }
      }
    }
  } catch (...) {
    return;  // an OpenCV error on odd input: the checks report nothing for this frame
  }

  // The status: the image conditions explain any failure; water only refuses a found depth (or a
  // shallow one: the lid of a pool is no rut); vegetation any status but a rut at the edge of the view.
  if (m.status == RutStatus::NoMeasurement) return;
  // Exposure first: a dark or clipped strip also looks flat and unmatched. Clipping alone, where
  // extract_rut measured the depth OK (within its uncertainty limit) and no other check fired, only
  // took texture away: DIC finds no gradient in a clipped patch and leaves it unmatched, and the
  // depth's coverage term counts what the unmatched bins could hide. The flag stays; the depth stands
  // (auto exposure holding the median of dark mud up clips its bright patches on every frame).
  const bool clipped_only = m.conditions == kConditionOverexposed && m.status == RutStatus::Ok && !unsynchronised;
  if ((m.conditions & (kConditionLowLight | kConditionOverexposed)) && !clipped_only) {
    m.status = RutStatus::BadExposure;
  } else if (unsynchronised) {
    // The views show the ground at two moments: what their comparison raised is the motion's, except a
    // lens covered whole, which is then the status (cleaning it comes before pairing the cameras).
    std::uint8_t motion_bits = kConditionVegetation | kConditionCalibrationDrift;
    if (!covered_left) {
      motion_bits |= kConditionLeftObstructed;
      m.obstructed_left = 0.0;
    }
    if (!covered_right) {
      motion_bits |= kConditionRightObstructed;
      m.obstructed_right = 0.0;
    }
    m.conditions &= static_cast<std::uint8_t>(~motion_bits);
    m.status = covered_left || covered_right ? RutStatus::LensObstructed : RutStatus::Unsynchronised;
  } else if (m.conditions & (kConditionLeftObstructed | kConditionRightObstructed)) {
    m.status = RutStatus::LensObstructed;
  } else if (m.conditions & kConditionCalibrationDrift) {
    m.status = RutStatus::CalibrationDrift;
  } else if (bottom_hidden && (depth_found(m.status) || m.status == RutStatus::NoRut)) {
    m.status = RutStatus::BottomNotSeen;
  } else if ((m.conditions & kConditionVegetation) && m.status != RutStatus::RutAtEdge) {
    m.status = RutStatus::Vegetation;
  }
}

}  // namespace rutd
