#pragma once
// The stereo calibration file (DESIGN.md, Formats): an OpenCV FileStorage YAML file as OpenCV's own
// stereo calibration writes it (image_width, image_height, M1, D1, M2, D2, R, T).
#include <string>

#include <opencv2/core.hpp>

#include "core/stereo_calibration.hpp"

namespace rutd {

// Reads and checks a calibration file. Throws InputError naming the file and the key for: unreadable
// file, missing key, wrong matrix shape or type, non-finite value, non-positive focal length or image
// size, R not a rotation, zero baseline.
StereoCalibration load_calibration(const std::string& path);
// The same checks on the file's text, already read; `path` names the file in messages.
StereoCalibration parse_calibration(const std::string& text, const std::string& path);

// Writes the file in the same format (readable by load_calibration and by OpenCV's FileStorage).
// Throws InputError if the file cannot be written.
void save_calibration(const std::string& path, const StereoCalibration& calibration);

// Throws InputError(file, "image_width"/"image_height", ...) when a frame of `frame_size` read from
// `frame_file` does not match the calibration.
void check_frame_size(const StereoCalibration& calibration, cv::Size frame_size, const std::string& frame_file);

}  // namespace rutd
