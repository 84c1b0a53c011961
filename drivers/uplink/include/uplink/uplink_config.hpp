#pragma once
// The fleet uplink's configuration (the `uplink` section of rutd.yaml; README, Fleet uplink). Off by
// default. Checked by check_uplink_config at start-up, each problem naming its key.
#include <cstdint>
#include <string>

#include "uplink/outbox.hpp"

namespace rutd {

struct UplinkConfig {
  bool enabled = false;
  std::string host = "127.0.0.1";
  int port = 1883;  // 8883 is MQTT over TLS by convention
  // The vehicle: its MQTT client id and the last element of its topic prefix. Letters, digits, '-', '_',
  // '.' only, so that it needs no escaping in a topic or in JSON.
  std::string vehicle = "rutd";
  std::string topic_prefix = "rutd";  // messages go to PREFIX/VEHICLE/{segment,second,health,status}
  int keepalive_s = 30;
  // TLS: on when ca_file is set (the broker's certificate is verified against it, host name included).
  std::string ca_file;
  std::string cert_file;  // client certificate and key (both or neither)
  std::string key_file;
  // A file with the user name on its first line and the password on its second; it must not be readable
  // by group or others (checked, as ssh does with keys). Empty: no user name.
  std::string credentials_file;
  OutboxConfig queue;  // store and forward; queue.path empty: /var/lib/rutd/uplink.sqlite
  int health_period_s = 10;
  int retry_min_ms = 500;  // reconnection back-off: doubles from min to max
  int retry_max_ms = 30'000;
  int inflight = 32;  // messages handed to the broker and not yet acknowledged, at most
};

// Empty if usable, else "KEY: what is wrong" (KEY relative to the section).
std::string check_uplink_config(const UplinkConfig& c);

// The credentials file's user name and password. Throws std::runtime_error naming the file when it is
// missing, readable by group or others, or not two lines.
struct UplinkCredentials {
  std::string username, password;
};
UplinkCredentials read_uplink_credentials(const std::string& path);

}  // namespace rutd
