#pragma once
// Stereo geometry of a calibrated rig (DESIGN.md §2 and §4): rectification of a horizontal strip of
// rows, the disparity <-> distance relation and reprojection of a disparity strip to 3D points.
//
// Conventions: the left camera is the reference. Disparity d = x_left - x_right in rectified pixels and
// is positive for points in front of the rig. 3D points are in the left RECTIFIED camera frame
// (X lateral, Y along travel, Z distance), millimetres.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/stereo_calibration.hpp"

namespace rutd {

// Rows of the RECTIFIED left image processed per frame; rows == 0 means the whole image.
struct StripRoi {
  int row0 = 0;
  int rows = 0;
};

// Immutable after construction; all const methods are thread-safe.
class StereoGeometry {
 public:
  // Runs cv::stereoRectify with CALIB_ZERO_DISPARITY. The free-scaling parameter alpha is the largest
  // one (least zoom, widest view) for which every pixel of the strip, in both rectified images, maps
  // inside its raw image, so no black border lands in the strip. Resampling tables cover the strip
  // rows only. Throws std::invalid_argument if the strip lies outside the rectified image or
  // the rig is not a left/right pair (right camera not to the right of the left one after rectification).
  // The strip is resampled at the maps' float positions with a cubic B-spline, not with OpenCV's
  // fixed-point remap (see rectify()); the taps and weights of every strip pixel are computed here.
  StereoGeometry(const StereoCalibration& calibration, StripRoi roi);

  cv::Size rectified_size() const { return rectified_size_; }
  StripRoi roi() const { return roi_; }                // resolved: rows > 0
  double alpha() const { return alpha_; }              // the stereoRectify free-scaling parameter chosen, 0..1
  double focal_px() const { return focal_px_; }        // rectified focal length, pixels
  double baseline_mm() const { return baseline_mm_; }  // distance between the rectified centres, mm
  const cv::Matx44d& Q() const { return Q_; }          // [x y d 1] (rectified left pixel) -> homogeneous mm
  const cv::Matx33d& R1() const { return R1_; }        // left camera frame -> left rectified frame
  const cv::Matx33d& R2() const { return R2_; }        // right camera frame -> right rectified frame
  const cv::Matx34d& P1() const { return P1_; }        // left rectified projection (full image rows)
  const cv::Matx34d& P2() const { return P2_; }        // right rectified projection (full image rows)
  // The above as plain data, for the sinks (core/stereo_calibration.hpp).
  StereoRectification rectification() const { return {rectified_size_, R1_, R2_, P1_, P2_, Q_}; }

  // Disparity (px) of a point at distance z_mm (> 0) along the rectified optical axis, and back.
  double disparity_at(double z_mm) const;
  double distance_at(double disparity_px) const;

  // Remaps the strip rows of both raw images (CV_8UC1 or CV_16UC1, size = calibration image size) into
  // CV_8UC1 strips of rectified width x roi().rows, resampled at exact (float) positions with a cubic
  // B-spline smoothing kernel (why: stereo_geometry.cpp, make_taps). 16-bit images are scaled to
  // 8 bits by one factor common to both strips, 255 / (brightest strip pixel), when that pixel exceeds
  // 255 (so 10/12/16-bit sensors all use the full 8-bit range); otherwise copied unscaled. Reuses the
  // output buffers when they already fit. Throws std::invalid_argument for a wrong size or type.
  void rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_strip, cv::Mat& right_strip) const;

  // The float maps rectify() resamples at, for engines that rectify on their own device: per strip pixel,
  // row-major, the raw x then y it samples (px). Size 2 x rectified width x roi().rows each.
  cv::Size raw_size() const { return raw_size_; }
  const std::vector<float>& left_map() const { return left_map_; }
  const std::vector<float>& right_map() const { return right_map_; }

  // Disparity strip (CV_32FC1 px, roi().rows x rectified width, NaN = invalid; row r is rectified row
  // roi().row0 + r) to CV_32FC3 points (mm, left rectified frame), NaN where the disparity is invalid
  // or not positive. Reuses `xyz` when it already fits.
  void reproject(const cv::Mat& disparity, cv::Mat& xyz) const;

 private:
  cv::Size raw_size_;
  cv::Size rectified_size_;
  StripRoi roi_;
  double alpha_ = 0.0;
  double focal_px_ = 0.0;
  double baseline_mm_ = 0.0;
  cv::Matx44d Q_;
  cv::Matx33d R1_, R2_;
  cv::Matx34d P1_, P2_;
  // Per strip pixel, row-major: the first column and row of the 4x4 raw block the cubic B-spline reads
  // (unclamped: pixels at the raw border clamp when they are resampled) and the kernel's weights
  // along x and y. Computed once from the float positions, so a frame costs the 16 taps alone.
  struct SplineTap {
    std::int32_t x = 0, y = 0;
    float wx[4] = {}, wy[4] = {};
  };
  std::vector<SplineTap> left_taps_, right_taps_;
  std::vector<float> left_map_, right_map_;
};

}  // namespace rutd
