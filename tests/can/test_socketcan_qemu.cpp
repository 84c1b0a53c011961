// SocketCAN on a real Linux kernel: boots Debian's kernel under qemu (tests/can/qemu/run-guest.sh),
// with the host's root shared read-only, and runs rutd's programs inside it on a virtual CAN bus.
// The truth is outside rutd: can-utils' candump records the bus, and the DBC decoder
// (tests/can/decode_candump.py, canmatrix) must decode what it recorded without CRC or counter errors.
//
// The kernel and the initramfs are cached in <build>/can-qemu; the first run downloads the kernel
// package (about 70 MB). Skips where qemu, the kernel, busybox-static or the decoder cannot be had.
#include <sys/wait.h>
#include <unistd.h>
#include <x86intrin.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "can/candump_log.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using test::quoted;
using test::read_text;
using test::run_shell;

namespace fs = std::filesystem;
constexpr const char* kPython = "/usr/bin/python3";
constexpr int kBootTimeoutS = 150;  // rutd's own run takes 30-60 s under emulation

fs::path bin_dir() { return fs::path(RUTD_BINARY).parent_path(); }
fs::path cache_dir() { return bin_dir().parent_path() / "can-qemu"; }
fs::path qemu_dir() { return fs::path(RUTD_SOURCE_DIR) / "tests" / "can" / "qemu"; }

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // the serial console writes CR LF
    lines.push_back(line);
  }
  return lines;
}

// The host's TSC rate in kHz, measured against CLOCK_MONOTONIC; the guest kernel gets it as
// tsc_early_khz= and then skips its own calibration, which can hang under emulation.
long measure_tsc_khz() {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  const unsigned long long c0 = __rdtsc();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const unsigned long long c1 = __rdtsc();
  const auto t1 = clock::now();
  const double ns = std::chrono::duration<double, std::nano>(t1 - t0).count();
  return static_cast<long>(static_cast<double>(c1 - c0) / ns * 1e6);
}

struct GuestRun {
  int status = -1;      // run-guest.sh's exit status (77: cannot run here)
  std::string console;  // the guest's serial console
  std::string error;    // run-guest.sh's stderr
  double wall_s = 0;
};

// Boots the guest once and runs `job` (shell script text) in it.
GuestRun run_guest(const std::string& job) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path jobs = cache_dir() / "jobs";
  fs::create_directories(jobs);
  // The job lives in the build tree, which the guest sees read-only through the shared host root.
  const fs::path job_file = jobs / (std::string(info->name()) + "-" + std::to_string(::getpid()) + ".sh");
  std::ofstream(job_file) << job;
  const fs::path console = jobs / (job_file.stem().string() + ".console");
  const fs::path error = jobs / (job_file.stem().string() + ".err");

  static const long tsc_khz = measure_tsc_khz();
  const std::string command = "RUTD_TSC_KHZ=" + std::to_string(tsc_khz) + " " + quoted(qemu_dir() / "run-guest.sh") +
                              " " + quoted(cache_dir()) + " " + quoted(job_file) + " " + std::to_string(kBootTimeoutS) +
                              " >" + quoted(console) + " 2>" + quoted(error);
  GuestRun run;
  const auto t0 = std::chrono::steady_clock::now();
  run.status = run_shell(command);
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.console = read_text(console);
  run.error = read_text(error);
  std::printf("[ qemu     ] boot + job + power-off: %.2f s wall (TSC %ld kHz)\n", run.wall_s, tsc_khz);
  fs::remove(job_file);
  fs::remove(console);
  fs::remove(error);
  return run;
}

// The status the job reported, or nothing if the guest did not get that far.
std::optional<std::string> job_exit(const std::string& console) {
  for (const std::string& line : lines_of(console)) {
    if (line.rfind("RUTD-GUEST-EXIT=", 0) == 0) return line.substr(16);
  }
  return std::nullopt;
}

