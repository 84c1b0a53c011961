// libFuzzer target: the recording reader (ReplaySource): frames.csv and the image files it lists. The
// input is frames.csv's bytes, then a NUL byte, then the bytes of the image file left/f.png and
// right/f.png (any bytes: a PNG, a cut-off PNG, another format, garbage). The folder also holds a good
// calibration.yaml (64x64) and a good 64x64 pair left/ok.png, right/ok.png that lines may list. The
// reader is driven as replay drives it, to the end of the stream; every Error's message must be one
// line "FOLDER/frames.csv: line N: ..." and a refused folder an InputError naming a file in it.
#include <stdlib.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fuzz_check.hpp"
#include "recording/calibration_file.hpp"
#include "recording/recording.hpp"

namespace {

// Bounds the work per input: a frames.csv of many good lines is no more interesting than one of 64.
constexpr int kMaxPairs = 64;

std::string g_folder;  // removed at exit (libFuzzer ends with exit() after -runs or -max_total_time)

void write_file(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    std::abort();
  }
}

std::string make_folder() {
  const char* tmp = std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
  std::string pattern = std::string(tmp) + "/rutd-fuzz-replay-XXXXXX";
  if (!mkdtemp(pattern.data())) std::abort();
  const std::string dir = pattern;
  g_folder = dir;
  std::atexit([] { std::filesystem::remove_all(g_folder); });
  std::filesystem::create_directory(dir + "/left");
  std::filesystem::create_directory(dir + "/right");
  rutd::StereoCalibration c;
  c.image_size = {64, 64};
  c.M1 = c.M2 = cv::Matx33d(60, 0, 32, 0, 60, 32, 0, 0, 1);
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Matx33d::eye();
  c.T = cv::Vec3d(-100, 0, 0);
  rutd::save_calibration(dir + "/calibration.yaml", c);
  cv::Mat image(64, 64, CV_8UC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(x * 4 + y);
  cv::imwrite(dir + "/left/ok.png", image);
  cv::imwrite(dir + "/right/ok.png", image);
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string dir = make_folder();
  static const std::string frames = dir + "/frames.csv";
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t nul = input.find('\0');
  write_file(frames, input.substr(0, nul));
  const std::string_view image = nul == std::string_view::npos ? std::string_view() : input.substr(nul + 1);
  write_file(dir + "/left/f.png", image);
  write_file(dir + "/right/f.png", image);

  try {
    rutd::ReplaySource source(dir);
    rutd::StereoFrame frame;
    int pairs = 0;
    for (int calls = 0; calls < 4 * kMaxPairs && pairs < kMaxPairs; ++calls) {
      const rutd::SourceStatus status = source.next(frame);
      if (status == rutd::SourceStatus::EndOfStream) {
        if (source.truncated_tail()) rutd::fuzz::check_one_line(source.truncation_note());
        break;
      }
      if (status == rutd::SourceStatus::Ok) {
        ++pairs;
        if (frame.left.size() != cv::Size(64, 64) || frame.left.size() != frame.right.size() ||
            frame.left.type() != frame.right.type() || (frame.left.type() != CV_8UC1 && frame.left.type() != CV_16UC1))
          rutd::fuzz::fail("a pair the calibration does not describe was accepted", "");
        continue;
      }
      if (status != rutd::SourceStatus::Error) rutd::fuzz::fail("a recording cannot time out", "");
      const std::string& message = source.error_message();
      rutd::fuzz::check_one_line(message);
      if (message.rfind(frames + ": line ", 0) != 0) rutd::fuzz::fail("the error does not name frames.csv", message);
    }
  } catch (const rutd::InputError& e) {
    rutd::fuzz::check_input_error(e, dir, /*prefix_only=*/true);
  }
  return 0;
}
