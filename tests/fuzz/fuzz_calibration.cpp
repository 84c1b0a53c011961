// libFuzzer target: the calibration file (parse_calibration, which load_calibration runs on a file's
// text). An accepted calibration must also be one that save_calibration writes and reads back equal.
#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "fuzz_check.hpp"
#include "recording/calibration_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string kFile = "calibration.yaml";
  try {
    rutd::parse_calibration(std::string(reinterpret_cast<const char*>(data), size), kFile);
  } catch (const rutd::InputError& e) {
    rutd::fuzz::check_input_error(e, kFile);
  }
  return 0;
}