// The lines between "----- BEGIN name -----" and "----- END name -----" (guest-candump.sh).
std::optional<std::vector<std::string>> block(const std::string& console, const std::string& name) {
  std::vector<std::string> out;
  bool inside = false;
  for (const std::string& line : lines_of(console)) {
    if (line == "----- BEGIN " + name + " -----") {
      inside = true;
    } else if (line == "----- END " + name + " -----") {
      return out;
    } else if (inside) {
      out.push_back(line);
    }
  }
  return std::nullopt;
}

std::string value_after(const std::string& console, const std::string& key) {
  for (const std::string& line : lines_of(console)) {
    if (line.rfind(key, 0) == 0) return line.substr(key.size());
  }
  return {};
}

std::string decoder_unavailable() {
  if (!fs::exists(kPython)) return std::string(kPython) + " is needed (with python3-canmatrix)";
  if (run_shell(std::string(kPython) + " -c 'import canmatrix.formats' >/dev/null 2>&1") != 0) {
    return std::string("canmatrix for ") + kPython + " is needed (Debian package python3-canmatrix)";
  }
  return {};
}

// Fails the test (and returns false) unless the guest ran the job to its end.
::testing::AssertionResult guest_completed(const GuestRun& run) {
  if (run.status != 0) {
    return ::testing::AssertionFailure() << "run-guest.sh exited with " << run.status << ": " << run.error
                                         << "\nconsole:\n"
                                         << run.console;
  }
  if (!job_exit(run.console)) {
    return ::testing::AssertionFailure() << "the guest never finished its job\nconsole:\n" << run.console;
  }
  return ::testing::AssertionSuccess();
}

class GuestKernel : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(qemu_dir() / "run-guest.sh")) FAIL() << "missing " << qemu_dir() / "run-guest.sh";
  }
  // Boots; skips the test if the guest cannot be had here. run-guest.sh applies the skip policy
  // (tests/skip_policy.sh): under RUTD_TEST_NO_SKIP=1 a missing package is its failure, not 77.
  GuestRun boot(const std::string& job) {
    GuestRun run = run_guest(job);
    if (run.status == 77) skipped_ = "cannot boot the test guest here: " + run.error;
    return run;
  }
  std::string skipped_;
};

#define SKIP_IF_NO_GUEST()                                     \
  do {                                                         \
    if (!skipped_.empty()) RUTD_SKIP_NEEDS_HARDWARE(skipped_); \
  } while (false)

// Checks guest-candump.sh's report: the sender succeeded, candump saw exactly the frames the sender
// logged as sent (same order, identifiers, lengths and data), then the end marker; and the DBC decoder
// decodes candump's record without problems. `min_frames` guards against a sender that sent nothing.
void check_candump_matches_sent(const std::string& console, std::size_t min_frames) {
  EXPECT_EQ(value_after(console, "RUTD-SENDER-EXIT="), "0") << console;
  const auto seen_lines = block(console, "candump.log");
  const auto sent_lines = block(console, "sent.log");
  ASSERT_TRUE(seen_lines && sent_lines) << "no candump.log or sent.log block\n" << console;

  std::vector<CanFrame> seen;
  std::vector<CanFrame> sent;
  for (const auto& line : *seen_lines) {
    const auto parsed = parse_candump_line(line);
    ASSERT_TRUE(parsed) << "candump wrote an unexpected line: " << line;
    seen.push_back(parsed->first);
  }
  for (const auto& line : *sent_lines) {
    const auto parsed = parse_candump_line(line);
    ASSERT_TRUE(parsed) << "the sender logged an unreadable line: " << line;
    sent.push_back(parsed->first);
  }
  ASSERT_FALSE(seen.empty());
  const CanFrame end_marker{0x7FF, false, 0, {}};
  EXPECT_EQ(seen.back(), end_marker) << "candump's record does not end with the end marker";
  seen.pop_back();

  EXPECT_GE(sent.size(), min_frames);
  ASSERT_EQ(seen.size(), sent.size()) << console;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(seen[i], sent[i]) << "frame " << i << ": bus " << (*seen_lines)[i] << ", sent " << (*sent_lines)[i];
  }

  if (const std::string missing = decoder_unavailable(); !missing.empty())
    RUTD_SKIP_NEEDS_INSTALLED("DBC decoding: " << missing);
  const fs::path log = cache_dir() / "jobs" / ("candump-" + std::to_string(::getpid()) + ".log");
  {
    std::ofstream out(log);
    for (std::size_t i = 0; i + 1 < seen_lines->size(); ++i) out << (*seen_lines)[i] << "\n";
  }
  const fs::path dbc = fs::path(RUTD_SOURCE_DIR) / "config" / "rutd.dbc";
  const fs::path errors = log.string() + ".err";
  const int status = run_shell(std::string(kPython) + " " + quoted(qemu_dir().parent_path() / "decode_candump.py") +
                               " " + quoted(dbc) + " " + quoted(log) + " >/dev/null 2>" + quoted(errors));
  const std::string report = read_text(errors);
  EXPECT_EQ(status, 0) << report;
  EXPECT_NE(report.find("frames=" + std::to_string(sent.size()) + " "), std::string::npos) << report;
  fs::remove(log);
  fs::remove(errors);
}

