// rutd_faults: `rutd run` with faults injected at its lowest I/O calls, for the fault tests
// (tests/integration/test_faults.cpp). The daemon code is rutd's own (add_run_command); this program
// only builds the IoFaults it is handed (core/io_faults.hpp), so the rutd executable has no way to
// switch a fault on. Not installed.
//
// Usage: rutd_faults [--fault SPEC]... [--can-socketpair] run [rutd run options]
//   SPEC = POINT:FAULT[:every=N][:from=S][:until=S]
//     POINT  camera-pop | can-write | record-write | image-decode | csv-write
//     FAULT  timeout | corrupt | short | an errno name: EAGAIN ENOBUFS ENETDOWN ENOSPC EIO
//     every=N  every Nth call in the window fails (default 1); from/until: the window, in seconds since
//              the first call at that point (default: the whole run).
//   --can-socketpair  sinks.socketcan (or --socketcan NAME) opens one end of a socketpair instead of a
//              CAN socket; a thread reads the other end. Runs the CAN path without CAN kernel support.
//   --speed-from LOG  trafficability.speed.socketcan (or --speed-socketcan NAME) receives on one end of a
//              socketpair; a thread sends LOG's frames (a candump log) into the other end at the log's
//              pace, from the moment the receiver opens (the vehicle's speed without CAN kernel support).
// At exit, one line on stderr per point: "injected POINT N"; with --can-socketpair "peer received N".
#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "can/candump_log.hpp"
#include "can/socketcan_bus.hpp"
#include "can/vehicle_speed_receiver.hpp"
#include "core/input_error.hpp"
#include "daemon/commands.hpp"

namespace {

const std::map<std::string, rutd::IoPoint> kPoints{{"camera-pop", rutd::IoPoint::CameraPop},
                                                   {"can-write", rutd::IoPoint::CanWrite},
                                                   {"record-write", rutd::IoPoint::RecordWrite},
                                                   {"image-decode", rutd::IoPoint::ImageDecode},
                                                   {"csv-write", rutd::IoPoint::MeasurementWrite}};
const std::map<std::string, int> kFaults{{"timeout", rutd::io_fault::kTimeout},
                                         {"corrupt", rutd::io_fault::kCorrupt},
                                         {"short", rutd::io_fault::kShort},
                                         {"EAGAIN", EAGAIN},
                                         {"ENOBUFS", ENOBUFS},
                                         {"ENETDOWN", ENETDOWN},
                                         {"ENOSPC", ENOSPC},
                                         {"EIO", EIO}};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out(1);
  for (char c : s) {
    if (c == sep) {
      out.emplace_back();
    } else {
      out.back().push_back(c);
    }
  }
  return out;
}

