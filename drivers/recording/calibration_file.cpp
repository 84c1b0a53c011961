// Calibration file reading, checking and writing (DESIGN.md, Formats).
//
// Matrices are parsed element by element, so that a bad file gets one
// message naming the key and the element instead of an OpenCV assertion. The same checks run before
// saving, so save_calibration never writes a file that load_calibration would refuse.
#include "recording/calibration_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <yaml-cpp/yaml.h>

#include "core/input_error.hpp"
#include "fd_write.hpp"

namespace rutd {
namespace {

// A principal point may sit off-centre, but not further than half an image outside the image.
constexpr double kPrincipalPointMargin = 0.5;
// R^T R may differ from I by this much per element (hand-typed files carry ~6 significant digits).
constexpr double kRotationTolerance = 1e-4;
// Below this the rig cannot triangulate; the usual cause is T written in metres instead of mm.
constexpr double kMinBaselineMm = 1.0;

// A scalar as the file's reader sees it: OpenCV's FileStorage types an unquoted scalar as an integer, a
// real or a string; a quoted one is always a string.
enum class ScalarKind { Integer, Real, String };

bool parse_whole(std::string_view text, long long& out) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), out);
  return error == std::errc() && end == text.data() + text.size() && !text.empty();
}

// Decimal or scientific notation (OpenCV writes "0." and "1.4102597656250000e+03"), or YAML's .nan/.inf.
bool parse_real(std::string_view text, double& out) {
  std::string_view body = text;
  const bool negative = !body.empty() && body.front() == '-';
  if (!body.empty() && (body.front() == '+' || body.front() == '-')) body.remove_prefix(1);
  if (body == ".nan" || body == ".NaN" || body == ".NAN") {
    out = std::numeric_limits<double>::quiet_NaN();
    return text == body;
  }
  if (body == ".inf" || body == ".Inf" || body == ".INF") {
    out = negative ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  if (body.empty() || body.front() == '+' || body.front() == '-') return false;
  const auto [end, error] = std::from_chars(text.data() + (text.size() - body.size()), text.data() + text.size(), out);
  if (error != std::errc() || end != text.data() + text.size()) return false;
  if (negative) out = -out;
  return true;
}

ScalarKind scalar_kind(const YAML::Node& node) {
  if (node.Tag() == "!") return ScalarKind::String;  // quoted
  long long integer = 0;
  double real = 0.0;
  if (parse_whole(node.Scalar(), integer)) return ScalarKind::Integer;
  if (parse_real(node.Scalar(), real)) return ScalarKind::Real;
  return ScalarKind::String;
}

std::string describe_node(const YAML::Node& node) {
  if (node.IsSequence()) return "a sequence";
  if (node.IsMap()) return "a map";
  if (!node.IsScalar()) return "an empty value";
  switch (scalar_kind(node)) {
    case ScalarKind::Integer: return "the integer " + node.Scalar();
    case ScalarKind::Real: return "the number " + node.Scalar();
    case ScalarKind::String: break;
  }
  return "the string '" + node.Scalar() + "'";
}

std::string format_number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "file", "is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "file", std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, "file", "read error");
  return text.str();
}

// The file is read with yaml-cpp, not with OpenCV's FileStorage: OpenCV 4.6's YAML reader hangs in an
// endless loop on some malformed files (e.g. "%YAML:1.0\n   t:d\n1, -\n ") and throws std::length_error
// on others, both found by fuzzing (tests/fuzz/fuzz_calibration.cpp). The format stays OpenCV's: the
// "%YAML:1.0" line (an unknown directive to yaml-cpp, which skips it), !!opencv-matrix maps of rows,
// cols, dt and data, and OpenCV still writes the file (save_calibration) and reads it back in the tests.
YAML::Node open_yaml(const std::string& path, const std::string& text) {
  if (text.rfind("%YAML", 0) != 0) {
    throw InputError(path, "file", "not an OpenCV FileStorage file (expected '%YAML:1.0' and keys)");
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path, "line " + std::to_string(e.mark.line + 1),
                     e.msg + " (not a valid OpenCV FileStorage YAML file)");
  }
  if (!root.IsMap()) {
    throw InputError(path, "file", "not an OpenCV FileStorage file (expected '%YAML:1.0' and keys)");
  }
  return root;
}

