// bench_uplink_fleet: a fleet through one broker, on this machine, bounded in count and time, loopback only.
// Starts Debian's Mosquitto on a free loopback port (persistence on, no bound on a subscriber's queue),
// a counting subscriber (libmosquitto, QoS 1, persistent session), and VEHICLES simulated vehicles, each a
// real Uplink (its own thread, SQLite queue and MQTT connection) in PROCESSES child processes (libmosquitto's
// select() needs every socket below FD_SETSIZE). Each vehicle posts RATE messages a second for SECONDS; the
// broker is stopped for OUTAGE seconds from OUTAGE_FROM, so the queues fill and drain. Prints one JSON line:
// messages sent, delivered (distinct ids), lost, duplicates, delivered per second outside the outage, the
// latency from post to delivery (p50, p99), the broker's CPU, the vehicles' CPU, the largest backlog and
// how long it took to drain.
//
// Usage: bench_uplink_fleet [--vehicles 200] [--processes 4] [--rate 2] [--seconds 30] [--outage-from 10]
//                           [--outage 8]
#include <mosquitto.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "process_support.hpp"
#include "uplink/uplink.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Options {
  int vehicles = 200, processes = 4, rate = 2, seconds = 30, outage_from = 10, outage = 8;
};

std::int64_t unix_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double cpu_seconds_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), {});
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return 0;
  std::vector<std::string> f;
  std::size_t at = close + 2;
  while (at < stat.size()) {
    const auto sp = stat.find(' ', at);
    f.push_back(stat.substr(at, sp - at));
    if (sp == std::string::npos) break;
    at = sp + 1;
  }
  // utime and stime are fields 14 and 15 of the file; f[0] is field 3.
  return f.size() > 12 ? (std::stod(f[11]) + std::stod(f[12])) / static_cast<double>(sysconf(_SC_CLK_TCK)) : 0;
}

// The subscriber: counts distinct (vehicle, id) and the latency from the vehicle's post to delivery.
struct Counter {
  std::mutex mutex;
  std::map<int, std::vector<bool>> seen;  // vehicle number -> ids seen
  std::uint64_t messages = 0, duplicates = 0;
  std::vector<double> latency_ms;
  std::vector<std::int64_t> arrival_ns;  // when each distinct message arrived
};

long field_number(const char* text, std::size_t len, const char* key) {
  const std::string_view s(text, len);
  const auto at = s.find(key);
  return at == std::string_view::npos ? -1 : std::atol(text + at + std::strlen(key));
}

