#include "geometry/stereo_calibrate.hpp"

#include <filesystem>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/input_error.hpp"

namespace rutd {
namespace {

using Corners = std::vector<cv::Point2f>;

cv::Mat read_grey(const std::string& path, cv::Size& size) {
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw InputError(path, "image", "cannot read the image");
  if (size.area() == 0) size = img.size();
  if (img.size() != size)
    throw InputError(path, "image size",
                     "is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + ", the first image is " +
                         std::to_string(size.width) + "x" + std::to_string(size.height));
  return img;
}

bool find_corners(const cv::Mat& img, cv::Size pattern, Corners& corners) {
  if (!cv::findChessboardCorners(img, pattern, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return false;
  cv::cornerSubPix(img, corners, {11, 11}, {-1, -1},
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01));
  return true;
}

std::vector<cv::Point3f> board_points(const ChessboardSpec& board) {
  std::vector<cv::Point3f> pts;
  for (int r = 0; r < board.inner_corners.height; ++r)
    for (int c = 0; c < board.inner_corners.width; ++c)
      pts.emplace_back(static_cast<float>(c * board.square_mm), static_cast<float>(r * board.square_mm), 0.f);
  return pts;
}

// RMS of the row difference between matching corners after rectification: what the matcher relies on.
double epipolar_rms(const StereoCalibration& c, const std::vector<Corners>& left, const std::vector<Corners>& right) {
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(c.M1, c.D1, c.M2, c.D2, c.image_size, c.R, c.T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0);
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < left.size(); ++i) {
    Corners l, r;
    cv::undistortPoints(left[i], l, c.M1, c.D1, R1, P1);
    cv::undistortPoints(right[i], r, c.M2, c.D2, R2, P2);
    for (std::size_t k = 0; k < l.size(); ++k, ++n) sum += (l[k].y - r[k].y) * (l[k].y - r[k].y);
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

}  // namespace

StereoCalibrationReport calibrate_stereo(const std::vector<std::string>& left, const std::vector<std::string>& right,
                                         const ChessboardSpec& board) {
  if (left.size() != right.size()) throw std::invalid_argument("as many left as right images are needed");
  StereoCalibrationReport report;
  cv::Size size;
  std::vector<Corners> left_corners, right_corners;
  for (std::size_t i = 0; i < left.size(); ++i) {
    const cv::Mat l = read_grey(left[i], size), r = read_grey(right[i], size);
    Corners cl, cr;
    if (find_corners(l, board.inner_corners, cl) && find_corners(r, board.inner_corners, cr)) {
      left_corners.push_back(std::move(cl));
      right_corners.push_back(std::move(cr));
      report.used.push_back(left[i]);
    } else {
      report.rejected.push_back(left[i]);
    }
  }
  if (left_corners.size() < 3)
    throw std::invalid_argument("the chessboard was found in both views of only " +
                                std::to_string(left_corners.size()) + " pairs; at least 3 are needed");

  const std::vector<std::vector<cv::Point3f>> object(left_corners.size(), board_points(board));
  StereoCalibration& c = report.calibration;
  c.image_size = size;
  cv::Mat M1, D1, M2, D2, rv, tv;
  // Each camera alone first (k3 fixed: these lenses do not need it and it overfits a few views), then both
  // refined jointly from there.
  const int mono_flags = cv::CALIB_FIX_K3;
  cv::calibrateCamera(object, left_corners, size, M1, D1, rv, tv, mono_flags);
  cv::calibrateCamera(object, right_corners, size, M2, D2, rv, tv, mono_flags);
  cv::Mat R, T, E, F;
  report.rms_px = cv::stereoCalibrate(object, left_corners, right_corners, M1, D1, M2, D2, size, R, T, E, F,
                                      cv::CALIB_USE_INTRINSIC_GUESS | mono_flags,
                                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
  c.M1 = cv::Matx33d(M1);
  c.M2 = cv::Matx33d(M2);
  c.D1 = D1.reshape(1, 1).clone();
  c.D2 = D2.reshape(1, 1).clone();
  c.R = cv::Matx33d(R);
  c.T = cv::Vec3d(T.at<double>(0), T.at<double>(1), T.at<double>(2));
  report.epipolar_rms_px = epipolar_rms(c, left_corners, right_corners);
  return report;
}

void read_image_list(const std::string& path, std::vector<std::string>& left, std::vector<std::string>& right) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw InputError(path, "imagelist", "not an OpenCV FileStorage file");
  }
  if (!fs.isOpened()) throw InputError(path, "imagelist", "cannot open the file");
  const cv::FileNode list = fs.getFirstTopLevelNode();
  if (list.type() != cv::FileNode::SEQ) throw InputError(path, "imagelist", "expected a sequence of image names");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<std::string> names;
  for (const auto& node : list) {
    if (!node.isString()) throw InputError(path, "imagelist", "every entry must be an image file name");
    names.push_back((folder / static_cast<std::string>(node)).string());
  }
  if (names.size() % 2 != 0)
    throw InputError(path, "imagelist", "expected alternating left and right images, got an odd count");
  for (std::size_t i = 0; i < names.size(); i += 2) {
    left.push_back(names[i]);
    right.push_back(names[i + 1]);
  }
}

}  // namespace rutd
