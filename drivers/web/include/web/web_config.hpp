#pragma once
// The `web` section of the configuration: the live view for installing and checking the cameras
// (docs/web.md). Off by default; on, it listens on 127.0.0.1 unless `bind` says otherwise, and on any
// other address it answers only requests that carry the token read from `token_file`.
#include <string>

namespace rutd {

struct WebConfig {
  bool enabled = false;
  std::string bind = "127.0.0.1";  // numeric IPv4 or IPv6 address to listen on
  int port = 8080;                 // 0: any free port (the log says which; tests)
  std::string token_file;          // required unless bind is a loopback address; mode 600 or stricter
  double rate_hz = 4.0;            // pairs handed to the view per second, at most (0.5 .. 30)
  int threads = 4;                 // HTTP worker threads (1 .. 32); more clients wait their turn
};

// What is wrong with the section, as "KEY: message", or "" when it can be used. Reads nothing.
std::string check_web_config(const WebConfig& config);

// True for 127.0.0.0/8 and ::1 (the only addresses served without a token).
bool is_loopback_address(const std::string& address);

// The token from the file: its first line without surrounding blanks. Throws std::invalid_argument naming
// the file when it cannot be read, is readable by group or others, or holds fewer than 16 characters.
std::string read_web_token(const std::string& path);

}  // namespace rutd
