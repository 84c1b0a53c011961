// libFuzzer target: the YAML configuration (parse_config, which load_config runs on a file's text).
#include <cstddef>
#include <cstdint>
#include <string>

#include "daemon/config.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string kFile = "rutd.yaml";
  try {
    rutd::parse_config(std::string(reinterpret_cast<const char*>(data), size), kFile);
  } catch (const rutd::InputError& e) {
    rutd::fuzz::check_input_error(e, kFile);
  }
  return 0;
}