int run_vehicles(const Options& o, int first, int count, int port, const fs::path& dir, int report_fd) {
  spdlog::set_level(spdlog::level::err);
  std::vector<std::unique_ptr<rutd::Uplink>> fleet;
  for (int v = first; v < first + count; ++v) {
    rutd::UplinkConfig c;
    c.enabled = true;
    c.port = port;
    c.vehicle = fmt::format("v{}", v);
    c.health_period_s = 60;
    c.retry_min_ms = 200;
    c.retry_max_ms = 1000;
    c.queue.path = (dir / (c.vehicle + ".sqlite")).string();
    fleet.push_back(std::make_unique<rutd::Uplink>(c, "bench"));
  }
  const auto t0 = Clock::now();
  const std::int64_t total = static_cast<std::int64_t>(o.rate) * o.seconds;
  std::uint64_t posted = 0, max_queued = 0;
  for (std::int64_t k = 0; k < total; ++k) {
    std::this_thread::sleep_until(t0 + std::chrono::nanoseconds(k * 1'000'000'000LL / o.rate));
    for (int i = 0; i < count; ++i) {
      const std::int64_t now = unix_ns();
      fleet[static_cast<std::size_t>(i)]->post(
          rutd::UplinkTopic::Segment,
          fmt::format(R"("schema":"rutd-uplink/1","type":"segment","vehicle":"v{}","n":{},"v":{},"sent_ns":{})",
                      first + i, k, first + i, now),
          now);
      ++posted;
    }
    std::uint64_t queued = 0;
    for (const auto& u : fleet) queued += u->health().queued;
    max_queued = std::max(max_queued, queued);
  }
  // Until every queue is empty (or 120 s), then the time that took after the last post.
  const auto end = Clock::now();
  std::uint64_t left = 1;
  while (left > 0 && Clock::now() - end < std::chrono::seconds(120)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    left = 0;
    for (const auto& u : fleet) left += u->health().queued;
  }
  const double drain_s = std::chrono::duration<double>(Clock::now() - end).count();
  std::uint64_t not_queued = 0, send_errors = 0, dropped = 0;
  for (const auto& u : fleet) {
    const rutd::UplinkHealth h = u->health();
    not_queued += h.not_queued;
    send_errors += h.send_errors;
    dropped += h.dropped_oldest;
  }
  for (auto& u : fleet) u->stop(200);
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  const double cpu = static_cast<double>(r.ru_utime.tv_sec + r.ru_stime.tv_sec) +
                     static_cast<double>(r.ru_utime.tv_usec + r.ru_stime.tv_usec) * 1e-6;
  const std::string line = fmt::format("{} {} {} {} {} {} {:.3f} {:.3f}\n", posted, max_queued, left, not_queued,
                                       send_errors, dropped, drain_s, cpu);
  return ::write(report_fd, line.data(), line.size()) == static_cast<ssize_t>(line.size()) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    const int v = std::atoi(argv[i + 1]);
    if (k == "--vehicles") o.vehicles = std::clamp(v, 1, 1000);
    else if (k == "--processes") o.processes = std::clamp(v, 1, 32);
    else if (k == "--rate") o.rate = std::clamp(v, 1, 100);
    else if (k == "--seconds") o.seconds = std::clamp(v, 1, 300);
    else if (k == "--outage-from") o.outage_from = v;
    else if (k == "--outage") o.outage = std::clamp(v, 0, 120);
    else {
      std::fprintf(stderr, "bench_uplink_fleet: unknown option %s\n", k.c_str());
      return 64;
    }
  }
  if (!fs::exists("/usr/sbin/mosquitto")) {
    std::fprintf(stderr, "bench_uplink_fleet: needs /usr/sbin/mosquitto (Debian mosquitto)\n");
    return 77;
  }
  char tmpl[] = "/tmp/rutd-fleet-XXXXXX";
  const fs::path dir = mkdtemp(tmpl);
  const int port = rutd::test::free_loopback_port();
  std::ofstream(dir / "mosquitto.conf") << "listener " << port << " 127.0.0.1\nallow_anonymous true\n"
                                        << "max_queued_messages 0\nmax_inflight_messages 100\npersistence true\n"
                                        << "persistence_location " << dir.string() << "/\nuser root\n";
  auto broker = std::make_unique<rutd::test::ProcessGroup>(
      std::vector<std::string>{"/usr/sbin/mosquitto", "-c", (dir / "mosquitto.conf").string()}, dir / "broker.log");
  if (!rutd::test::wait_for_port(port, std::chrono::seconds(10))) return 2;
  double broker_cpu = 0;

  mosquitto_lib_init();
  Counter counter;
  mosquitto* sub = mosquitto_new("fleet-counter", false, &counter);
  mosquitto_max_inflight_messages_set(sub, 100);
  mosquitto_connect_callback_set(sub, [](mosquitto* m, void*, int rc) {
    if (rc == 0) mosquitto_subscribe(m, nullptr, "rutd/#", 1);
  });
  mosquitto_message_callback_set(sub, [](mosquitto*, void* self, const mosquitto_message* msg) {
    auto* c = static_cast<Counter*>(self);
    const auto* text = static_cast<const char*>(msg->payload);
    const std::size_t len = static_cast<std::size_t>(msg->payloadlen);
    const long id = field_number(text, len, "\"id\":"), v = field_number(text, len, "\"v\":");
    const long sent = field_number(text, len, "\"sent_ns\":");
    if (id <= 0 || v < 0) return;
    const std::int64_t now = unix_ns();
    std::lock_guard lock(c->mutex);
    ++c->messages;
    auto& ids = c->seen[static_cast<int>(v)];
    if (ids.size() <= static_cast<std::size_t>(id)) ids.resize(static_cast<std::size_t>(id) * 2 + 16);
    if (ids[static_cast<std::size_t>(id)]) {
      ++c->duplicates;
      return;
    }
    ids[static_cast<std::size_t>(id)] = true;
    c->latency_ms.push_back(static_cast<double>(now - sent) * 1e-6);
    c->arrival_ns.push_back(now);
  });
  mosquitto_reconnect_delay_set(sub, 1, 2, false);
  if (mosquitto_connect(sub, "127.0.0.1", port, 30) != MOSQ_ERR_SUCCESS) return 2;
  mosquitto_loop_start(sub);

  // The vehicles, in child processes reporting one line each through a pipe.
  int fds[2];
  if (::pipe(fds) != 0) return 2;
  std::vector<pid_t> children;
  const std::int64_t t0 = unix_ns();
  for (int p = 0; p < o.processes; ++p) {
    const int first = p * o.vehicles / o.processes, count = (p + 1) * o.vehicles / o.processes - first;
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(fds[0]);
      ::_exit(run_vehicles(o, first, count, port, dir, fds[1]));
    }
    children.push_back(pid);
  }
  ::close(fds[1]);
  // The outage.
  std::this_thread::sleep_for(std::chrono::seconds(o.outage_from));
  const std::int64_t outage_start = unix_ns();
  if (o.outage > 0) {
    broker_cpu += cpu_seconds_of(broker->pid());
    broker.reset();
    std::this_thread::sleep_for(std::chrono::seconds(o.outage));
    broker = std::make_unique<rutd::test::ProcessGroup>(
        std::vector<std::string>{"/usr/sbin/mosquitto", "-c", (dir / "mosquitto.conf").string()}, dir / "broker-2.log");
    rutd::test::wait_for_port(port, std::chrono::seconds(10));
  }
  const std::int64_t outage_end = unix_ns();
  std::uint64_t posted = 0, max_queued = 0, left = 0, not_queued = 0, send_errors = 0, dropped = 0;
  double drain_s = 0, vehicles_cpu = 0;
  FILE* reports = ::fdopen(fds[0], "r");
  for (std::size_t i = 0; i < children.size(); ++i) {
    unsigned long long a = 0, b = 0, c = 0, d = 0, e = 0, f = 0;
    double g = 0, h = 0;
    if (std::fscanf(reports, "%llu %llu %llu %llu %llu %llu %lf %lf", &a, &b, &c, &d, &e, &f, &g, &h) == 8) {
      posted += a, max_queued += b, left += c, not_queued += d, send_errors += e, dropped += f;
      drain_s = std::max(drain_s, g);
      vehicles_cpu += h;
    }
  }
  for (pid_t pid : children) ::waitpid(pid, nullptr, 0);
  std::this_thread::sleep_for(std::chrono::seconds(2));  // the subscriber's last deliveries
  broker_cpu += cpu_seconds_of(broker->pid());
  const double wall = static_cast<double>(unix_ns() - t0) * 1e-9;
  mosquitto_loop_stop(sub, true);
  broker.reset();

  std::lock_guard lock(counter.mutex);
  std::uint64_t distinct = 0;
  for (const auto& [v, ids] : counter.seen)
    distinct += static_cast<std::uint64_t>(std::count(ids.begin(), ids.end(), true));
  // Delivery rate outside the outage and its drain: distinct messages that arrived in the steady first part.
  std::uint64_t steady = 0;
  for (const std::int64_t t : counter.arrival_ns) steady += t >= t0 + 2'000'000'000LL && t < outage_start;
  const double steady_s = static_cast<double>(outage_start - t0) * 1e-9 - 2.0;
  std::vector<double> lat = counter.latency_ms;
  std::sort(lat.begin(), lat.end());
  auto pct = [&](double q) { return lat.empty() ? 0.0 : lat[static_cast<std::size_t>(q * (lat.size() - 1))]; };
  std::printf(
      "{\"vehicles\":%d,\"processes\":%d,\"rate_per_vehicle\":%d,\"seconds\":%d,\"outage_s\":%.1f,"
      "\"posted\":%llu,\"delivered_distinct\":%llu,\"lost\":%lld,\"duplicates\":%llu,"
      "\"steady_delivered_per_s\":%.0f,\"latency_p50_ms\":%.1f,\"latency_p99_ms\":%.0f,\"latency_max_ms\":%.0f,"
      "\"broker_cpu_percent\":%.1f,\"vehicles_cpu_percent\":%.1f,\"max_queued\":%llu,\"drain_after_last_post_s\":%.1f,"
      "\"left_queued\":%llu,\"not_queued\":%llu,\"send_errors\":%llu,\"dropped_oldest\":%llu}\n",
      o.vehicles, o.processes, o.rate, o.seconds, static_cast<double>(outage_end - outage_start) * 1e-9,
      static_cast<unsigned long long>(posted), static_cast<unsigned long long>(distinct),
      static_cast<long long>(posted) - static_cast<long long>(distinct),
      static_cast<unsigned long long>(counter.duplicates), steady_s > 0 ? static_cast<double>(steady) / steady_s : 0.0,
      pct(0.5), pct(0.99), lat.empty() ? 0.0 : lat.back(), 100.0 * broker_cpu / wall, 100.0 * vehicles_cpu / wall,
      static_cast<unsigned long long>(max_queued), drain_s, static_cast<unsigned long long>(left),
      static_cast<unsigned long long>(not_queued), static_cast<unsigned long long>(send_errors),
      static_cast<unsigned long long>(dropped));
  fs::remove_all(dir);
  return 0;
}
