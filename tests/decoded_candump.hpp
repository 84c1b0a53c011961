#pragma once
// A candump log as an independent decoder reads it: tests/can/decode_candump.py decodes it with
// python3-canmatrix and config/rutd.dbc (checking every CRC and counter); this parses its CSV into one
// record per frame. Tests use it to read what rutd put on the bus without rutd's own decoding.
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace rutd::test {

inline bool have_canmatrix() { return std::system("/usr/bin/python3 -c 'import canmatrix' >/dev/null 2>&1") == 0; }

// Decodes `log` into frames in log order (read_decoded_csv); `ok` is false when the decoder reported a
// problem (CRC, counter, unknown frame, bad line) or could not run.
inline std::vector<DecodedFrame> decode_candump(const std::filesystem::path& log, bool& ok) {
  const std::filesystem::path csv = log.string() + ".decoded.csv";
  const std::string cmd = std::string("/usr/bin/python3 ") + RUTD_SOURCE_DIR + "/tests/can/decode_candump.py " +
                          RUTD_SOURCE_DIR + "/config/rutd.dbc " + quoted(log) + " > " + quoted(csv);
  ok = std::system(cmd.c_str()) == 0;
  return read_decoded_csv(csv);
}

// The frames of one message, in log order.
inline std::vector<DecodedFrame> frames_of(const std::vector<DecodedFrame>& all, const std::string& message) {
  std::vector<DecodedFrame> out;
  for (const DecodedFrame& f : all) {
    if (f.message == message) out.push_back(f);
  }
  return out;
}

}  // namespace rutd::test
