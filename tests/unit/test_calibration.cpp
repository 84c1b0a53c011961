// Calibration file: the real stereo_calib text loads, every bad input gives one error naming the file
// and the key, save -> load round-trips exactly, and OpenCV's own FileStorage reads what we write.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/input_error.hpp"
#include "recording/calibration_file.hpp"

namespace rutd {
namespace {

namespace fs = std::filesystem;

// What OpenCV's stereo_calib sample writes (intrinsics and extrinsics in one file, with the image size),
// including the rectification keys it adds, which the loader ignores. T in millimetres.
const std::vector<std::pair<std::string, std::string>> kStereoCalibBlocks = {
    {"image_width", "image_width: 1280\n"},
    {"image_height", "image_height: 960\n"},
    {"M1",
     "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [ 1.4102597656250000e+03, 0., 6.3748529052734375e+02, 0.,\n"
     "       1.4098811035156250e+03, 4.7901055908203125e+02, 0., 0., 1. ]\n"},
    {"D1",
     "D1: !!opencv-matrix\n   rows: 1\n   cols: 8\n   dt: d\n"
     "   data: [ -1.0582470119887934e-01, 1.4328541532973640e-01,\n"
     "       3.6217491432085283e-04, -5.2712019811216093e-04, 0., 0., 0.,\n"
     "       1.7790263373544458e-01 ]\n"},
    {"M2",
     "M2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [ 1.4102597656250000e+03, 0., 6.4512408447265625e+02, 0.,\n"
     "       1.4098811035156250e+03, 4.8300262451171875e+02, 0., 0., 1. ]\n"},
    {"D2",
     "D2: !!opencv-matrix\n   rows: 1\n   cols: 8\n   dt: d\n"
     "   data: [ -9.8723055019617200e-02, 1.0265208035707474e-01,\n"
     "       -2.3458210751414299e-04, 8.0314651131629944e-04, 0., 0., 0.,\n"
     "       1.1850216984748840e-01 ]\n"},
    {"R",
     "R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [ 9.9991155150319744e-01, -2.3339812449514196e-03,\n"
     "       -1.3093574837169792e-02, 2.2658624026429147e-03,\n"
     "       9.9998383527472234e-01, -5.2148879977743628e-03,\n"
     "       1.3105534633910981e-02, 5.1847585098302174e-03,\n"
     "       9.9990067668801685e-01 ]\n"},
    {"T",
     "T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n"
     "   data: [ -1.2003475189208984e+02, 3.1254032254219055e-01,\n"
     "       1.2087503671646118e+00 ]\n"},
    {"R1",
     "R1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
     "   data: [ 9.9987, -0.0028, -0.0159, 0.0029, 0.99999, 0.0042, 0.0159, -0.0042, 0.99986 ]\n"},
    {"Q",
     "Q: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
     "   data: [ 1., 0., 0., -6.4e+02, 0., 1., 0., -4.8e+02, 0., 0., 0., 1.41e+03, 0., 0., 8.3e-03, 0. ]\n"},
};

// The fixture text with some keys' blocks replaced (a key is removed when its block is empty).
std::string stereo_calib_text(const std::map<std::string, std::string>& replaced = {}) {
  std::string text = "%YAML:1.0\n---\n";
  for (const auto& [name, original] : kStereoCalibBlocks) {
    const auto it = replaced.find(name);
    text += it == replaced.end() ? original : it->second;
  }
  return text;
}

std::string stereo_calib_text(const std::string& key, const std::string& block) {
  return stereo_calib_text(std::map<std::string, std::string>{{key, block}});
}

std::string matrix_block(const std::string& key, int rows, int cols, const std::string& data) {
  return key + ": !!opencv-matrix\n   rows: " + std::to_string(rows) + "\n   cols: " + std::to_string(cols) +
         "\n   dt: d\n   data: [ " + data + " ]\n";
}

class CalibrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rutd_calibration_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& text, const std::string& name = "calibration.yaml") {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // Loads `text` and returns the InputError it must raise.
  InputError load_error(const std::string& text) {
    const std::string path = write(text);
    try {
      load_calibration(path);
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      return e;
    }
    ADD_FAILURE() << "no InputError for:\n" << text;
    return InputError(path, "", "");
  }