// The value of `key` in a mapping, or an undefined node. Not map[key]: on a const node yaml-cpp returns
// an invalid node for a missing key, which throws YAML::InvalidNode on the next question (found by
// fuzzing), and it would compare keys that are lists or maps as text.
YAML::Node child(const YAML::Node& map, const std::string& key) {
  if (map.IsMap()) {
    for (const auto& kv : map) {
      if (kv.first.IsScalar() && kv.first.Scalar() == key) return kv.second;
    }
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

YAML::Node require(const YAML::Node& root, const std::string& path, const std::string& key) {
  const YAML::Node node = child(root, key);
  if (!node.IsDefined() || node.IsNull()) throw InputError(path, key, "missing");
  return node;
}

int read_integer(const YAML::Node& node, const std::string& what, const std::string& path, const std::string& key) {
  long long value = 0;
  if (!node.IsScalar() || scalar_kind(node) != ScalarKind::Integer || !parse_whole(node.Scalar(), value)) {
    throw InputError(path, key, what + "expected an integer, found " + describe_node(node));
  }
  if (value <= 0) throw InputError(path, key, what + "must be positive, found " + node.Scalar());
  if (value > std::numeric_limits<int>::max()) throw InputError(path, key, what + "is too large: " + node.Scalar());
  return static_cast<int>(value);
}

int read_image_dimension(const YAML::Node& root, const std::string& path, const std::string& key) {
  return read_integer(require(root, path, key), "", path, key);
}

double read_element(const YAML::Node& element, const std::string& path, const std::string& key, std::size_t index) {
  double value = 0.0;
  if (!element.IsScalar() || scalar_kind(element) == ScalarKind::String || !parse_real(element.Scalar(), value)) {
    throw InputError(path, key, "element " + std::to_string(index) + " is not a number: " + describe_node(element));
  }
  if (!std::isfinite(value)) {
    throw InputError(path, key, "element " + std::to_string(index) + " is not finite");
  }
  return value;
}

cv::Mat read_sequence(const YAML::Node& seq, int rows, int cols, const std::string& path, const std::string& key) {
  if (static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) != seq.size()) {
    throw InputError(path, key,
                     "data holds " + std::to_string(seq.size()) + " values but rows x cols is " + std::to_string(rows) +
                         "x" + std::to_string(cols));
  }
  cv::Mat values(rows, cols, CV_64F);
  std::size_t index = 0;
  for (auto it = seq.begin(); it != seq.end(); ++it, ++index) {
    values.at<double>(static_cast<int>(index)) = read_element(*it, path, key, index);
  }
  return values;
}

int read_matrix_size(const YAML::Node& matrix, const char* name, const std::string& path, const std::string& key) {
  const YAML::Node node = child(matrix, name);
  long long value = 0;
  if (!node.IsScalar() || scalar_kind(node) != ScalarKind::Integer || !parse_whole(node.Scalar(), value) ||
      value <= 0 || value > std::numeric_limits<int>::max()) {
    throw InputError(path, key, std::string("'") + name + "' must be a positive integer");
  }
  return static_cast<int>(value);
}

// Reads an !!opencv-matrix block, or a plain sequence of numbers as a 1xN matrix. Returns CV_64F.
cv::Mat read_matrix(const YAML::Node& root, const std::string& path, const std::string& key) {
  const YAML::Node node = require(root, path, key);
  if (node.IsSequence()) {
    if (node.size() == 0) throw InputError(path, key, "expected a matrix, found an empty sequence");
    return read_sequence(node, 1, static_cast<int>(node.size()), path, key);
  }
  if (!node.IsMap()) {
    throw InputError(path, key, "expected a matrix (!!opencv-matrix), found " + describe_node(node));
  }
  const int rows = read_matrix_size(node, "rows", path, key);
  const int cols = read_matrix_size(node, "cols", path, key);
  const YAML::Node dt = child(node, "dt");
  if (!dt.IsScalar() || dt.Scalar().size() != 1 || dt.Scalar().find_first_not_of("ucwsifd") != std::string::npos) {
    throw InputError(path, key, "'dt' must be a single-channel element type such as d");
  }
  const YAML::Node data = child(node, "data");
  if (!data.IsSequence()) throw InputError(path, key, "'data' must be a sequence of numbers");
  return read_sequence(data, rows, cols, path, key);
}

std::string shape_of(const cv::Mat& m) { return std::to_string(m.rows) + "x" + std::to_string(m.cols); }

void check_camera_matrix(const cv::Matx33d& m, cv::Size image_size, const std::string& path, const std::string& key) {
  if (!(m(0, 0) > 0.0) || !(m(1, 1) > 0.0)) {
    throw InputError(
        path, key,
        "focal length must be positive, found fx = " + format_number(m(0, 0)) + ", fy = " + format_number(m(1, 1)));
  }
  if (m(1, 0) != 0.0 || m(2, 0) != 0.0 || m(2, 1) != 0.0 || m(2, 2) != 1.0) {
    throw InputError(path, key, "not a camera matrix: expected [fx s cx; 0 fy cy; 0 0 1]");
  }
  const double cx = m(0, 2), cy = m(1, 2);
  const double w = image_size.width, h = image_size.height;
  const double mx = kPrincipalPointMargin * w, my = kPrincipalPointMargin * h;
  if (!(cx >= -mx && cx <= w + mx && cy >= -my && cy <= h + my)) {
    throw InputError(path, key,
                     "principal point (" + format_number(cx) + ", " + format_number(cy) + ") is far outside the " +
                         std::to_string(image_size.width) + "x" + std::to_string(image_size.height) + " image");
  }
}

void check_finite(const cv::Mat& m, const std::string& path, const std::string& key) {
  for (int i = 0; i < static_cast<int>(m.total()); ++i) {
    if (!std::isfinite(m.at<double>(i))) {
      throw InputError(path, key, "element " + std::to_string(i) + " is not finite");
    }
  }
}

cv::Matx33d to_matx33(const cv::Mat& m, const std::string& path, const std::string& key) {
  if (m.rows != 3 || m.cols != 3) throw InputError(path, key, "expected a 3x3 matrix, found " + shape_of(m));
  cv::Matx33d out;
  for (int i = 0; i < 9; ++i) out.val[i] = m.at<double>(i);
  return out;
}

bool is_distortion_length(int n) { return n == 4 || n == 5 || n == 8 || n == 12 || n == 14; }

// Returns the coefficients as a 1xN CV_64F row, the layout StereoCalibration promises.
cv::Mat check_distortion(const cv::Mat& d, const std::string& path, const std::string& key) {
  if (d.empty() || (d.rows != 1 && d.cols != 1) || !is_distortion_length(static_cast<int>(d.total()))) {
    throw InputError(path, key,
                     "expected 1xN or Nx1 distortion coefficients with N in 4, 5, 8, 12, 14, found " + shape_of(d));
  }
  cv::Mat row;
  d.reshape(1, 1).convertTo(row, CV_64F);
  check_finite(row, path, key);
  return row;
}

void check_rotation(const cv::Matx33d& r, const std::string& path) {
  const cv::Matx33d deviation = r.t() * r - cv::Matx33d::eye();
  double worst = 0.0;
  for (double v : deviation.val) worst = std::max(worst, std::abs(v));
  if (worst > kRotationTolerance) {
    throw InputError(path, "R", "not a rotation matrix: R^T R differs from the identity by " + format_number(worst));
  }
  const double det = cv::determinant(r);
  if (det < 0.0) {
    throw InputError(path, "R", "determinant is " + format_number(det) + " (a reflection, not a rotation)");
  }
}

cv::Matx33d read_rotation(const YAML::Node& root, const std::string& path) {
  const cv::Mat m = read_matrix(root, path, "R");
  if (m.total() == 3 && (m.rows == 1 || m.cols == 1)) {  // Rodrigues vector
    cv::Matx33d r;
    cv::Rodrigues(m.reshape(1, 3), r);
    return r;
  }
  if (m.rows != 3 || m.cols != 3) {
    throw InputError(path, "R", "expected a 3x3 rotation matrix or a 3x1 Rodrigues vector, found " + shape_of(m));
  }
  return to_matx33(m, path, "R");
}

void check_translation(const cv::Vec3d& t, const std::string& path) {
  const double baseline = cv::norm(t);
  if (baseline == 0.0) throw InputError(path, "T", "zero baseline: both cameras at the same place");
  if (baseline < kMinBaselineMm) {
    throw InputError(path, "T",
                     "baseline " + format_number(baseline) +
                         " mm is implausibly small: T must be in millimetres (was it written in metres?)");
  }
}

cv::Vec3d read_translation(const YAML::Node& root, const std::string& path) {
  const cv::Mat m = read_matrix(root, path, "T");
  if (m.total() != 3 || (m.rows != 1 && m.cols != 1)) {
    throw InputError(path, "T", "expected a 3x1 or 1x3 translation, found " + shape_of(m));
  }
  return {m.at<double>(0), m.at<double>(1), m.at<double>(2)};
}

void check_image_size(cv::Size size, const std::string& path) {
  if (size.width <= 0) throw InputError(path, "image_width", "must be positive");
  if (size.height <= 0) throw InputError(path, "image_height", "must be positive");
}

void check_matx_finite(const cv::Matx33d& m, const std::string& path, const std::string& key) {
  check_finite(cv::Mat(m), path, key);
}

// Everything load_calibration checks on values, shared with save_calibration.
void check_calibration(const StereoCalibration& c, const std::string& path) {
  check_image_size(c.image_size, path);
  check_matx_finite(c.M1, path, "M1");
  check_camera_matrix(c.M1, c.image_size, path, "M1");
  check_distortion(c.D1, path, "D1");
  check_matx_finite(c.M2, path, "M2");
  check_camera_matrix(c.M2, c.image_size, path, "M2");
  check_distortion(c.D2, path, "D2");
  check_matx_finite(c.R, path, "R");
  check_rotation(c.R, path);
  check_finite(cv::Mat(c.T), path, "T");
  check_translation(c.T, path);
}

// Makes the rename itself durable (best effort: some file systems refuse fsync on a folder).
void sync_parent_directory(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, std::max<std::size_t>(slash, 1));
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Writes through a synced temporary and a rename, so neither a crash nor a power loss leaves a
// half-written calibration.
void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw InputError(path, "file", std::string("cannot write: ") + std::strerror(errno));
  const bool written = fd_write_all(fd, text.data(), text.size()) && ::fsync(fd) == 0;
  int err = errno;
  ::close(fd);
  if (written && ::rename(tmp.c_str(), path.c_str()) == 0) {
    sync_parent_directory(path);
    return;
  }
  if (written) err = errno;
  ::unlink(tmp.c_str());
  throw InputError(path, "file", std::string("cannot write: ") + std::strerror(err));
}

}  // namespace

