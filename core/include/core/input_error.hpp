#pragma once
// The one exception type for bad input found when opening or reading a file (calibration, recording,
// configuration). Start-up code throws it; callers print what() once and exit non-zero.
#include <stdexcept>
#include <string>

namespace rutd {

class InputError : public std::runtime_error {
 public:
  // what() reads "FILE: FIELD: MESSAGE" (FIELD is a key such as "M1" or "line 12").
  InputError(std::string file, std::string field, const std::string& message)
      : std::runtime_error(file + ": " + field + ": " + message), file_(std::move(file)), field_(std::move(field)) {}

  const std::string& file() const noexcept { return file_; }
  const std::string& field() const noexcept { return field_; }

 private:
  std::string file_;
  std::string field_;
};

}  // namespace rutd
