#include "can/candump_log.hpp"

#include <algorithm>
#include <charconv>
#include <cstdint>

namespace rutd {
namespace {

constexpr std::string_view kSpace = " \t\r\n";
constexpr char kHex[] = "0123456789ABCDEF";
constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;
constexpr std::uint32_t kMaxStandardId = 0x7FF;

// Writes `value` as exactly `digits` characters in base `base` (zero-padded); returns the end.
char* put_fixed(char* p, std::uint64_t value, int digits, unsigned base) noexcept {
  for (int i = digits - 1; i >= 0; --i) {
    p[i] = kHex[value % base];
    value /= base;
  }
  return p + digits;
}

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// Parses "SECONDS.MICROSECONDS" (the part between the parentheses) into nanoseconds.
std::optional<std::int64_t> parse_time(std::string_view text) {
  const auto dot = text.find('.');
  if (dot == std::string_view::npos || dot == 0 || text.size() - dot - 1 != 6) return std::nullopt;
  std::int64_t seconds = 0;
  std::int64_t micros = 0;
  const auto [end_s, err_s] = std::from_chars(text.data(), text.data() + dot, seconds);
  const auto [end_u, err_u] = std::from_chars(text.data() + dot + 1, text.data() + text.size(), micros);
  if (err_s != std::errc{} || end_s != text.data() + dot || err_u != std::errc{} ||
      end_u != text.data() + text.size() || seconds < 0 || micros < 0) {
    return std::nullopt;
  }
  if (seconds > (INT64_MAX - micros * 1000) / 1'000'000'000) return std::nullopt;
  return seconds * 1'000'000'000 + micros * 1000;
}

// Parses "ID#DATA".
std::optional<CanFrame> parse_frame(std::string_view text) {
  const auto hash = text.find('#');
  if (hash != 3 && hash != 8) return std::nullopt;
  CanFrame frame;
  frame.extended = hash == 8;
  for (std::size_t i = 0; i < hash; ++i) {
    const int v = hex_value(text[i]);
    if (v < 0) return std::nullopt;
    frame.id = frame.id << 4 | static_cast<std::uint32_t>(v);
  }
  if (frame.id > (frame.extended ? kMaxExtendedId : kMaxStandardId)) return std::nullopt;
  std::string_view data = text.substr(hash + 1);
  while (!data.empty()) {
    if (data.front() == '.') {
      data.remove_prefix(1);
      continue;
    }
    if (data.size() < 2 || frame.len == frame.data.size()) return std::nullopt;
    const int hi = hex_value(data[0]);
    const int lo = hex_value(data[1]);
    if (hi < 0 || lo < 0) return std::nullopt;  // also rejects 'R' (remote) and '#' (CAN FD)
    frame.data[frame.len++] = static_cast<std::uint8_t>(hi << 4 | lo);
    data.remove_prefix(2);
  }
  return frame;
}

std::string_view next_token(std::string_view& rest) {
  const auto begin = rest.find_first_not_of(kSpace);
  if (begin == std::string_view::npos) {
    rest = {};
    return {};
  }
  rest.remove_prefix(begin);
  const auto end = std::min(rest.find_first_of(kSpace), rest.size());
  const std::string_view token = rest.substr(0, end);
  rest.remove_prefix(end);
  return token;
}

}  // namespace

CandumpLogWriter::CandumpLogWriter(std::ostream& out, std::string interface_name)
    : out_(out), interface_name_(std::move(interface_name)) {
  line_.resize(kCandumpLineMax + interface_name_.size() + 1);
}

bool CandumpLogWriter::write(const CanFrame& frame, std::int64_t t_ns) {
  const std::size_t n = format_candump_line(frame, t_ns, interface_name_, line_.data());
  line_[n] = '\n';
  out_.write(line_.data(), static_cast<std::streamsize>(n + 1));
  return !out_.fail();
}

std::size_t format_candump_line(const CanFrame& frame, std::int64_t t_ns, std::string_view interface_name,
                                char* buffer) noexcept {
  const auto t = static_cast<std::uint64_t>(std::max<std::int64_t>(t_ns, 0));
  char* p = buffer;
  *p++ = '(';
  p = put_fixed(p, t / 1'000'000'000, 10, 10);
  *p++ = '.';
  p = put_fixed(p, (t % 1'000'000'000) / 1000, 6, 10);
  *p++ = ')';
  *p++ = ' ';
  p = std::copy(interface_name.begin(), interface_name.end(), p);
  *p++ = ' ';
  p = frame.extended ? put_fixed(p, frame.id & kMaxExtendedId, 8, 16) : put_fixed(p, frame.id & kMaxStandardId, 3, 16);
  *p++ = '#';
  const std::size_t len = std::min<std::size_t>(frame.len, frame.data.size());
  for (std::size_t i = 0; i < len; ++i) p = put_fixed(p, frame.data[i], 2, 16);
  return static_cast<std::size_t>(p - buffer);
}

std::optional<std::pair<CanFrame, std::int64_t>> parse_candump_line(std::string_view line) {
  std::string_view rest = line;
  const std::string_view time = next_token(rest);
  const std::string_view interface_name = next_token(rest);
  const std::string_view frame_text = next_token(rest);
  if (time.size() < 3 || time.front() != '(' || time.back() != ')' || interface_name.empty() || frame_text.empty() ||
      rest.find_first_not_of(kSpace) != std::string_view::npos) {
    return std::nullopt;
  }
  const auto t_ns = parse_time(time.substr(1, time.size() - 2));
  auto frame = parse_frame(frame_text);
  if (!t_ns || !frame) return std::nullopt;
  return std::pair{*frame, *t_ns};
}

}  // namespace rutd
