#pragma once
// The fleet uplink (DESIGN.md, Fleet uplink): messages from the publish thread go through a bounded
// lock-free hand-off to the uplink's own thread, which appends them to the store-and-forward queue
// (uplink/outbox.hpp) and sends them to an MQTT broker with QoS 1 (libmosquitto, driven by this thread's
// own loop: no library thread, reconnection with our back-off, every error seen here). A message leaves the
// queue only when the broker acknowledged it (PUBACK); on reconnection what was not acknowledged is sent
// again (at-least-once: a consumer drops duplicates by id).
//
// Order and fairness: at each connection the queue's content is the backlog. The backlog drains in id
// order beside the live messages (made since the connection), which go first in each turn, also in id
// order: a long backlog never holds the live segments back, and each lane's order is kept.
//
// Topics: PREFIX/VEHICLE/segment, .../second, .../health, and .../status, retained: "online" once
// connected, "offline" as the last will (the broker publishes it when the vehicle vanishes) and at a
// clean stop.
//
// Never slows the measurement: post() is a bounded, non-blocking push (full: the message is counted as
// not queued and dropped); the broker, the disk and the network are this thread's business alone.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include <boost/lockfree/spsc_queue.hpp>

#include "uplink/outbox.hpp"
#include "uplink/uplink_config.hpp"
#include "uplink/uplink_json.hpp"

namespace rutd {

enum class UplinkTopic : std::uint8_t { Segment, Second, Health };

class Uplink {
 public:
  static constexpr std::size_t kHandoff = 1024;  // messages; at a few a second, minutes of a stalled thread

  // Checks the configuration, reads the credentials and opens the queue, then starts the thread (which
  // connects in the background). Throws std::runtime_error / std::invalid_argument naming the file or key
  // (start-up errors). software: what the status message says is running.
  Uplink(UplinkConfig config, std::string software);
  ~Uplink();  // stop()
  Uplink(const Uplink&) = delete;
  Uplink& operator=(const Uplink&) = delete;

  // Publish thread (one producer): hands a message on; false when the hand-off is full (counted).
  bool post(UplinkTopic topic, std::string body, std::int64_t created_unix_ns);
  // Queues everything posted so far, sends what it can while the broker is reachable for at most
  // `drain_ms`, then "offline" and a clean disconnection; joins the thread. Idempotent. Post nothing after
  // it (such a message is counted as not queued).
  void stop(int drain_ms = 1000);

  // Any thread.
  UplinkHealth health() const;
  const UplinkConfig& config() const noexcept { return config_; }

 private:
  struct Posted {
    UplinkTopic topic = UplinkTopic::Segment;
    std::string body;
    std::int64_t created_unix_ns = 0;
  };
  struct Link;  // libmosquitto and the connection state, this thread's only

  void run(std::stop_token stop) noexcept;
  void store_posted();
  void publish_health_atomics();

  UplinkConfig config_;
  std::string software_;
  std::unique_ptr<Outbox> outbox_;
  std::unique_ptr<Link> link_;
  boost::lockfree::spsc_queue<Posted, boost::lockfree::capacity<kHandoff>> handoff_;
  std::atomic<std::uint64_t> not_queued_{0};
  std::atomic<int> drain_ms_{0};
  // Health, written by the thread, read by health().
  std::atomic<bool> link_up_{false};
  std::atomic<std::uint64_t> queued_{0}, queued_bytes_{0}, sent_{0}, acknowledged_{0}, send_errors_{0},
      connect_failures_{0}, dropped_oldest_{0}, queue_errors_{0};
  std::atomic<std::int64_t> oldest_created_unix_ns_{0};
  std::jthread thread_;
};

// The topic's name below PREFIX/VEHICLE/.
const char* to_string(UplinkTopic topic) noexcept;

}  // namespace rutd