  fs::path dir_;
};

TEST_F(CalibrationTest, LoadsStereoCalibSampleOutput) {
  const StereoCalibration c = load_calibration(write(stereo_calib_text()));
  EXPECT_EQ(c.image_size, cv::Size(1280, 960));
  EXPECT_DOUBLE_EQ(c.M1(0, 0), 1.4102597656250000e+03);
  EXPECT_DOUBLE_EQ(c.M1(0, 2), 6.3748529052734375e+02);
  EXPECT_DOUBLE_EQ(c.M2(1, 2), 4.8300262451171875e+02);
  EXPECT_DOUBLE_EQ(c.M1(2, 2), 1.0);
  ASSERT_EQ(c.D1.size(), cv::Size(8, 1));
  EXPECT_EQ(c.D1.type(), CV_64F);
  EXPECT_DOUBLE_EQ(c.D1.at<double>(7), 1.7790263373544458e-01);
  EXPECT_DOUBLE_EQ(c.D2.at<double>(0), -9.8723055019617200e-02);
  EXPECT_DOUBLE_EQ(c.R(1, 2), -5.2148879977743628e-03);
  EXPECT_DOUBLE_EQ(c.T[0], -1.2003475189208984e+02);
  EXPECT_NEAR(cv::norm(c.T), 120.041, 1e-3);  // baseline in mm
}

TEST_F(CalibrationTest, AcceptsColumnDistortionAndRodriguesRotation) {
  const std::string text = stereo_calib_text({{"D2", matrix_block("D2", 5, 1, "-0.1, 0.02, 0.001, -0.002, 0.003")},
                                              {"R", matrix_block("R", 3, 1, "0.0052, -0.0131, 0.0023")}});
  const StereoCalibration c = load_calibration(write(text));
  const cv::Vec3d rodrigues(0.0052, -0.0131, 0.0023);
  ASSERT_EQ(c.D2.size(), cv::Size(5, 1));
  EXPECT_DOUBLE_EQ(c.D2.at<double>(4), 0.003);
  cv::Matx33d expected;
  cv::Rodrigues(rodrigues, expected);
  EXPECT_LT(cv::norm(c.R - expected), 1e-12);
  // The fixture's 3x3 R was computed from the same Rodrigues vector.
  const StereoCalibration original = load_calibration(write(stereo_calib_text(), "original.yaml"));
  EXPECT_LT(cv::norm(c.R - original.R), 1e-12);
}

TEST_F(CalibrationTest, MissingFileNamesTheFile) {
  const std::string path = (dir_ / "nope.yaml").string();
  try {
    load_calibration(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.field(), "file");
    EXPECT_EQ(std::string(e.what()), path + ": file: cannot open: No such file or directory");
  }
}

TEST_F(CalibrationTest, FolderInsteadOfFile) {
  try {
    load_calibration(dir_.string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), dir_.string() + ": file: is a folder, not a file");
  }
}

struct BadCase {
  std::string name;
  std::string text;
  std::string field;
  std::string message;  // must appear in what()
};

