#include "opencv_engines.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace rutd {
namespace {

int or_default(int value, int fallback) { return value < 0 ? fallback : value; }

// EngineConfig::disp12_max_diff: -1 = default 1, -2 = off (OpenCV switches it off for negative values).
int disp12(int value) { return value == -1 ? 1 : (value < -1 ? -1 : value); }

void check_block_size(int block_size, int min_size) {
  if (block_size < min_size || block_size % 2 == 0) {
    throw std::invalid_argument("disparity engine: block_size must be odd and >= " + std::to_string(min_size) +
                                ", got " + std::to_string(block_size));
  }
}

void check_inputs(const cv::Mat& left, const cv::Mat& right, DisparityBand band) {
  CV_Assert(left.type() == CV_8UC1 && right.type() == CV_8UC1 && left.size() == right.size());
  CV_Assert(band.num_disparities > 0 && band.num_disparities % 16 == 0);
}

int sgbm_mode(EngineKind kind) {
  switch (kind) {
    case EngineKind::Sgbm: return cv::StereoSGBM::MODE_SGBM;
    case EngineKind::Sgbm3Way: return cv::StereoSGBM::MODE_SGBM_3WAY;
    case EngineKind::Hh4: return cv::StereoSGBM::MODE_HH4;
    case EngineKind::Hh: return cv::StereoSGBM::MODE_HH;
    case EngineKind::Bm:
    case EngineKind::Gpu:
    case EngineKind::SgmRef: break;
  }
  throw std::invalid_argument("OpenCvSgbmEngine: not an SGBM mode");
}

}  // namespace

void fixed_point_to_float(const cv::Mat& fixed_point, int min_disparity, cv::Mat& disparity) {
  CV_Assert(fixed_point.type() == CV_16SC1);
  disparity.create(fixed_point.size(), CV_32FC1);
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  const int invalid_below = min_disparity * 16;
  for (int r = 0; r < fixed_point.rows; ++r) {
    const short* in = fixed_point.ptr<short>(r);
    float* out = disparity.ptr<float>(r);
    for (int x = 0; x < fixed_point.cols; ++x) {
      out[x] = in[x] < invalid_below ? kNaN : static_cast<float>(in[x]) * (1.0f / 16.0f);
    }
  }
}

OpenCvBmEngine::OpenCvBmEngine(const EngineConfig& params)
    : block_size_(params.block_size == 0 ? 15 : params.block_size) {
  check_block_size(block_size_, 5);
  matcher_ = cv::StereoBM::create(16, block_size_);
  matcher_->setUniquenessRatio(or_default(params.uniqueness_ratio, 15));
  matcher_->setSpeckleWindowSize(or_default(params.speckle_window, 100));
  matcher_->setSpeckleRange(or_default(params.speckle_range, 2));
  matcher_->setDisp12MaxDiff(disp12(params.disp12_max_diff));
  matcher_->setPreFilterCap(or_default(params.pre_filter_cap, 31));
  matcher_->setTextureThreshold(or_default(params.texture_threshold, 10));
}

void OpenCvBmEngine::compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) {
  check_inputs(left, right, band);
  // StereoBM needs the block inside the strip: shrink it (odd, >= 5) for very thin strips.
  int block = std::min(block_size_, std::min(left.rows, left.cols) | 1);
  if (block > std::min(left.rows, left.cols)) block -= 2;
  matcher_->setBlockSize(std::max(block, 5));
  matcher_->setMinDisparity(band.min_disparity);
  matcher_->setNumDisparities(band.num_disparities);
  matcher_->compute(left, right, fixed_point_);
  fixed_point_to_float(fixed_point_, band.min_disparity, disparity);
}

OpenCvSgbmEngine::OpenCvSgbmEngine(EngineKind kind, const EngineConfig& params) : kind_(kind) {
  const int mode = sgbm_mode(kind);
  const int block = params.block_size == 0 ? 5 : params.block_size;
  check_block_size(block, 1);
  const int p1 = or_default(params.p1, 8 * block * block);
  const int p2 = or_default(params.p2, 32 * block * block);
  if (p2 <= p1) throw std::invalid_argument("disparity engine: p2 must be greater than p1");
  matcher_ = cv::StereoSGBM::create(0, 16, block, p1, p2, disp12(params.disp12_max_diff),
                                    or_default(params.pre_filter_cap, 63), or_default(params.uniqueness_ratio, 10),
                                    or_default(params.speckle_window, 100), or_default(params.speckle_range, 2), mode);
}

void OpenCvSgbmEngine::compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) {
  check_inputs(left, right, band);
  matcher_->setMinDisparity(band.min_disparity);
  matcher_->setNumDisparities(band.num_disparities);
  matcher_->compute(left, right, fixed_point_);
  fixed_point_to_float(fixed_point_, band.min_disparity, disparity);
}

}  // namespace rutd
