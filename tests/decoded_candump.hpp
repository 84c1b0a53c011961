#pragma once
// A candump log as an independent decoder reads it: tests/can/decode_candump.py decodes it with
// python3-canmatrix and config/rutd.dbc (checking every CRC and counter); this parses its CSV into one
// record per frame. Tests use it to read what rutd put on the bus without rutd's own decoding.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace rutd::test {

inline bool have_canmatrix() { return std::system("/usr/bin/python3 -c 'import canmatrix' >/dev/null 2>&1") == 0; }

struct DecodedFrame {
  std::string message;
  std::int64_t t_ns = 0;
  std::map<std::string, double> phys;  // NaN where the signal is NOT AVAILABLE (all ones)
  std::map<std::string, std::string> named;
};

// Decodes `log` into frames in log order; `ok` is false when the decoder reported a problem (CRC,
// counter, unknown frame, bad line) or could not run.
inline std::vector<DecodedFrame> decode_candump(const std::filesystem::path& log, bool& ok) {
  const std::filesystem::path csv = log.string() + ".decoded.csv";
  const std::string cmd = std::string("/usr/bin/python3 ") + RUTD_SOURCE_DIR + "/tests/can/decode_candump.py " +
                          RUTD_SOURCE_DIR + "/config/rutd.dbc " + quoted(log) + " > " + quoted(csv);
  ok = std::system(cmd.c_str()) == 0;
  std::vector<DecodedFrame> frames;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // index,t_ns,message,signal,raw,phys,named,na
  long last_index = -1;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    if (f.size() < 7) continue;
    if (f.size() == 7) f.push_back("0");
    const long index = std::stol(f[0]);
    if (index != last_index) {
      frames.emplace_back();
      frames.back().message = f[2];
      frames.back().t_ns = std::stoll(f[1]);
      last_index = index;
    }
    frames.back().phys[f[3]] = f[7] == "1" ? std::numeric_limits<double>::quiet_NaN() : std::stod(f[5]);
    frames.back().named[f[3]] = f[6];
  }
  return frames;
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
