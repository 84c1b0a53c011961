#include "uplink/uplink.hpp"

#include <mosquitto.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include <spdlog/spdlog.h>

#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

using Clock = std::chrono::steady_clock;

// Why a connection attempt failed, in words that say what to check.
std::string failure_text(int rc, const UplinkConfig& c) {
  if (rc == MOSQ_ERR_TLS)
    return fmt::format(
        "the TLS handshake with {}:{} failed: its certificate is not signed by uplink.ca_file ({}), "
        "names another host, or the broker refused the client certificate",
        c.host, c.port, c.ca_file);
  return rc == MOSQ_ERR_ERRNO ? std::string(std::strerror(errno)) : std::string(mosquitto_strerror(rc));
}

void init_library_once() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

const char* to_string(UplinkTopic topic) noexcept {
  switch (topic) {
    case UplinkTopic::Segment: return "segment";
    case UplinkTopic::Second: return "second";
    case UplinkTopic::Health: return "health";
  }
  return "segment";
}

// The connection: libmosquitto's handle, what is in flight, the two lanes' cursors and the back-off.
struct Uplink::Link {
  mosquitto* mosq = nullptr;
  std::string prefix;            // PREFIX/VEHICLE/
  std::string status_topic;      // PREFIX/VEHICLE/status
  bool socket_open = false;      // mosquitto_connect succeeded; CONNACK may still be pending or refused
  bool connected = false;        // CONNACK accepted
  bool refused = false;          // CONNACK refused (said by the connect callback)
  bool announce_online = false;  // the retained "online" is due (set by the connect callback)
  std::unordered_map<int, Outbox::Acked> inflight;  // mid -> the queued message
  std::vector<Outbox::Acked> acked;
  std::int64_t backlog_end = 0, backlog_cursor = 0, live_cursor = 0;
  Clock::time_point next_attempt{};
  int backoff_ms = 0;
  std::string last_problem;  // logged once until it changes or the link comes up

  ~Link() {
    if (mosq) mosquitto_destroy(mosq);
  }
  // The next attempt after a failure: retry_min_ms, doubling up to retry_max_ms.
  void back_off(Clock::time_point now, const UplinkConfig& c) {
    backoff_ms = backoff_ms == 0 ? c.retry_min_ms : std::min(2 * backoff_ms, c.retry_max_ms);
    next_attempt = now + std::chrono::milliseconds(backoff_ms);
  }
  // The retained status message (not queued).
  void publish_status(const std::string& json) {
    mosquitto_publish(mosq, nullptr, status_topic.c_str(), static_cast<int>(json.size()), json.data(), 1, true);
  }
  // Logs a problem once (until a different one, or a connection, comes).
  void problem(const std::string& what) {
    if (what == last_problem) return;
    last_problem = what;
    spdlog::warn("uplink: {}; retrying with back-off", what);
  }
};

