// libFuzzer target: the synthetic scene's truth.csv reader (read_truth_csv on a stream, which the file
// overload opens).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "synthetic/truth_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string kFile = "truth.csv";
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size), std::ios::binary);
  std::vector<std::int64_t> t_ns;
  try {
    const auto rows = rutd::read_truth_csv(in, kFile, &t_ns);
    if (rows.size() != t_ns.size()) rutd::fuzz::fail("one t_ns per row", "");
  } catch (const rutd::InputError& e) {
    rutd::fuzz::check_input_error(e, kFile);
  }
  return 0;
}
