#include "web/web_config.hpp"

#include <arpa/inet.h>
#include <sys/stat.h>

#include <fstream>
#include <stdexcept>

namespace rutd {

bool is_loopback_address(const std::string& address) {
  in_addr v4{};
  if (::inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (::inet_pton(AF_INET6, address.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  return false;
}

std::string check_web_config(const WebConfig& c) {
  in_addr v4{};
  in6_addr v6{};
  if (::inet_pton(AF_INET, c.bind.c_str(), &v4) != 1 && ::inet_pton(AF_INET6, c.bind.c_str(), &v6) != 1)
    return "bind: expected a numeric IPv4 or IPv6 address (127.0.0.1, 0.0.0.0, ::1), got '" + c.bind + "'";
  if (c.port < 0 || c.port > 65535) return "port: expected 0..65535, got " + std::to_string(c.port);
  if (!(c.rate_hz >= 0.5 && c.rate_hz <= 30)) return "rate_hz: expected 0.5..30";
  if (c.threads < 1 || c.threads > 32) return "threads: expected 1..32, got " + std::to_string(c.threads);
  if (c.enabled && c.token_file.empty() && !is_loopback_address(c.bind))
    return "token_file: required when bind is not a loopback address (" + c.bind + ")";
  return "";
}

std::string read_web_token(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw std::invalid_argument(path + ": cannot read the token file");
  if ((st.st_mode & 077) != 0)
    throw std::invalid_argument(path + ": the token file is readable by others (mode " +
                                std::to_string((st.st_mode >> 6) & 7) + std::to_string((st.st_mode >> 3) & 7) +
                                std::to_string(st.st_mode & 7) + "); chmod 600 it");
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) throw std::invalid_argument(path + ": cannot read the token file");
  const auto first = line.find_first_not_of(" \t\r");
  const auto last = line.find_last_not_of(" \t\r");
  const std::string token = first == std::string::npos ? "" : line.substr(first, last - first + 1);
  if (token.size() < 16) throw std::invalid_argument(path + ": the token must have at least 16 characters");
  return token;
}

}  // namespace rutd