std::vector<BadCase> bad_cases() {
  std::vector<BadCase> cases = {
      {"empty", "", "file", "file is empty"},
      {"plain_text", "hello world\n", "file", "not an OpenCV FileStorage file"},
      {"broken_yaml", "%YAML:1.0\n---\nimage_width: 1280\nM1: [ 1, 2\n", "line 5",
       "end of sequence flow not found (not a valid OpenCV FileStorage YAML file)"},
      // Found by fuzzing: OpenCV 4.6's own YAML reader loops forever on the first and throws
      // std::length_error on the second (an empty key); the file is now read with yaml-cpp.
      {"opencv_reader_loops", "%YAML:1.0\n   t:d\n1, -\n ", "file", "not an OpenCV FileStorage file"},
      {"opencv_reader_length_error", "%YAML:1.0\n   t:d\n   :", "line 3", "illegal map value"},
      {"matrix_without_rows", stereo_calib_text("M1", "M1: !!opencv-matrix\n   cols: 3\n   dt: d\n   data: [ 1. ]\n"),
       "M1", "'rows' must be a positive integer"},
      {"matrix_without_data", stereo_calib_text("M1", "M1: !!opencv-matrix\n   rows: 1\n   cols: 1\n   dt: d\n"), "M1",
       "'data' must be a sequence of numbers"},
      {"key_is_a_list", "%YAML:1.0\n? [image_width]\n: 1280\n", "image_width", "missing"},
      {"width_text", stereo_calib_text("image_width", "image_width: wide\n"), "image_width",
       "expected an integer, found the string 'wide'"},
      {"width_real", stereo_calib_text("image_width", "image_width: 1280.5\n"), "image_width", "expected an integer"},
      {"height_zero", stereo_calib_text("image_height", "image_height: 0\n"), "image_height",
       "must be positive, found 0"},
      {"width_negative", stereo_calib_text("image_width", "image_width: -1280\n"), "image_width",
       "must be positive, found -1280"},
      {"m1_shape", stereo_calib_text("M1", matrix_block("M1", 2, 3, "1, 0, 2, 0, 1, 3")), "M1",
       "expected a 3x3 matrix, found 2x3"},
      {"m1_scalar", stereo_calib_text("M1", "M1: 1410.0\n"), "M1", "expected a matrix (!!opencv-matrix)"},
      {"m2_text_element",
       stereo_calib_text("M2", matrix_block("M2", 3, 3, "1410., abc, 645., 0., 1410., 483., 0., 0., 1.")), "M2",
       "element 1 is not a number: the string 'abc'"},
      {"m1_nan", stereo_calib_text("M1", matrix_block("M1", 3, 3, "1410., 0., .nan, 0., 1410., 483., 0., 0., 1.")),
       "M1", "element 2 is not finite"},
      {"d2_inf", stereo_calib_text("D2", matrix_block("D2", 1, 5, "0.1, -.inf, 0., 0., 0.")), "D2",
       "element 1 is not finite"},
      {"data_count", stereo_calib_text("M1", matrix_block("M1", 3, 3, "1410., 0., 640., 0., 1410., 480.")), "M1",
       "data holds 6 values but rows x cols is 3x3"},
      {"focal_negative",
       stereo_calib_text("M1", matrix_block("M1", 3, 3, "-1410., 0., 640., 0., 1410., 480., 0., 0., 1.")), "M1",
       "focal length must be positive, found fx = -1410, fy = 1410"},
      {"focal_zero", stereo_calib_text("M2", matrix_block("M2", 3, 3, "1410., 0., 640., 0., 0., 480., 0., 0., 1.")),
       "M2", "focal length must be positive"},
      {"not_camera_matrix",
       stereo_calib_text("M1", matrix_block("M1", 3, 3, "1410., 0., 640., 0., 1410., 480., 0., 0., 2.")), "M1",
       "not a camera matrix"},
      {"principal_point_far",
       stereo_calib_text("M2", matrix_block("M2", 3, 3, "1410., 0., 5000., 0., 1410., 480., 0., 0., 1.")), "M2",
       "principal point (5000, 480) is far outside the 1280x960 image"},
      {"d1_length", stereo_calib_text("D1", matrix_block("D1", 1, 6, "0.1, 0.1, 0., 0., 0., 0.")), "D1",
       "N in 4, 5, 8, 12, 14, found 1x6"},
      {"d1_2d", stereo_calib_text("D1", matrix_block("D1", 2, 4, "0.1, 0.1, 0., 0., 0., 0., 0., 0.")), "D1",
       "found 2x4"},
      {"r_shape", stereo_calib_text("R", matrix_block("R", 3, 2, "1., 0., 0., 1., 0., 0.")), "R",
       "expected a 3x3 rotation matrix or a 3x1 Rodrigues vector, found 3x2"},
      {"r_scaled", stereo_calib_text("R", matrix_block("R", 3, 3, "1.1, 0., 0., 0., 1.1, 0., 0., 0., 1.1")), "R",
       "not a rotation matrix: R^T R differs from the identity by 0.21"},
      {"r_reflection", stereo_calib_text("R", matrix_block("R", 3, 3, "1., 0., 0., 0., 1., 0., 0., 0., -1.")), "R",
       "determinant is -1 (a reflection, not a rotation)"},
      {"t_shape", stereo_calib_text("T", matrix_block("T", 2, 1, "-120., 0.3")), "T",
       "expected a 3x1 or 1x3 translation, found 2x1"},
      {"t_zero", stereo_calib_text("T", matrix_block("T", 3, 1, "0., 0., 0.")), "T", "zero baseline"},
      {"t_metres", stereo_calib_text("T", matrix_block("T", 3, 1, "-0.12, 0.0003, 0.0012")), "T",
       "T must be in millimetres"},
      {"bad_dt",
       stereo_calib_text("R", "R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: q\n   data: [ 1., 0., 0. ]\n"), "R",
       "'dt' must be a single-channel element type"},
  };
  for (const auto& [key, block] : kStereoCalibBlocks) {
    if (key == "R1" || key == "Q") continue;  // optional keys
    cases.push_back({"missing_" + key, stereo_calib_text(key, ""), key, "missing"});
  }
  return cases;
}

TEST_F(CalibrationTest, EveryBadInputNamesFileAndKey) {
  for (const BadCase& c : bad_cases()) {
    SCOPED_TRACE(c.name);
    const InputError e = load_error(c.text);
    EXPECT_EQ(e.field(), c.field);
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(e.file() + ": " + c.field + ": ", 0), 0u) << what;
    EXPECT_NE(what.find(c.message), std::string::npos) << what;
  }
}

