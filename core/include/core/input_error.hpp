#pragma once
// The one exception type for bad input found when opening or reading a file (calibration, recording,
// configuration). Start-up code throws it; callers print what() once and exit non-zero.
#include <stdexcept>
#include <string>
#include <string_view>

namespace rutd {

// `text` made safe for one log line: control characters (a CR or LF inside a quoted field of a bad
// file, a byte of binary garbage) are written as \r, \n, \t or \xNN, so an error never spans lines nor
// carries terminal escapes. Other bytes (UTF-8 included) pass unchanged.
inline std::string one_line(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c != 0x7F) {
      out.push_back(ch);
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else {
      constexpr char kHex[] = "0123456789ABCDEF";
      out += "\\x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 0xF]);
    }
  }
  return out;
}

class InputError : public std::runtime_error {
 public:
  // what() reads "FILE: FIELD: MESSAGE" (FIELD is a key such as "M1" or "line 12"), on one line: the
  // parts pass through one_line(), since messages quote the bad input. file() and field() stay as given.
  InputError(std::string file, std::string field, const std::string& message)
      : std::runtime_error(one_line(file) + ": " + one_line(field) + ": " + one_line(message)),
        file_(std::move(file)),
        field_(std::move(field)) {}

  const std::string& file() const noexcept { return file_; }
  const std::string& field() const noexcept { return field_; }

 private:
  std::string file_;
  std::string field_;
};

}  // namespace rutd
