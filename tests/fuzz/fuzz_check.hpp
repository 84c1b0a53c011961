#pragma once
// What every fuzz target asserts about a rejected input, beyond "no crash, no leak, no hang": the one
// error is an InputError whose what() is one line reading "FILE: FIELD: MESSAGE", naming the file the
// parser was given and a non-empty field (a key such as "M1" or "measurement.engine", or "line N"). Any
// other exception escapes the target, which libFuzzer reports as a crash.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/input_error.hpp"

namespace rutd::fuzz {

[[noreturn]] inline void fail(const std::string& what, std::string_view message) {
  std::fprintf(stderr, "fuzz check failed: %s\n  message: [%.*s]\n", what.c_str(), static_cast<int>(message.size()),
               message.data());
  std::abort();
}

// A message meant for one log line: no line break of any kind.
inline void check_one_line(std::string_view message) {
  if (message.find_first_of("\n\r") != std::string_view::npos) fail("the error is not one line", message);
  if (message.empty()) fail("the error is empty", message);
}

// `file`: the name the parser was handed. `prefix_only`: the error may name a file inside it (a folder).
inline void check_input_error(const InputError& e, std::string_view file, bool prefix_only = false) {
  const std::string_view what = e.what();
  check_one_line(what);
  const bool names_file = prefix_only ? e.file().rfind(file, 0) == 0 : e.file() == file;
  if (!names_file) fail("the error does not name the file '" + std::string(file) + "'", what);
  if (e.field().empty()) fail("the error names no field", what);
  if (what.rfind(one_line(e.file()) + ": " + one_line(e.field()) + ": ", 0) != 0)
    fail("the error is not 'FILE: FIELD: MESSAGE'", what);
}

}  // namespace rutd::fuzz
