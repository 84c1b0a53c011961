#pragma once
// The two text primitives every CSV format of rutd (frames.csv, measurement CSV, truth.csv) reads with:
// locale-independent, allocation-free.
#include <charconv>
#include <cstddef>
#include <string_view>
#include <system_error>

namespace rutd {

// Splits `line` at commas into at most `max` fields (views into `line`); returns how many fields the line
// has, which may exceed `max`. No quoting: rutd's CSV fields never contain commas.
inline std::size_t split_csv_fields(std::string_view line, std::string_view* fields, std::size_t max) {
  std::size_t count = 0, start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::size_t end = comma == std::string_view::npos ? line.size() : comma;
    if (count < max) fields[count] = line.substr(start, end - start);
    ++count;
    if (comma == std::string_view::npos) return count;
    start = comma + 1;
  }
}

// Parses the whole of `text` as a number (integer or floating point, std::from_chars rules); false for
// an empty field, trailing characters or a value out of range.
template <typename Number>
bool parse_csv_number(std::string_view text, Number& value) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return !text.empty() && ec == std::errc() && end == text.data() + text.size();
}

}  // namespace rutd