StereoCalibration load_calibration(const std::string& path) { return parse_calibration(read_text(path), path); }

StereoCalibration parse_calibration(const std::string& text, const std::string& path) {
  if (text.empty()) throw InputError(path, "file", "file is empty");
  const YAML::Node root = open_yaml(path, text);
  StereoCalibration c;
  c.image_size.width = read_image_dimension(root, path, "image_width");
  c.image_size.height = read_image_dimension(root, path, "image_height");
  c.M1 = to_matx33(read_matrix(root, path, "M1"), path, "M1");
  check_camera_matrix(c.M1, c.image_size, path, "M1");
  c.D1 = check_distortion(read_matrix(root, path, "D1"), path, "D1");
  c.M2 = to_matx33(read_matrix(root, path, "M2"), path, "M2");
  check_camera_matrix(c.M2, c.image_size, path, "M2");
  c.D2 = check_distortion(read_matrix(root, path, "D2"), path, "D2");
  c.R = read_rotation(root, path);
  check_rotation(c.R, path);
  c.T = read_translation(root, path);
  check_translation(c.T, path);
  return c;
}

void save_calibration(const std::string& path, const StereoCalibration& calibration) {
  check_calibration(calibration, path);
  cv::FileStorage storage(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  storage << "image_width" << calibration.image_size.width;
  storage << "image_height" << calibration.image_size.height;
  storage << "M1" << cv::Mat(calibration.M1) << "D1" << check_distortion(calibration.D1, path, "D1");
  storage << "M2" << cv::Mat(calibration.M2) << "D2" << check_distortion(calibration.D2, path, "D2");
  // A 3x1 Mat, not a Vec3d: OpenCV writes Vec3d as a plain sequence, stereo_calib writes a matrix.
  storage << "R" << cv::Mat(calibration.R) << "T" << cv::Mat(calibration.T);
  write_atomically(path, storage.releaseAndGetString());
}

void check_frame_size(const StereoCalibration& calibration, cv::Size frame_size, const std::string& frame_file) {
  if (frame_size == calibration.image_size) return;
  const std::string message = "frame is " + std::to_string(frame_size.width) + "x" + std::to_string(frame_size.height) +
                              " but calibration says " + std::to_string(calibration.image_size.width) + "x" +
                              std::to_string(calibration.image_size.height);
  const bool width_differs = frame_size.width != calibration.image_size.width;
  throw InputError(frame_file, width_differs ? "image_width" : "image_height", message);
}

}  // namespace rutd
