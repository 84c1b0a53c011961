// libFuzzer target: the candump -L log reader, one line at a time as a log is read. The parser returns
// nothing for a line it refuses (it has no error text); every line it accepts must format back with
// format_candump_line to a line that parses to the same frame and time (to the microsecond).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "can/candump_log.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  std::string line(rutd::kCandumpLineMax + 4, '\0');
  while (!rest.empty()) {
    const std::size_t end = rest.find('\n');
    const std::string_view text = rest.substr(0, end);
    rest.remove_prefix(end == std::string_view::npos ? rest.size() : end + 1);
    const auto parsed = rutd::parse_candump_line(text);
    if (!parsed) continue;
    const auto& [frame, t_ns] = *parsed;
    if (frame.len > frame.data.size() || t_ns < 0) rutd::fuzz::fail("accepted an impossible frame", text);
    const std::size_t n = rutd::format_candump_line(frame, t_ns, "can0", line.data());
    const auto again = rutd::parse_candump_line(std::string_view(line.data(), n));
    if (!again || again->second != t_ns || again->first.id != frame.id || again->first.extended != frame.extended ||
        again->first.len != frame.len ||
        !std::equal(frame.data.begin(), frame.data.begin() + frame.len, again->first.data.begin())) {
      rutd::fuzz::fail("the line does not survive format and parse", text);
    }
  }
  return 0;
}
