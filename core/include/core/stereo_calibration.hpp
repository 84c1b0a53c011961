#pragma once
// A calibrated stereo rig (DESIGN.md, Formats): what every frame source produces and the pipeline's
// geometry (pipeline/stereo_geometry.hpp) is computed from. Reading and writing the calibration file is
// recording/calibration_file.hpp's business.
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

}  // namespace rutd