// The sink's and the speed receiver's own kernel tests, which skip on a host without CAN, pass on a
// kernel with it.
TEST_F(GuestKernel, SocketCanBusTestsPassOnARealKernel) {
  const fs::path tests = bin_dir() / "test_socketcan";
  ASSERT_TRUE(fs::exists(tests)) << "build the test_socketcan target first: " << tests;
  const GuestRun run = boot(quoted(tests) +
                            " --gtest_filter='SocketCanBusOnKernel.*:SocketCanBusOpen.*:VehicleSpeedOnKernel.*' 2>&1\n"
                            "echo RUTD-TESTS-EXIT=$?\n");
  SKIP_IF_NO_GUEST();
  ASSERT_TRUE(guest_completed(run));
  EXPECT_EQ(value_after(run.console, "RUTD-TESTS-EXIT="), "0") << run.console;
  EXPECT_NE(run.console.find("[  PASSED  ] 7 tests."), std::string::npos) << run.console;
  EXPECT_EQ(run.console.find("SKIPPED"), std::string::npos) << "a kernel test skipped in the guest\n" << run.console;
}

// Diagnostic sender (test_socketcan's EncodedFramesArriveUnchanged, which logs what it sent): the
// harness itself, independent of rutd's command line.
TEST_F(GuestKernel, CandumpRecordsWhatTheSinkSent) {
  const fs::path tests = bin_dir() / "test_socketcan";
  ASSERT_TRUE(fs::exists(tests)) << "build the test_socketcan target first: " << tests;
  const GuestRun run = boot("exec /bin/sh " + quoted(qemu_dir() / "guest-candump.sh") +
                            " /mnt/sent.log env RUTD_SOCKETCAN_SENT_LOG=/mnt/sent.log " + quoted(tests) +
                            " --gtest_filter=SocketCanBusOnKernel.EncodedFramesArriveUnchanged\n");
  SKIP_IF_NO_GUEST();
  ASSERT_TRUE(guest_completed(run));
  check_candump_matches_sent(run.console, 15);
}

bool rutd_has_socketcan_option() {
  const fs::path help = cache_dir() / ("rutd-run-help-" + std::to_string(::getpid()));
  run_shell(quoted(RUTD_BINARY) + " run --help >" + quoted(help) + " 2>&1");
  const bool has = read_text(help).find("--socketcan") != std::string::npos;
  fs::remove(help);
  return has;
}

