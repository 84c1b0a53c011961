#pragma once
// Stereo calibration from chessboard pairs (OpenCV's method): corners found in both views of each pair,
// each camera calibrated, then the pair refined jointly. Start-up/tool code: throws on bad input.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/stereo_calibration.hpp"

namespace rutd {

struct ChessboardSpec {
  cv::Size inner_corners{9, 6};  // inner corners per row and column
  double square_mm = 25.0;       // side of one square, mm: sets the unit of T
};

struct StereoCalibrationReport {
  StereoCalibration calibration;
  double rms_px = 0.0;                // stereoCalibrate's RMS reprojection error over both views
  double epipolar_rms_px = 0.0;       // RMS row difference of the corners after rectification
  std::vector<std::string> used;      // left image of each pair used
  std::vector<std::string> rejected;  // left image of each pair where the board was not found in both views
};

// left[i] and right[i] are one pair. Throws InputError naming the file for an unreadable image or a size
// different from the first image, and std::invalid_argument when fewer than 3 pairs show the board.
StereoCalibrationReport calibrate_stereo(const std::vector<std::string>& left, const std::vector<std::string>& right,
                                         const ChessboardSpec& board);

// Reads an OpenCV image list file (<imagelist> of alternating left/right names, as OpenCV's stereo_calib
// sample uses); names are relative to the list's folder. Throws InputError naming the file.
void read_image_list(const std::string& path, std::vector<std::string>& left, std::vector<std::string>& right);

}  // namespace rutd
