#pragma once
// can-utils log files (`candump -L`, replayed by `canplayer`, converted by `log2asc`). One frame a line:
//
//   (SECONDS.MICROSECONDS) INTERFACE ID#DATA
//
//   (1700000000.123456) can0 18FF50A0#0102030405060708   29-bit identifier: 8 hex digits
//   (1700000000.223456) can0 350#A1B2                    11-bit identifier: 3 hex digits, 2 data bytes
//   (0000000012.000001) can0 123#                        no data (len 0)
//
// Seconds are zero-padded to 10 digits and microseconds to 6, as candump writes them; data bytes are
// two uppercase hex digits each. The parser also accepts lowercase hex and '.' between data bytes
// (`123#11.22.33`), as can-utils' parse_canframe() does; it rejects remote frames (`123#R`), CAN FD
// frames (`123##1...`) and error frames (8-digit identifiers with bit 0x20000000), which rutd never
// sends.
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>

#include "can/can_frame.hpp"

namespace rutd {

class CandumpLogWriter {  // not thread-safe: one writer thread.
 public:
  // `out` is not owned and must outlive the writer. `interface_name` is the bus name written on each
  // line (canplayer maps it to a real interface at replay).
  explicit CandumpLogWriter(std::ostream& out, std::string interface_name = "can0");

  // Appends one line for `frame` taken at `t_ns` (nanoseconds; written truncated to microseconds,
  // negative times as 0). No allocation. Returns false if the stream is in a failed state afterwards.
  bool write(const CanFrame& frame, std::int64_t t_ns);

 private:
  std::ostream& out_;
  std::string interface_name_;
  std::string line_;  // one formatted line, sized once at construction
};

// Formats one line without the trailing newline into `buffer` and returns its length. The buffer must
// hold at least kCandumpLineMax + interface name length characters.
inline constexpr std::size_t kCandumpLineMax = 48;
std::size_t format_candump_line(const CanFrame& frame, std::int64_t t_ns, std::string_view interface_name,
                                char* buffer) noexcept;

// Parses one log line (trailing whitespace or newline allowed). Returns the frame and its time in
// nanoseconds, or nothing if the line is not a classic CAN data frame in the format above.
std::optional<std::pair<CanFrame, std::int64_t>> parse_candump_line(std::string_view line);

}  // namespace rutd