StereoCalibration random_calibration(std::mt19937& rng, int distortion_length) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  StereoCalibration c;
  c.image_size = {1936, 1216};
  c.M1 = {1800 + 100 * u(rng), 0, 968 + 20 * u(rng), 0, 1800 + 100 * u(rng), 608 + 20 * u(rng), 0, 0, 1};
  c.M2 = {1800 + 100 * u(rng), 0.01 * u(rng), 968 + 20 * u(rng), 0, 1800 + 100 * u(rng), 608 + 20 * u(rng), 0, 0, 1};
  c.D1 = cv::Mat(1, distortion_length, CV_64F);
  c.D2 = cv::Mat(1, distortion_length, CV_64F);
  for (int i = 0; i < distortion_length; ++i) {
    c.D1.at<double>(i) = 0.1 * u(rng);
    c.D2.at<double>(i) = 0.1 * u(rng);
  }
  cv::Rodrigues(cv::Vec3d(0.05 * u(rng), 0.05 * u(rng), 0.05 * u(rng)), c.R);
  c.T = {-150 + 10 * u(rng), u(rng), u(rng)};
  return c;
}

void expect_same(const StereoCalibration& a, const StereoCalibration& b) {
  EXPECT_EQ(a.image_size, b.image_size);
  EXPECT_EQ(cv::norm(a.M1 - b.M1, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.M2 - b.M2, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.R - b.R, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.T - b.T, cv::NORM_INF), 0.0);
  ASSERT_EQ(a.D1.size(), b.D1.size());
  ASSERT_EQ(a.D2.size(), b.D2.size());
  EXPECT_EQ(cv::norm(a.D1, b.D1, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.D2, b.D2, cv::NORM_INF), 0.0);
}

TEST_F(CalibrationTest, SaveThenLoadIsBitExact) {
  std::mt19937 rng(7);
  for (int n : {4, 5, 8, 12, 14}) {
    SCOPED_TRACE(n);
    const StereoCalibration original = random_calibration(rng, n);
    const std::string path = (dir_ / ("cal" + std::to_string(n) + ".yaml")).string();
    save_calibration(path, original);
    expect_same(load_calibration(path), original);
    EXPECT_FALSE(fs::exists(path + ".tmp"));
  }
}

TEST_F(CalibrationTest, OpenCvReadsWhatWeWrite) {
  std::mt19937 rng(11);
  const StereoCalibration original = random_calibration(rng, 5);
  const std::string path = (dir_ / "cal.yaml").string();
  save_calibration(path, original);

  cv::FileStorage storage(path, cv::FileStorage::READ);
  ASSERT_TRUE(storage.isOpened());
  EXPECT_EQ(static_cast<int>(storage["image_width"]), 1936);
  EXPECT_EQ(static_cast<int>(storage["image_height"]), 1216);
  cv::Mat m1, d1, m2, d2, r, t;
  storage["M1"] >> m1;
  storage["D1"] >> d1;
  storage["M2"] >> m2;
  storage["D2"] >> d2;
  storage["R"] >> r;
  storage["T"] >> t;
  EXPECT_EQ(cv::norm(m1, cv::Mat(original.M1), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(m2, cv::Mat(original.M2), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(d1, original.D1, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(d2, original.D2, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(r, cv::Mat(original.R), cv::NORM_INF), 0.0);
  ASSERT_EQ(t.size(), cv::Size(1, 3));  // a 3x1 matrix, as stereoCalibrate returns it
  EXPECT_EQ(cv::norm(t, cv::Mat(original.T), cv::NORM_INF), 0.0);
  // The file starts like every OpenCV YAML file.
  std::ifstream in(path);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "%YAML:1.0");
}

TEST_F(CalibrationTest, SaveRefusesWhatLoadWouldRefuse) {
  std::mt19937 rng(3);
  StereoCalibration c = random_calibration(rng, 5);
  c.D2 = cv::Mat();
  const std::string path = (dir_ / "cal.yaml").string();
  try {
    save_calibration(path, c);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.field(), "D2");
  }
  EXPECT_FALSE(fs::exists(path));
  c = random_calibration(rng, 5);
  c.T = {0, 0, 0};
  EXPECT_THROW(save_calibration(path, c), InputError);
}

TEST_F(CalibrationTest, SaveIntoMissingFolderNamesTheFile) {
  std::mt19937 rng(5);
  const std::string path = (dir_ / "no_such_folder" / "cal.yaml").string();
  try {
    save_calibration(path, random_calibration(rng, 5));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.field(), "file");
    EXPECT_NE(std::string(e.what()).find("cannot write"), std::string::npos) << e.what();
  }
}

TEST_F(CalibrationTest, FrameSizeCheckNamesFrameAndDimension) {
  StereoCalibration c;
  c.image_size = {1280, 960};
  EXPECT_NO_THROW(check_frame_size(c, {1280, 960}, "left/00000001.png"));
  try {
    check_frame_size(c, {640, 960}, "left/00000001.png");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "left/00000001.png: image_width: frame is 640x960 but calibration says 1280x960");
  }
  try {
    check_frame_size(c, {1280, 480}, "right/00000002.png");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "right/00000002.png: image_height: frame is 1280x480 but calibration says 1280x960");
  }
}

}  // namespace
}  // namespace rutd