// rutd itself: `rutd run --frames 5 --socketcan vcan0 --candump LOG` on the synthetic source puts on
// the bus exactly what it logs, and that decodes with the DBC. Small images, block matching and no DIC
// keep it to about 30 s under emulation (the defaults take minutes there); the CAN path is the same.
TEST_F(GuestKernel, RutdSendsOnVcanWhatItLogs) {
  fs::create_directories(cache_dir());
  ASSERT_TRUE(rutd_has_socketcan_option()) << "`rutd run --help` lists no --socketcan option";
  const GuestRun run =
      boot("exec /bin/sh " + quoted(qemu_dir() / "guest-candump.sh") + " /mnt/rutd.log " + quoted(RUTD_BINARY) +
           " run --frames 5 --size 320x240 --engine bm --no-dic"
           " --socketcan vcan0 --candump /mnt/rutd.log\n");
  SKIP_IF_NO_GUEST();
  ASSERT_TRUE(guest_completed(run));
  check_candump_matches_sent(run.console, 10);  // two measurement frames per stereo pair at least
}

// The vehicle speed on a real kernel's vcan: canplayer (can-utils) plays J1939 CCVS frames encoded by
// canmatrix from its own J1939 database (tests/integration/encode_speed_profile.py: every 4 s forward,
// a stop, reversing (the direction from ETC2's current gear, trafficability.speed.direction_from_gear),
// a stop and the sender silent for 0.8 s) while cangen floods the bus with another parameter group
// (asked for 2,000 frames a second; under emulation (TCG) a few hundred reach the bus, all of them with
// KVM: the kernel's own count, /proc/net/can/stats, is printed). `rutd run --speed-socketcan vcan0` must
// get the speed through its kernel filters (none of the flood reaches it, none of its frames is dropped
// by the kernel) and publish every measurement asked for; and its segments must equal an independent
// computation (tests/integration/segments_from_recording.py, canmatrix decoding the vehicle.log the guest
// recorded, and tests/unit/trafficability_reference.py from the per-frame CSV), with UNKNOWN where the
// speed stopped. The receiver's cost with every foreign frame let through (no filters) is
// test_trafficability_live's and bench_trafficability's.
TEST_F(GuestKernel, RutdReceivesTheSpeedThroughKernelFiltersUnderAFlood) {
  fs::create_directories(cache_dir());
  const fs::path log = cache_dir() / ("speed-" + std::to_string(::getpid()) + ".log");
  std::string knots, gaps;
  for (int c = 0; c < 15; ++c) {
    const double b = 4.0 * c;
    char k[160], g[40];
    std::snprintf(k, sizeof k, "%s%.1f:10.8,%.1f:10.8,%.1f:0,%.1f:0,%.1f:-3.6,%.1f:-3.6,%.1f:0", c ? "," : "", b,
                  b + 1.5, b + 2, b + 2.3, b + 2.5, b + 2.9, b + 3.1);
    std::snprintf(g, sizeof g, "%s%.1f:%.1f", c ? "," : "", b + 3.2, b + 4);
    knots += k;
    gaps += g;
  }
  ASSERT_EQ(run_shell(std::string(kPython) + " " +
                      quoted(fs::path(RUTD_SOURCE_DIR) / "tests/integration/encode_speed_profile.py") + " " +
                      quoted(log) + " 50 60 " + knots + " " + gaps + " gear 2>/dev/null"),
            0)
      << "canmatrix (python3-canmatrix) is needed";
  // The installed configuration with the direction from the gear (the guest reads the host's files).
  const fs::path config = cache_dir() / ("gear-" + std::to_string(::getpid()) + ".yaml");
  {
    std::string text = read_text(fs::path(RUTD_SOURCE_DIR) / "config/rutd.yaml");
    const std::string from = "direction_from_gear: false";
    ASSERT_NE(text.find(from), std::string::npos);
    text.replace(text.find(from), from.size(), "direction_from_gear: true");
    std::ofstream(config) << text;
  }
  const GuestRun run = boot(
      "cangen vcan0 -e -I 18FEF200 -L 8 -g 0.5 &\nflood=$!\n"
      "canplayer -I " +
      quoted(log) + " vcan0=can0 &\nplayer=$!\n" +
      "t0=$(cut -d' ' -f1 /proc/uptime); f0=$(awk '/transmitted frames/{print $1}' /proc/net/can/stats)\n" +
      quoted(RUTD_BINARY) + " run --config " + quoted(config) +
      " --frames 150 --size 320x240 --engine bm --no-dic --candump '' --speed-socketcan vcan0"
      " --segments /mnt/segments.csv --csv /mnt/m.csv --record /mnt/rec 2>/mnt/run.log\n"
      "echo RUTD-RUN-EXIT=$?\n"
      "t1=$(cut -d' ' -f1 /proc/uptime); f1=$(awk '/transmitted frames/{print $1}' /proc/net/can/stats)\n"
      "kill $flood $player\n"
      "echo RUTD-BUS-FRAMES=$((f1 - f0))\necho RUTD-BUS-SECONDS=$(awk \"BEGIN{print $t1 - $t0}\")\n"
      "for f in run.log segments.csv m.csv rec/vehicle.log; do\n"
      "  echo \"----- BEGIN $f -----\"; cat /mnt/$f; echo \"----- END $f -----\"\ndone\n");
  fs::remove(log);
  fs::remove(config);
  SKIP_IF_NO_GUEST();
  ASSERT_TRUE(guest_completed(run));
  EXPECT_EQ(value_after(run.console, "RUTD-RUN-EXIT="), "0") << run.console;
  const auto run_log = block(run.console, "run.log");
  const auto segments = block(run.console, "segments.csv");
  const auto per_frame = block(run.console, "m.csv");
  const auto vehicle = block(run.console, "rec/vehicle.log");
  ASSERT_TRUE(run_log && segments && per_frame && vehicle) << run.console;
  std::string text;
  for (const std::string& line : *run_log) text += line + "\n";
  const std::regex speed(
      R"(vehicle speed on vcan0 .*: (\d+) frames, (\d+) samples \((\d+) ok.* (\d+) other; (\d+) dropped by the kernel)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, speed)) << text;
  std::printf("[ guest    ] %s\n", m[0].str().c_str());
  const long speed_samples = std::stol(m[3]);
  EXPECT_GT(speed_samples, 100) << "too few speed samples";
  EXPECT_EQ(m[4], "0") << "foreign frames passed the kernel filter";
  EXPECT_EQ(m[5], "0") << "the kernel dropped speed frames";
  const std::regex published(R"(stopped: acquired \d+ \([^)]*\) published (\d+))");
  ASSERT_TRUE(std::regex_search(text, m, published)) << text;
  EXPECT_GE(std::stoi(m[1]), 150);
  // What the bus carried meanwhile, by the kernel's count (the flood and the speed frames).
  const std::string bus_frames = value_after(run.console, "RUTD-BUS-FRAMES=");
  const std::string bus_seconds = value_after(run.console, "RUTD-BUS-SECONDS=");
  ASSERT_FALSE(bus_frames.empty() || bus_seconds.empty()) << run.console;
  const double seconds = std::stod(bus_seconds);
  std::printf("[ guest    ] the bus carried %s frames in %.1f s (%.0f a second; cangen asked for 2,000)\n",
              bus_frames.c_str(), seconds, seconds > 0 ? std::stod(bus_frames) / seconds : 0.0);
  EXPECT_GT(std::stol(bus_frames), 2 * speed_samples) << "no flood beside the speed frames";

  // The segments against the independent computation from what the guest recorded.
  const fs::path work = cache_dir() / "jobs" / ("segments-" + std::to_string(::getpid()));
  fs::remove_all(work);
  fs::create_directories(work / "rec");
  auto write = [](const fs::path& p, const std::vector<std::string>& lines) {
    std::ofstream out(p);
    for (const std::string& line : lines) out << line << '\n';
  };
  write(work / "rec" / "vehicle.log", *vehicle);
  write(work / "m.csv", *per_frame);
  write(work / "live.csv", *segments);
  const fs::path tests(fs::path(RUTD_SOURCE_DIR) / "tests");
  ASSERT_EQ(run_shell(std::string(kPython) + " " + quoted(tests / "integration/segments_from_recording.py") + " " +
                      quoted(work / "rec") + " " + quoted(work / "m.csv") + " " + quoted(work) + " gear 2>/dev/null"),
            0);
  std::ofstream(work / "config.csv") << "length_m,1\nmax_age_ns,500000000\ncaution_depth_mm,80\nno_go_depth_mm,150\n"
                                        "hysteresis_m,3\nmax_untrusted_fraction,0.5\nmin_trusted_frames,3\n"
                                        "coverage_factor,2\nsoil_table,0:1 1:0\nlimit_one_pass,0\n"
                                        "limit_fifty_passes,0\ndamage,100:1 200:1 200:4\n";
  ASSERT_EQ(
      run_shell(std::string(kPython) + " " + quoted(tests / "unit/trafficability_reference.py") + " " + quoted(work)),
      0);
  const auto live = lines_of(read_text(work / "live.csv"));
  const auto want = lines_of(read_text(work / "segments_ref.csv"));
  ASSERT_GE(live.size(), 4u) << "header and at least 3 segments\n" << text;
  ASSERT_EQ(live.size(), want.size()) << read_text(work / "live.csv") << "\n" << read_text(work / "segments_ref.csv");
  auto fields = [](const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) out.push_back(f);
    return out;
  };
  const auto live_head = fields(live[0]), want_head = fields(want[0]);
  auto column = [](const std::vector<std::string>& head, const std::string& name) {
    return static_cast<std::size_t>(std::find(head.begin(), head.end(), name) - head.begin());
  };
  const char* advisories[] = {"UNKNOWN", "GO", "CAUTION", "NO_GO"};
  int unknown = 0;
  for (std::size_t i = 1; i < live.size(); ++i) {
    const auto l = fields(live[i]), w = fields(want[i]);
    const std::string at = "segment row " + std::to_string(i);
    ASSERT_GT(l.size(), column(live_head, "advisory")) << at;
    ASSERT_GT(w.size(), column(want_head, "advisory")) << at;
    EXPECT_EQ(l[column(live_head, "frames")], w[column(want_head, "frames")]) << at;
    EXPECT_EQ(l[column(live_head, "refused")], w[column(want_head, "refused")]) << at;
    EXPECT_NEAR(std::stod(l[column(live_head, "start_m")]), std::stod(w[column(want_head, "start_m")]), 1e-3) << at;
    const std::string mean = l[column(live_head, "mean_depth_mm")], mean_want = w[column(want_head, "mean")];
    if (mean_want != "nan") {
      EXPECT_NEAR(std::stod(mean), std::stod(mean_want), 0.006) << at;
    } else {
      EXPECT_TRUE(mean.empty() || mean == "nan") << at << ": " << mean;
    }
    const std::string advisory = advisories[std::stoi(w[column(want_head, "advisory")])];
    EXPECT_EQ(l[column(live_head, "advisory")], advisory) << at;
    unknown += advisory == std::string("UNKNOWN");
  }
  EXPECT_GT(unknown, 0) << "the sender's silences left no segment UNKNOWN";
  EXPECT_NE(text.find(" reversed"), std::string::npos) << text;
  const std::regex reversed(R"(\(([0-9.]+) m reversed)");
  ASSERT_TRUE(std::regex_search(text, m, reversed)) << text;
  EXPECT_GT(std::stod(m[1]), 0.5) << "the vehicle reversed about 0.3 m in every 4 s";
  if (!HasFailure()) fs::remove_all(work);
}

}  // namespace
}  // namespace rutd
