#pragma once
// A calibrated stereo rig (DESIGN.md, Formats): what every frame source produces and the pipeline's
// geometry (geometry/stereo_geometry.hpp) is computed from; and the rectification computed from it. Reading and writing
// the calibration file is recording/calibration_file.hpp's business.
#include <opencv2/core.hpp>

namespace rutd {

struct StereoCalibration {
  cv::Size image_size;  // image_width x image_height of the raw frames, pixels
  cv::Matx33d M1;       // left camera matrix, pixels
  cv::Mat D1;           // left distortion, 1xN CV_64F, N in {4, 5, 8, 12, 14} (OpenCV order)
  cv::Matx33d M2;       // right camera matrix, pixels
  cv::Mat D2;           // right distortion, as D1
  cv::Matx33d R;        // rotation left -> right: X_right = R X_left + T
  cv::Vec3d T;          // translation left -> right, millimetres
};

// How the measurer rectifies the rig (cv::stereoRectify's outputs for the free scaling it chose), as plain
// data: what a sink needs to draw on rectified images, or to find a rectified point in a raw one, without
// the pipeline. The daemon fills it from the measurer's geometry (StereoGeometry::rectification()).
struct StereoRectification {
  cv::Size rectified_size;  // pixels; the raw image size (CALIB_ZERO_DISPARITY keeps it)
  cv::Matx33d R1, R2;       // left/right camera frame -> its rectified frame
  cv::Matx34d P1, P2;       // left/right rectified projection, pixels (full image rows)
  cv::Matx44d Q;            // [x y d 1] (rectified left pixel, disparity) -> homogeneous mm
};

}  // namespace rutd
