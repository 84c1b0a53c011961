#pragma once
// Small helpers shared by the tests: a temporary folder removed afterwards, and running the rutd
// program as a user would.
#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "skip_policy.hpp"

namespace rutd::test {

// OpenCV's parallel_for_ runs on TBB, which ThreadSanitizer cannot see into: TBB's joins look like races
// in the loop bodies. Under ThreadSanitizer every test program runs OpenCV's loops on the calling thread;
// threads of our own are unaffected and stay checked.
#if defined(__SANITIZE_THREAD__)
inline const bool kOpenCvSequentialUnderTsan = (cv::setNumThreads(0), true);
#endif

class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "rutd-test-XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Runs `command` through the shell; its exit status, or -1 if it did not exit normally.
inline int run_shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A path in single quotes for a shell command line (paths here contain no quotes).
inline std::string quoted(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

// The whole file as text; empty if it cannot be read.
inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Lines of the file at `path` that contain `needle`; 0 if it cannot be read.
inline int count_lines(const std::filesystem::path& path, const std::string& needle) {
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += line.find(needle) != std::string::npos;
  return n;
}

// One CAN frame as tests/can/decode_candump.py writes it (decoded by canmatrix with the DBC): its log time,
// message name, and each signal's raw and physical value, its value-table text (empty if none) and
// whether it was NOT AVAILABLE (all ones).
struct DecodedFrame {
  std::int64_t t_ns = 0;
  std::string message;
  std::map<std::string, double> raw, phys;
  std::map<std::string, std::string> named;
  std::map<std::string, bool> na;
};

// The frames of decode_candump.py's CSV (header index,t_ns,message,signal,raw,phys,named,na; one line
// per signal, a frame's lines sharing its index), in log order.
inline std::vector<DecodedFrame> read_decoded_csv(const std::filesystem::path& csv) {
  std::vector<DecodedFrame> frames;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  long last_index = -1;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string index, t, message, signal, raw, phys, named, na;
    std::getline(ss, index, ',');
    std::getline(ss, t, ',');
    std::getline(ss, message, ',');
    std::getline(ss, signal, ',');
    std::getline(ss, raw, ',');
    std::getline(ss, phys, ',');
    std::getline(ss, named, ',');
    std::getline(ss, na, ',');
    if (std::stol(index) != last_index) {
      frames.push_back({std::stoll(t), message, {}, {}, {}, {}});
      last_index = std::stol(index);
    }
    frames.back().raw[signal] = std::stod(raw);
    frames.back().phys[signal] = std::stod(phys);
    frames.back().named[signal] = named;
    frames.back().na[signal] = na == "1";
  }
  return frames;
}

// Runs `rutd ARGS` through the shell (ARGS must be shell-safe) and returns its exit status, or -1 if it
// did not exit normally. stderr_file, when given, receives the program's standard error.
inline int run_rutd(const std::string& args, const std::string& stderr_file = {}) {
  std::string cmd = test::quoted(RUTD_BINARY) + " " + args;
  if (!stderr_file.empty()) cmd += " 2>" + test::quoted(stderr_file);
  return run_shell(cmd);
}

// Runs `rutd ARGS` (shell-safe) and returns its standard output; `status` receives the exit status, or -1
// if it did not exit normally. Standard error is discarded.
inline std::string run_rutd_output(const std::string& args, int& status) {
  std::string out;
  status = -1;
  FILE* p = popen((test::quoted(RUTD_BINARY) + " " + args + " 2>/dev/null").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int s = pclose(p);
  status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  return out;
}

// The number of "key":VALUE in a one-line JSON object; NaN when the key is missing or null.
inline double json_number(const std::string& line, const std::string& key) {
  std::smatch m;
  return std::regex_search(line, m, std::regex("\"" + key + "\":(-?[0-9.eE+-]+|null)")) && m[1] != "null"
             ? std::stod(m[1])
             : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace rutd::test