// Throws std::invalid_argument naming the part of SPEC at fault.
void add_fault(rutd::IoFaults& faults, const std::string& spec) {
  const std::vector<std::string> parts = split(spec, ':');
  if (parts.size() < 2) throw std::invalid_argument("--fault " + spec + ": expected POINT:FAULT[:key=value]...");
  const auto point = kPoints.find(parts[0]);
  if (point == kPoints.end()) throw std::invalid_argument("--fault " + spec + ": unknown point '" + parts[0] + "'");
  const auto fault = kFaults.find(parts[1]);
  if (fault == kFaults.end()) throw std::invalid_argument("--fault " + spec + ": unknown fault '" + parts[1] + "'");
  rutd::IoFaultRule rule;
  rule.fault = fault->second;
  for (std::size_t i = 2; i < parts.size(); ++i) {
    const auto eq = parts[i].find('=');
    const std::string key = parts[i].substr(0, eq), value = eq == std::string::npos ? "" : parts[i].substr(eq + 1);
    try {
      if (key == "every" && std::stoull(value) > 0) {
        rule.every = std::stoull(value);
      } else if (key == "from") {
        rule.from_s = std::stod(value);
      } else if (key == "until") {
        rule.until_s = std::stod(value);
      } else {
        throw std::invalid_argument(key);
      }
    } catch (const std::exception&) {
      throw std::invalid_argument("--fault " + spec + ": bad '" + parts[i] + "'");
    }
  }
  faults.set(point->second, rule);
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("rutd"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  rutd::IoFaults faults;
  bool socketpair_bus = false;
  std::string speed_log;
  std::vector<char*> rest{argv[0]};
  try {
    int i = 1;
    for (; i < argc && std::strcmp(argv[i], "run") != 0; ++i) {
      if (std::strcmp(argv[i], "--fault") == 0 && i + 1 < argc) {
        add_fault(faults, argv[++i]);
      } else if (std::strcmp(argv[i], "--can-socketpair") == 0) {
        socketpair_bus = true;
      } else if (std::strcmp(argv[i], "--speed-from") == 0 && i + 1 < argc) {
        speed_log = argv[++i];
      } else {
        throw std::invalid_argument(std::string("unknown argument '") + argv[i] + "' before 'run'");
      }
    }
    for (; i < argc; ++i) rest.push_back(argv[i]);
  } catch (const std::exception& e) {
    std::cerr << "rutd_faults: " << e.what() << '\n';
    return 2;
  }

  rutd::RunInjection injection;
  injection.faults = &faults;
  std::atomic<std::uint64_t> peer_frames{0};
  std::thread peer;
  auto bus_adopted = std::make_shared<bool>(false);
  int bus_fd = -1;
  if (socketpair_bus) {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) {
      std::perror("rutd_faults: socketpair");
      return 2;
    }
    // The bus's end never blocks (as the CAN socket); the peer reads until the bus closes its end.
    bus_fd = fds[0];
    const int peer_fd = fds[1];
    if (fcntl(bus_fd, F_SETFL, O_NONBLOCK) != 0) return 2;
    peer = std::thread([peer_fd, &peer_frames] {
      char frame[64];
      while (::recv(peer_fd, frame, sizeof frame, 0) > 0) peer_frames.fetch_add(1, std::memory_order_relaxed);
      ::close(peer_fd);
    });
    injection.open_bus = [bus_fd, bus_adopted, &faults](const std::string& name) {
      *bus_adopted = true;
      return rutd::SocketCanBus::adopt(bus_fd, name, &faults);
    };
  }

  // The vehicle: LOG's frames, paced by their timestamps, into the receiver's end of a socketpair.
  std::thread vehicle;
  std::atomic<std::uint64_t> vehicle_frames{0};
  auto vehicle_start = std::make_shared<std::atomic<bool>>(false);
  int vehicle_fds[2] = {-1, -1};
  if (!speed_log.empty()) {
    std::ifstream in(speed_log);
    if (!in) {
      std::cerr << "rutd_faults: --speed-from " << speed_log << ": cannot open\n";
      return 2;
    }
    std::vector<std::pair<rutd::CanFrame, std::int64_t>> frames;
    for (std::string line; std::getline(in, line);)
      if (const auto f = rutd::parse_candump_line(line)) frames.push_back(*f);
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, vehicle_fds) != 0) return 2;
    const int out_fd = vehicle_fds[1];
    vehicle = std::thread([out_fd, frames = std::move(frames), vehicle_start, &vehicle_frames] {
      while (!vehicle_start->load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      const auto t0 = std::chrono::steady_clock::now();
      const std::int64_t first = frames.empty() ? 0 : frames.front().second;
      for (const auto& [frame, t_ns] : frames) {
        std::this_thread::sleep_until(t0 + std::chrono::nanoseconds(t_ns - first));
        const struct can_frame k = rutd::to_kernel_frame(frame);
        if (::send(out_fd, &k, sizeof k, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof k)) break;
        vehicle_frames.fetch_add(1, std::memory_order_relaxed);
      }
      ::close(out_fd);
    });
    injection.open_speed = [fd = vehicle_fds[0], vehicle_start](
                               const std::string& name, const rutd::VehicleSpeedConfig& config, std::ostream* log) {
      auto receiver = rutd::VehicleSpeedReceiver::adopt(fd, name, config, log);
      vehicle_start->store(true);
      return receiver;
    };
  }

  CLI::App app{"rutd run with injected I/O faults (tests only)"};
  app.require_subcommand(1);
  int exit_code = 0;
  rutd::add_run_command(app, exit_code, injection);
  try {
    app.parse(static_cast<int>(rest.size()), rest.data());
  } catch (const CLI::ParseError& e) {
    exit_code = app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "rutd_faults: error: " << e.what() << '\n';
    exit_code = 2;
  }
  for (const auto& [name, point] : kPoints)
    std::fprintf(stderr, "injected %s %llu\n", name.c_str(), static_cast<unsigned long long>(faults.injected(point)));
  if (peer.joinable()) {
    if (!*bus_adopted) ::close(bus_fd);  // the run never opened the bus
    peer.join();                         // the bus closed its end when the run ended
    std::fprintf(stderr, "peer received %llu\n", static_cast<unsigned long long>(peer_frames.load()));
  }
  if (vehicle.joinable()) {
    // A run that never opened the receiver: its end is still ours; let the thread run out.
    if (!vehicle_start->exchange(true)) ::close(vehicle_fds[0]);
    vehicle.join();
    std::fprintf(stderr, "vehicle sent %llu\n", static_cast<unsigned long long>(vehicle_frames.load()));
  }
  return exit_code;
}
