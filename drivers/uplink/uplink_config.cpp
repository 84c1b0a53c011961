#include "uplink/uplink_config.hpp"

#include <sys/stat.h>

#include <fstream>
#include <stdexcept>

namespace rutd {
namespace {

bool plain_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (const char c : s) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.';
    if (!ok) return false;
  }
  return true;
}

}  // namespace

std::string check_uplink_config(const UplinkConfig& c) {
  if (c.host.empty()) return "host: must name the broker";
  if (c.port < 1 || c.port > 65535) return "port: must be 1..65535";
  if (!plain_name(c.vehicle)) return "vehicle: 1..64 letters, digits, '-', '_' or '.'";
  if (c.topic_prefix.empty() || c.topic_prefix.find_first_of("#+") != std::string::npos ||
      c.topic_prefix.front() == '/' || c.topic_prefix.back() == '/')
    return "topic_prefix: a topic without wildcards and without a leading or trailing '/'";
  if (c.keepalive_s < 5 || c.keepalive_s > 3600) return "keepalive_s: must be 5..3600";
  if (c.cert_file.empty() != c.key_file.empty()) return "cert_file: needs key_file, and the other way round";
  if (!c.cert_file.empty() && c.ca_file.empty()) return "cert_file: a client certificate needs TLS (ca_file)";
  if (c.queue.max_bytes < 4096) return "queue.max_mb: must be at least 4 KiB";
  if (c.queue.max_messages < 1) return "queue.max_messages: must be at least 1";
  if (c.health_period_s < 1 || c.health_period_s > 3600) return "health_period_s: must be 1..3600";
  if (c.retry_min_ms < 10 || c.retry_max_ms < c.retry_min_ms) return "retry_min_ms: must be >= 10 and <= retry_max_ms";
  if (c.inflight < 1 || c.inflight > 1000) return "inflight: must be 1..1000";
  return {};
}

UplinkCredentials read_uplink_credentials(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw std::runtime_error(path + ": cannot read the uplink credentials");
  if (st.st_mode & (S_IRWXG | S_IRWXO))
    throw std::runtime_error(path + ": readable by group or others (chmod 600 it, owned by the rutd user)");
  std::ifstream in(path);
  UplinkCredentials c;
  if (!std::getline(in, c.username) || !std::getline(in, c.password) || c.username.empty())
    throw std::runtime_error(path + ": expected the user name on the first line and the password on the second");
  return c;
}

}  // namespace rutd
