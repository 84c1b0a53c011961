#pragma once
// The CPU disparity engines: OpenCV StereoBM and StereoSGBM behind DisparityEngine. Each object owns its
// OpenCV matcher and a 16-bit scratch disparity, reused between frames; one per thread.
#include <opencv2/calib3d.hpp>

#include "engines/disparity_engine.hpp"

namespace rutd {

class OpenCvBmEngine final : public DisparityEngine {
 public:
  explicit OpenCvBmEngine(const EngineConfig& params);
  EngineKind kind() const override { return EngineKind::Bm; }
  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override;

 private:
  int block_size_;
  cv::Ptr<cv::StereoBM> matcher_;
  cv::Mat fixed_point_;  // CV_16S, disparity * 16
};

// kind: Sgbm, Sgbm3Way, Hh4 or Hh.
class OpenCvSgbmEngine final : public DisparityEngine {
 public:
  OpenCvSgbmEngine(EngineKind kind, const EngineConfig& params);
  EngineKind kind() const override { return kind_; }
  void compute(const cv::Mat& left, const cv::Mat& right, DisparityBand band, cv::Mat& disparity) override;

 private:
  EngineKind kind_;
  cv::Ptr<cv::StereoSGBM> matcher_;
  cv::Mat fixed_point_;  // CV_16S, disparity * 16
};

// CV_16S disparity * 16 (OpenCV's output) to CV_32F px; values below min_disparity (OpenCV marks
// invalid pixels with (min_disparity - 1) * 16) become NaN. Reuses `disparity`.
void fixed_point_to_float(const cv::Mat& fixed_point, int min_disparity, cv::Mat& disparity);

}  // namespace rutd