Uplink::Uplink(UplinkConfig config, std::string software)
    : config_(std::move(config)), software_(std::move(software)), link_(std::make_unique<Link>()) {
  if (const std::string e = check_uplink_config(config_); !e.empty()) throw std::invalid_argument("uplink." + e);
  if (config_.queue.path.empty()) config_.queue.path = "/var/lib/rutd/uplink.sqlite";
  outbox_ = std::make_unique<Outbox>(config_.queue);  // throws naming the file
  init_library_once();
  Link& l = *link_;
  l.prefix = config_.topic_prefix + "/" + config_.vehicle + "/";
  l.status_topic = l.prefix + "status";
  l.mosq = mosquitto_new(config_.vehicle.c_str(), true, this);
  if (!l.mosq) throw std::runtime_error("uplink: cannot create an MQTT client: " + std::string(std::strerror(errno)));
  mosquitto_int_option(l.mosq, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_max_inflight_messages_set(l.mosq, static_cast<unsigned>(config_.inflight));
  const std::string offline = uplink_status_json(false, config_.vehicle, software_);
  mosquitto_will_set(l.mosq, l.status_topic.c_str(), static_cast<int>(offline.size()), offline.data(), 1, true);
  if (!config_.credentials_file.empty()) {
    const UplinkCredentials c = read_uplink_credentials(config_.credentials_file);  // throws naming the file
    mosquitto_username_pw_set(l.mosq, c.username.c_str(), c.password.c_str());
  }
  if (!config_.ca_file.empty()) {
    const int rc = mosquitto_tls_set(l.mosq, config_.ca_file.c_str(), nullptr,
                                     config_.cert_file.empty() ? nullptr : config_.cert_file.c_str(),
                                     config_.key_file.empty() ? nullptr : config_.key_file.c_str(), nullptr);
    if (rc != MOSQ_ERR_SUCCESS)
      throw std::runtime_error("uplink.ca_file: " + config_.ca_file + ": " + mosquitto_strerror(rc));
    mosquitto_tls_opts_set(l.mosq, 1, "tlsv1.2", nullptr);
  }
  mosquitto_connect_callback_set(l.mosq, [](mosquitto*, void* self, int rc) {
    auto* u = static_cast<Uplink*>(self);
    Link& k = *u->link_;
    if (rc != 0) {
      k.refused = true;
      ++u->connect_failures_;
      k.problem(fmt::format("the broker at {}:{} refused the connection: {}", u->config_.host, u->config_.port,
                            mosquitto_connack_string(rc)));
      return;
    }
    k.connected = true;
    k.backoff_ms = 0;
    spdlog::info("uplink: connected to {}:{} as {}; {} messages queued", u->config_.host, u->config_.port,
                 u->config_.vehicle, u->outbox_->stats().messages);
    k.last_problem.clear();
    k.inflight.clear();
    k.backlog_end = u->outbox_->last_id();
    k.backlog_cursor = 0;
    k.live_cursor = k.backlog_end;
    // Not from inside the callback: libmosquitto holds its callback lock here, and publishing takes its
    // packet locks, the reverse of their order in mosquitto_loop (ThreadSanitizer's lock-order report).
    k.announce_online = true;
  });
  mosquitto_disconnect_callback_set(l.mosq, [](mosquitto*, void* self, int rc) {
    auto* u = static_cast<Uplink*>(self);
    Link& k = *u->link_;
    if (k.connected && rc != 0)
      k.problem(fmt::format("lost the broker at {}:{}: {}", u->config_.host, u->config_.port, mosquitto_strerror(rc)));
    k.connected = false;
    k.socket_open = false;
    k.inflight.clear();  // not acknowledged: still queued, sent again after the reconnection
  });
  mosquitto_publish_callback_set(l.mosq, [](mosquitto*, void* self, int mid) {
    auto* u = static_cast<Uplink*>(self);
    Link& k = *u->link_;
    const auto it = k.inflight.find(mid);
    if (it == k.inflight.end()) return;  // the status message
    k.acked.push_back(it->second);
    k.inflight.erase(it);
    ++u->acknowledged_;
  });
  publish_health_atomics();
  thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
}

Uplink::~Uplink() {
  stop();
  // Posted after the thread ended (a caller that posts after stop()): lost, counted, and destroyed here
  // (the ring buffer does not destroy what it still holds).
  Posted p;
  while (handoff_.pop(p)) ++not_queued_;
}

bool Uplink::post(UplinkTopic topic, std::string body, std::int64_t created_unix_ns) {
  if (handoff_.push(Posted{topic, std::move(body), created_unix_ns})) return true;
  ++not_queued_;
  return false;
}

void Uplink::stop(int drain_ms) {
  if (!thread_.joinable()) return;
  drain_ms_ = drain_ms;
  thread_.request_stop();
  thread_.join();
}

UplinkHealth Uplink::health() const {
  UplinkHealth h;
  h.link_up = link_up_;
  h.queued = queued_;
  h.queued_bytes = queued_bytes_;
  const std::int64_t oldest = oldest_created_unix_ns_;
  h.oldest_unsent_s = oldest > 0 ? static_cast<double>(unix_now_ns() - oldest) * 1e-9 : 0.0;
  h.sent = sent_;
  h.acknowledged = acknowledged_;
  h.send_errors = send_errors_;
  h.connect_failures = connect_failures_;
  h.dropped_oldest = dropped_oldest_;
  h.queue_errors = queue_errors_;
  h.not_queued = not_queued_;
  return h;
}

void Uplink::publish_health_atomics() {
  const OutboxStats& s = outbox_->stats();
  link_up_ = link_->connected;
  queued_ = s.messages;
  queued_bytes_ = s.bytes;
  oldest_created_unix_ns_ = s.oldest_created_unix_ns;
  dropped_oldest_ = s.dropped_oldest;
  queue_errors_ = s.write_errors;
}

void Uplink::store_posted() {
  std::vector<Outbox::Pending> pending;
  Posted p;
  while (handoff_.pop(p)) pending.push_back({to_string(p.topic), std::move(p.body), p.created_unix_ns});
  if (pending.empty()) return;
  std::string error;
  if (!outbox_->append(pending, error)) {
    // Disk full or an I/O error: these messages are lost (counted); measuring goes on, and the next turn
    // tries the queue again.
    not_queued_ += pending.size();
    spdlog::error("uplink: {}: cannot queue {} messages: {}", outbox_->path(), pending.size(), error);
  }
}

void Uplink::run(std::stop_token stop) noexcept {
  Link& l = *link_;
  Clock::time_point drain_until{};
  bool draining = false;
  for (;;) {
    if (stop.stop_requested() && !draining) {
      draining = true;
      drain_until = Clock::now() + std::chrono::milliseconds(drain_ms_.load());
    }
    store_posted();
    if (draining) {
      const bool all_sent =
          l.inflight.empty() && l.live_cursor >= outbox_->last_id() && l.backlog_cursor >= l.backlog_end;
      if (!l.connected || all_sent || Clock::now() >= drain_until) break;
    }
    const Clock::time_point now = Clock::now();
    if (!l.socket_open && now >= l.next_attempt && !draining) {
      const int rc = mosquitto_connect(l.mosq, config_.host.c_str(), config_.port, config_.keepalive_s);
      if (rc == MOSQ_ERR_SUCCESS) {
        l.socket_open = true;
        l.refused = false;
      } else {
        ++connect_failures_;
        l.problem(rc == MOSQ_ERR_TLS ? failure_text(rc, config_)
                                     : fmt::format("cannot connect to {}:{}: {}", config_.host, config_.port,
                                                   failure_text(rc, config_)));
        l.back_off(now, config_);
      }
    }
    if (l.connected && l.announce_online) {
      l.announce_online = false;
      l.publish_status(uplink_status_json(true, config_.vehicle, software_));
    }
    if (l.connected) {
      // Live first, then the backlog, within the in-flight window; each lane in id order.
      std::size_t budget =
          static_cast<std::size_t>(config_.inflight) - std::min<std::size_t>(l.inflight.size(), config_.inflight);
      auto send = [&](const std::vector<OutboxMessage>& batch, std::int64_t& cursor, std::int64_t up_to) {
        for (const OutboxMessage& m : batch) {
          if (up_to > 0 && m.id > up_to) {
            cursor = up_to;
            return;
          }
          int mid = 0;
          const std::string topic = l.prefix + m.topic;
          const int rc = mosquitto_publish(l.mosq, &mid, topic.c_str(), static_cast<int>(m.payload.size()),
                                           m.payload.data(), 1, false);
          if (rc != MOSQ_ERR_SUCCESS) {
            ++send_errors_;
            return;  // sent again from here next turn
          }
          l.inflight[mid] = {m.id, m.payload.size()};
          cursor = m.id;
          ++sent_;
          --budget;
        }
      };
      if (budget > 0) send(outbox_->next(l.live_cursor, budget), l.live_cursor, 0);
      if (budget > 0 && l.backlog_cursor < l.backlog_end) {
        const auto batch = outbox_->next(l.backlog_cursor, budget);
        if (batch.empty()) l.backlog_cursor = l.backlog_end;
        send(batch, l.backlog_cursor, l.backlog_end);
      }
    }
    if (l.socket_open) {
      const int rc = mosquitto_loop(l.mosq, 50, 1);
      if (rc != MOSQ_ERR_SUCCESS) {
        // The disconnect callback has said why a connection was lost, the connect callback why it was
        // refused; what remains is a server that closed before it accepted or refused.
        const std::string why = failure_text(rc, config_);
        if (l.connected) {
          l.problem(fmt::format("connection to {}:{} failed: {}", config_.host, config_.port, why));
        } else if (rc == MOSQ_ERR_TLS) {
          ++connect_failures_;
          l.problem(why);
        } else if (!l.refused) {
          ++connect_failures_;
          l.problem(
              fmt::format("{}:{} closed the connection before accepting it ({}): not an MQTT broker, or one "
                          "that drops this client",
                          config_.host, config_.port, why));
        }
        l.connected = false;
        l.socket_open = false;
        l.inflight.clear();
        mosquitto_disconnect(l.mosq);
        l.back_off(Clock::now(), config_);
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!l.acked.empty()) {
      std::string error;
      if (!outbox_->remove(l.acked, error))
        spdlog::error("uplink: {}: cannot remove {} acknowledged messages: {}", outbox_->path(), l.acked.size(), error);
      l.acked.clear();
    }
    publish_health_atomics();
  }
  store_posted();  // what came in during the last turn stays queued for the next start
  if (l.connected) {
    l.publish_status(uplink_status_json(false, config_.vehicle, software_));
    for (int i = 0; i < 10; ++i) mosquitto_loop(l.mosq, 20, 1);
    mosquitto_disconnect(l.mosq);
    mosquitto_loop(l.mosq, 20, 1);
  }
  l.connected = false;
  publish_health_atomics();
}

}  // namespace rutd
