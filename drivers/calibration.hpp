#pragma once
// The stereo calibration file (DESIGN.md, Formats): an OpenCV FileStorage YAML file as OpenCV's own
// stereo calibration writes it. The data type lives in drivers/ because sources (the synthetic renderer,
// recordings, cameras) produce it; the geometry computed from it lives in pipeline/stereo_geometry.hpp.
#include <string>
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

// Reads and checks a calibration file. Throws InputError naming the file and the key for: unreadable
// file, missing key, wrong matrix shape or type, non-finite value, non-positive focal length or image
// size, R not a rotation, zero baseline.
StereoCalibration load_calibration(const std::string& path);

// Writes the file in the same format (readable by load_calibration and by OpenCV's FileStorage).
// Throws InputError if the file cannot be written.
void save_calibration(const std::string& path, const StereoCalibration& calibration);

// Throws InputError(file, "image_width"/"image_height", ...) when a frame of `frame_size` read from
// `frame_file` does not match the calibration.
void check_frame_size(const StereoCalibration& calibration, cv::Size frame_size,
                      const std::string& frame_file);

}  // namespace rutd
