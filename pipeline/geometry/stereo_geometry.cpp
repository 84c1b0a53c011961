#include "geometry/stereo_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace rutd {
namespace {

struct Rectification {
  cv::Mat R1, R2, P1, P2, Q;
};

Rectification stereo_rectify(const StereoCalibration& c, double alpha) {
  Rectification r;
  cv::stereoRectify(cv::Mat(c.M1), c.D1, cv::Mat(c.M2), c.D2, c.image_size, cv::Mat(c.R), cv::Mat(c.T), r.R1, r.R2,
                    r.P1, r.P2, r.Q, cv::CALIB_ZERO_DISPARITY, alpha, c.image_size);
  return r;
}

// Maps for the strip rows only: the projection's principal point moves up by row0, so row 0 of the
// map is rectified row row0.
void strip_maps(const cv::Matx33d& M, const cv::Mat& D, const cv::Mat& R, const cv::Mat& P, StripRoi roi, int width,
                int map1_type, cv::Mat& map1, cv::Mat& map2) {
  cv::Mat strip_p = P.colRange(0, 3).clone();
  strip_p.at<double>(1, 2) -= roi.row0;
  cv::initUndistortRectifyMap(cv::Mat(M), D, R, strip_p, cv::Size(width, roi.rows), map1_type, map1, map2);
}

// True when every map position lies within half a pixel of the raw image (BORDER_REPLICATE covers
// the half pixel), i.e. the strip shows no border.
bool maps_inside(const cv::Mat& map_x, const cv::Mat& map_y, cv::Size raw) {
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  cv::minMaxLoc(map_x, &min_x, &max_x);
  cv::minMaxLoc(map_y, &min_y, &max_y);
  constexpr double kSlack = 0.5;
  return min_x >= -kSlack && max_x <= raw.width - 1 + kSlack && min_y >= -kSlack && max_y <= raw.height - 1 + kSlack;
}

bool strip_inside(const StereoCalibration& c, const Rectification& r, StripRoi roi) {
  cv::Mat mx, my;
  strip_maps(c.M1, c.D1, r.R1, r.P1, roi, c.image_size.width, CV_32FC1, mx, my);
  if (!maps_inside(mx, my, c.image_size)) return false;
  strip_maps(c.M2, c.D2, r.R2, r.P2, roi, c.image_size.width, CV_32FC1, mx, my);
  return maps_inside(mx, my, c.image_size);
}

// Largest alpha in [0, 1] whose strip has no border; alpha 0 when even that fails by more than the
// slack (it keeps only valid pixels by construction, up to stereoRectify's sampling of the border).
double choose_alpha(const StereoCalibration& c, StripRoi roi) {
  if (strip_inside(c, stereo_rectify(c, 1.0), roi)) return 1.0;
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 12; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (strip_inside(c, stereo_rectify(c, mid), roi)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// Cubic B-spline weights for a sample at fraction t in [0, 1) past the second of four taps.
inline void bspline_weights(float t, float w[4]) {
  const float t2 = t * t, t3 = t2 * t, u = 1.0f - t;
  w[0] = u * u * u / 6.0f;
  w[1] = (3.0f * t3 - 6.0f * t2 + 4.0f) / 6.0f;
  w[2] = (-3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f) / 6.0f;
  w[3] = t3 / 6.0f;
}

// Why a cubic B-spline, and not OpenCV's remap: the strip is resampled at exact float positions with
// the cubic B-spline as a smoothing kernel (no prefilter): a symmetric low-pass of about 0.6 px whose
// response hardly changes with the fractional position. OpenCV's remap quantises positions to 1/32 px,
// and every interpolating kernel (bilinear worst, Keys' cubic less) shifts fine texture by an amount
// that depends on the fractional position. The rectification maps of the two cameras have different
// fractions that stay nearly constant down a column, so that error does not average out along the
// strip: it biased rendered rut depths by up to 0.9 mm with bilinear and Keys' cubic resampling,
// against 0.2 mm with this kernel (the same smoothing applied to both images is harmless to matching;
// see Pan et al., bias reduction of DIC by Gaussian pre-filtering). Edges are replicated.
//
// The positions never change, so the taps and weights are computed once (make_taps); a pixel then
// costs 16 loads and multiply-adds.
template <typename Tap>
std::vector<Tap> make_taps(const cv::Mat& map_x, const cv::Mat& map_y, cv::Size raw) {
  std::vector<Tap> taps(map_x.total());
  const int max_x = raw.width - 1, max_y = raw.height - 1;
  std::size_t i = 0;
  for (int r = 0; r < map_x.rows; ++r) {
    const float* mx = map_x.ptr<float>(r);
    const float* my = map_y.ptr<float>(r);
    for (int c = 0; c < map_x.cols; ++c, ++i) {
      const float x = std::clamp(mx[c], 0.0f, static_cast<float>(max_x));
      const float y = std::clamp(my[c], 0.0f, static_cast<float>(max_y));
      const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
      Tap& t = taps[i];
      t.x = x0 - 1;
      t.y = y0 - 1;
      bspline_weights(x - static_cast<float>(x0), t.wx);
      bspline_weights(y - static_cast<float>(y0), t.wy);
    }
  }
  return taps;
}

// x then y of every map position, row-major (StereoGeometry::left_map()).
std::vector<float> interleave(const cv::Mat& map_x, const cv::Mat& map_y) {
  cv::Mat xy;  // CV_32FC2, continuous: x then y per position
  cv::merge(std::vector<cv::Mat>{map_x, map_y}, xy);
  const auto* first = xy.ptr<float>();
  return std::vector<float>(first, first + 2 * xy.total());
}

// One strip pixel from its taps; the block is clamped to the raw image only where it leaves it.
template <typename Pixel, typename Tap>
inline float resample_pixel(const cv::Mat& raw, const Tap& t) {
  const int max_x = raw.cols - 1, max_y = raw.rows - 1;
  float sum = 0.0f;
  if (t.x >= 0 && t.x + 3 <= max_x && t.y >= 0 && t.y + 3 <= max_y) {
    const std::size_t step = raw.step1();
    const Pixel* p = raw.ptr<Pixel>(t.y) + t.x;
    for (int j = 0; j < 4; ++j, p += step)
      sum += t.wy[j] * (t.wx[0] * p[0] + t.wx[1] * p[1] + t.wx[2] * p[2] + t.wx[3] * p[3]);
    return sum;
  }
  int xs[4];
  for (int k = 0; k < 4; ++k) xs[k] = std::clamp(t.x + k, 0, max_x);
  for (int j = 0; j < 4; ++j) {
    const Pixel* p = raw.ptr<Pixel>(std::clamp(t.y + j, 0, max_y));
    sum += t.wy[j] * (t.wx[0] * p[xs[0]] + t.wx[1] * p[xs[1]] + t.wx[2] * p[xs[2]] + t.wx[3] * p[xs[3]]);
  }
  return sum;
}

// Four raw pixels of a row as floats. The bytes are copied to an aligned word first: OpenCV's
// v_load_expand_q reads them as one int, which at an odd address is undefined behaviour (UBSan reports
// it); the copy compiles to the same single load.
inline cv::v_float32x4 load4(const std::uint8_t* p) {
  alignas(4) std::uint8_t word[4];
  std::memcpy(word, p, sizeof word);
  return cv::v_cvt_f32(cv::v_reinterpret_as_s32(cv::v_load_expand_q(word)));
}
inline cv::v_float32x4 load4(const std::uint16_t* p) {
  return cv::v_cvt_f32(cv::v_reinterpret_as_s32(cv::v_load_expand(p)));
}

// One interior pixel as a vector whose lanes sum to the result: lane i holds sum_j wy_j wx_i p(j, i).
template <typename Pixel, typename Tap>
inline cv::v_float32x4 resample_lanes(const Pixel* p, std::size_t step, const Tap& t) {
  const cv::v_float32x4 wx = cv::v_load(t.wx);
  cv::v_float32x4 acc = load4(p) * cv::v_setall_f32(t.wy[0]);
  acc = cv::v_muladd(load4(p + step), cv::v_setall_f32(t.wy[1]), acc);
  acc = cv::v_muladd(load4(p + 2 * step), cv::v_setall_f32(t.wy[2]), acc);
  acc = cv::v_muladd(load4(p + 3 * step), cv::v_setall_f32(t.wy[3]), acc);
  return acc * wx;
}

template <typename Tap>
inline bool interior(const Tap& t, int max_x, int max_y) {
  return t.x >= 0 && t.x + 3 <= max_x && t.y >= 0 && t.y + 3 <= max_y;
}

// Resamples one strip row into floats, four pixels per step (one horizontal reduction for four);
// groups that touch the raw border go through the clamped scalar path.
template <typename Pixel, typename Tap>
void resample_row(const cv::Mat& raw, const Tap* t, int cols, float* o) {
  const int max_x = raw.cols - 1, max_y = raw.rows - 1;
  const std::size_t step = raw.step1();
  const auto block = [&](const Tap& tap) { return raw.ptr<Pixel>(tap.y) + tap.x; };
  int c = 0;
  for (; c + 4 <= cols; c += 4, t += 4) {
    if (interior(t[0], max_x, max_y) && interior(t[1], max_x, max_y) && interior(t[2], max_x, max_y) &&
        interior(t[3], max_x, max_y)) {
      cv::v_store(o + c,
                  cv::v_reduce_sum4(resample_lanes(block(t[0]), step, t[0]), resample_lanes(block(t[1]), step, t[1]),
                                    resample_lanes(block(t[2]), step, t[2]), resample_lanes(block(t[3]), step, t[3])));
    } else {
      for (int k = 0; k < 4; ++k) o[c + k] = resample_pixel<Pixel>(raw, t[k]);
    }
  }
  for (; c < cols; ++c, ++t) o[c] = resample_pixel<Pixel>(raw, *t);
}

// 8-bit raw: straight to the 8-bit strip, rounded as convertTo rounds. `row` is one row of float scratch.
template <typename Tap>
void resample_u8(const cv::Mat& raw, const std::vector<Tap>& taps, cv::Mat& out, std::vector<float>& row) {
  row.resize(static_cast<std::size_t>(out.cols));
  for (int r = 0; r < out.rows; ++r) {
    resample_row<std::uint8_t>(raw, taps.data() + static_cast<std::size_t>(r) * out.cols, out.cols, row.data());
    std::uint8_t* o = out.ptr<std::uint8_t>(r);
    for (int c = 0; c < out.cols; ++c) o[c] = cv::saturate_cast<std::uint8_t>(row[static_cast<std::size_t>(c)]);
  }
}

// 16-bit raw: float, scaled to 8 bits by the caller once both strips are known.
template <typename Tap>
void resample_u16(const cv::Mat& raw, const std::vector<Tap>& taps, cv::Mat& out) {
  for (int r = 0; r < out.rows; ++r)
    resample_row<std::uint16_t>(raw, taps.data() + static_cast<std::size_t>(r) * out.cols, out.cols, out.ptr<float>(r));
}

}  // namespace

StereoGeometry::StereoGeometry(const StereoCalibration& calibration, StripRoi roi)
    : raw_size_(calibration.image_size), rectified_size_(calibration.image_size) {
  if (roi.rows == 0 && roi.row0 == 0) roi.rows = rectified_size_.height;
  if (roi.row0 < 0 || roi.rows <= 0 || roi.row0 + roi.rows > rectified_size_.height) {
    throw std::invalid_argument("strip rows " + std::to_string(roi.row0) + ".." + std::to_string(roi.row0 + roi.rows) +
                                " outside the rectified image of " + std::to_string(rectified_size_.height) + " rows");
  }
  roi_ = roi;
  alpha_ = choose_alpha(calibration, roi_);
  const Rectification r = stereo_rectify(calibration, alpha_);
  R1_ = cv::Matx33d(r.R1);
  R2_ = cv::Matx33d(r.R2);
  P1_ = cv::Matx34d(r.P1);
  P2_ = cv::Matx34d(r.P2);
  Q_ = cv::Matx44d(r.Q);
  focal_px_ = P1_(0, 0);
  baseline_mm_ = -P2_(0, 3) / P2_(0, 0);
  if (std::abs(P2_(1, 3)) > 1e-9 * std::abs(P2_(0, 3)) || !(baseline_mm_ > 0.0)) {
    throw std::invalid_argument(
        "the calibration is not a left/right pair: after rectification the right "
        "camera must lie at +X of the left one (T.x < 0)");
  }
  cv::Mat x, y;
  strip_maps(calibration.M1, calibration.D1, r.R1, r.P1, roi_, rectified_size_.width, CV_32FC1, x, y);
  left_taps_ = make_taps<SplineTap>(x, y, raw_size_);
  left_map_ = interleave(x, y);
  strip_maps(calibration.M2, calibration.D2, r.R2, r.P2, roi_, rectified_size_.width, CV_32FC1, x, y);
  right_taps_ = make_taps<SplineTap>(x, y, raw_size_);
  right_map_ = interleave(x, y);
}

double StereoGeometry::disparity_at(double z_mm) const {
  // Z = Q23 / (Q32 d + Q33)  =>  d = (Q23 / Z - Q33) / Q32
  return (Q_(2, 3) / z_mm - Q_(3, 3)) / Q_(3, 2);
}

double StereoGeometry::distance_at(double disparity_px) const {
  return Q_(2, 3) / (Q_(3, 2) * disparity_px + Q_(3, 3));
}

void StereoGeometry::rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_strip,
                             cv::Mat& right_strip) const {
  const int type = left_raw.type();
  if (left_raw.size() != raw_size_ || right_raw.size() != raw_size_ || right_raw.type() != type ||
      (type != CV_8UC1 && type != CV_16UC1)) {
    throw std::invalid_argument("rectify: raw images must both be CV_8UC1 or CV_16UC1 of the calibration size");
  }
  const cv::Size strip(rectified_size_.width, roi_.rows);
  left_strip.create(strip, CV_8UC1);
  right_strip.create(strip, CV_8UC1);
  // Scratch per thread keeps this const method thread-safe and allocation-free after the first frame of
  // each thread.
  if (type == CV_8UC1) {
    thread_local std::vector<float> row;
    resample_u8(left_raw, left_taps_, left_strip, row);
    resample_u8(right_raw, right_taps_, right_strip, row);
    return;
  }
  thread_local cv::Mat left_f, right_f;
  left_f.create(strip, CV_32FC1);
  right_f.create(strip, CV_32FC1);
  resample_u16(left_raw, left_taps_, left_f);
  resample_u16(right_raw, right_taps_, right_f);
  double max_left = 0, max_right = 0;
  cv::minMaxLoc(left_f, nullptr, &max_left);
  cv::minMaxLoc(right_f, nullptr, &max_right);
  const double brightest = std::max(max_left, max_right);
  const double scale = brightest > 255.0 ? 255.0 / brightest : 1.0;
  left_f.convertTo(left_strip, CV_8U, scale);
  right_f.convertTo(right_strip, CV_8U, scale);
}

void StereoGeometry::reproject(const cv::Mat& disparity, cv::Mat& xyz) const {
  CV_Assert(disparity.type() == CV_32FC1);
  xyz.create(disparity.size(), CV_32FC3);
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  const cv::Matx44d& q = Q_;
  for (int r = 0; r < disparity.rows; ++r) {
    const float* d_row = disparity.ptr<float>(r);
    cv::Vec3f* out = xyz.ptr<cv::Vec3f>(r);
    const double y = roi_.row0 + r;
    for (int x = 0; x < disparity.cols; ++x) {
      const double d = d_row[x];
      const double w = q(3, 0) * x + q(3, 1) * y + q(3, 2) * d + q(3, 3);
      if (!std::isfinite(d) || d <= 0.0 || !(w > 0.0)) {
        out[x] = cv::Vec3f(kNaN, kNaN, kNaN);
        continue;
      }
      const double px = q(0, 0) * x + q(0, 1) * y + q(0, 2) * d + q(0, 3);
      const double py = q(1, 0) * x + q(1, 1) * y + q(1, 2) * d + q(1, 3);
      const double pz = q(2, 0) * x + q(2, 1) * y + q(2, 2) * d + q(2, 3);
      out[x] = cv::Vec3f(static_cast<float>(px / w), static_cast<float>(py / w), static_cast<float>(pz / w));
    }
  }
}

}  // namespace rutd
