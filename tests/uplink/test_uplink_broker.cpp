// The fleet uplink against a real broker: Debian's Mosquitto on 127.0.0.1 with a generated configuration
// (make_broker.sh: TLS with a test CA made by openssl, per-vehicle credentials, an ACL by which a vehicle
// publishes only under its own prefix), and a subscriber we did not write (subscribe.py, python3-paho-mqtt)
// whose every message is checked against docs/uplink.schema.json (check_messages.py, python3-jsonschema).
// `rutd run` is the vehicle: the synthetic source, the speed on CAN through rutd_faults where segments are
// wanted. Each case says what it breaks: the broker away for 60 s, rutd killed with SIGKILL while its
// backlog drains, the disk full under the queue, wrong credentials, a wrong CA, a server that accepts and
// drops, a vehicle publishing under another's prefix.
#include <signal.h>

#include <chrono>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "decoded_candump.hpp"
#include "process_support.hpp"
#include "skip_policy.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using test::read_text;
using test::run_shell;

const std::string kDir = std::string(RUTD_SOURCE_DIR) + "/tests/uplink";
constexpr const char* kPython = "/usr/bin/python3";

std::string missing_tools() {
  for (const char* tool : {"/usr/sbin/mosquitto", "/usr/bin/mosquitto_passwd", "/usr/bin/openssl"})
    if (!fs::exists(tool)) return std::string(tool) + " (Debian mosquitto, openssl)";
  if (run_shell(std::string(kPython) + " -c 'import paho.mqtt.client, jsonschema' >/dev/null 2>&1") != 0)
    return "python3-paho-mqtt and python3-jsonschema for /usr/bin/python3";
  return {};
}

class UplinkBroker : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string m = missing_tools(); !m.empty()) RUTD_SKIP_NEEDS_INSTALLED(m);
    port_ = test::free_loopback_port();
    cert_port_ = test::free_loopback_port();
    ASSERT_EQ(run_shell(test::quoted(kDir + "/make_broker.sh") + " " + test::quoted(dir()) + " " +
                        std::to_string(port_) + " " + std::to_string(cert_port_)),
              0);
    start_broker();
    subscriber_ = std::make_unique<test::ProcessGroup>(
        std::vector<std::string>{kPython, kDir + "/subscribe.py", "127.0.0.1", std::to_string(port_),
                                 (dir() / "ca.crt").string(), "fleet", "pw-fleet", "rutd/#",
                                 (dir() / "received.jsonl").string()},
        dir() / "subscriber.log");
    // The subscriber's session is in place once it has connected (its log says so).
    for (int i = 0; i < 100 && read_text(dir() / "subscriber.log").find("connected rc=0") == std::string::npos; ++i)
      std::this_thread::sleep_for(50ms);
    ASSERT_NE(read_text(dir() / "subscriber.log").find("connected rc=0"), std::string::npos)
        << read_text(dir() / "subscriber.log");
  }
  void TearDown() override {
    subscriber_.reset();
    broker_.reset();
  }

  fs::path dir() const { return tmp_.path(); }
  void start_broker() {
    broker_ = std::make_unique<test::ProcessGroup>(
        std::vector<std::string>{"/usr/sbin/mosquitto", "-c", (dir() / "mosquitto.conf").string()},
        dir() / ("broker-" + std::to_string(++broker_starts_) + ".log"));
    ASSERT_TRUE(test::wait_for_port(port_, 10s)) << read_text(dir() / "broker-1.log");
  }
  void stop_broker() { broker_.reset(); }

  // A configuration for `vehicle` with `extra` uplink keys (indented two spaces, one per line). The rig
  // plays a cycle of pairs rendered once, as the default configuration does: rendering every pair live
  // would cost a CPU the uplink's tests do not need (under the sanitizers it held the camera to 7 Hz).
  fs::path config(const std::string& name, const std::string& vehicle, const std::string& extra = "",
                  const std::string& credentials = "") {
    const fs::path p = dir() / (name + ".yaml");
    std::ofstream(p) << "source:\n  synthetic:\n    size: 320x240\n    fps: 30\n    cycle_frames: 8\n"
                     << "uplink:\n  enabled: true\n  host: 127.0.0.1\n  port: " << port_ << "\n  vehicle: " << vehicle
                     << "\n  ca_file: " << (dir() / "ca.crt").string() << "\n  credentials_file: "
                     << (dir() / ((credentials.empty() ? vehicle : credentials) + ".credentials")).string()
                     << "\n  health_period_s: 1\n  retry_min_ms: 200\n  retry_max_ms: 1000\n"
                     << extra << "  queue:\n    path: " << (dir() / (vehicle + ".sqlite")).string() << "\n"
                     << "logging:\n  stats_period_s: 1\n";
    return p;
  }
  // `rutd run --config CONFIG ARGS` to its end; returns its log.
  std::string run(const fs::path& config, const std::string& args) {
    const fs::path log = dir() / (config.stem().string() + ".log");
    EXPECT_EQ(test::run_rutd("run --config " + test::quoted(config) + " --candump '' " + args, log.string()), 0)
        << read_text(log);
    return read_text(log);
  }
  // check_messages.py's report once the subscriber has taken the last messages (nothing new for `settle`).
  std::string received(std::chrono::milliseconds settle = 1500ms) {
    std::uintmax_t size = 0;
    for (int i = 0; i < 600; ++i) {
      std::this_thread::sleep_for(settle);
      std::error_code ec;
      const std::uintmax_t now = fs::file_size(dir() / "received.jsonl", ec);
      if (!ec && now == size) break;
      size = ec ? 0 : now;
    }
    const fs::path out = dir() / "report.json";
    EXPECT_EQ(run_shell(std::string(kPython) + " " + test::quoted(kDir + "/check_messages.py") + " " +
                        test::quoted(std::string(RUTD_SOURCE_DIR) + "/docs/uplink.schema.json") + " " +
                        test::quoted(dir() / "received.jsonl") + " >" + test::quoted(out)),
              0);
    const std::string report = read_text(out);
    std::printf("[ received ] %s", report.c_str());
    return report;
  }

  test::TempDir tmp_;
  int port_ = 0, cert_port_ = 0;
  int broker_starts_ = 0;
  std::unique_ptr<test::ProcessGroup> broker_, subscriber_;
};

// How many log lines hold `text`.
int count_lines(const std::string& log, const std::string& text) {
  int n = 0;
  for (std::size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++n;
  return n;
}

double summary_number(const std::string& log, const std::string& what) {
  std::smatch m;
  const std::regex re("uplink 127\\.0\\.0\\.1:\\d+: .*?(\\d+) " + what);
  return std::regex_search(log, m, re) ? std::stod(m[1]) : -1;
}

// Segments with the speed on CAN: every message arrives valid, in order, once, and the retained status
// says online, then offline at the clean stop.
TEST_F(UplinkBroker, SegmentsAndHealthArriveValidInOrderAndOnce) {
  ASSERT_EQ(run_shell(std::string(kPython) + " " RUTD_SOURCE_DIR "/tests/integration/encode_speed_profile.py " +
                      test::quoted(dir() / "speed.log") + " 50 6 0:7.2,6:7.2 2>/dev/null"),
            0);
  const fs::path log = dir() / "drive.log";
  ASSERT_EQ(
      run_shell("exec " + test::quoted(RUTD_FAULTS_BINARY) + " --speed-from " + test::quoted(dir() / "speed.log") +
                " run --config " + test::quoted(config("drive", "truck-7")) + " --candump " +
                test::quoted(dir() / "can.log") + " --speed-socketcan vcan0 --frames 120 2>" + test::quoted(log)),
      0)
      << read_text(log);
  const std::string report = received();
  EXPECT_EQ(test::json_number(report, "invalid"), 0);
  EXPECT_GE(test::json_number(report, "segment"), 6) << "a segment a metre at 2 m/s for 4 s";
  EXPECT_GE(test::json_number(report, "health"), 3);
  EXPECT_EQ(test::json_number(report, "missing"), 0);
  EXPECT_EQ(test::json_number(report, "duplicates"), 0);
  EXPECT_EQ(test::json_number(report, "decreasing"), 1) << "in id order";
  EXPECT_NE(report.find(R"("status":["online","offline"])"), std::string::npos);
  const std::string run_log = read_text(log);
  EXPECT_NE(run_log.find("link down, 0 queued"), std::string::npos) << run_log;
  // RutUplinkStatus on CAN (canmatrix): the link up once connected, nothing waiting long.
  bool ok = false;
  const auto uplink = test::frames_of(test::decode_candump(dir() / "can.log", ok), "RutUplinkStatus");
  EXPECT_TRUE(ok);
  ASSERT_GE(uplink.size(), 30u);
  int up = 0;
  for (const auto& f : uplink) {
    up += f.named.at("UplinkLink") == "UP";
    EXPECT_LE(f.phys.at("UplinkOldestUnsent"), 2);
  }
  EXPECT_GE(up, static_cast<int>(uplink.size()) - 3);
}

// The broker away for 60 s while the vehicle measures: the messages made meanwhile are queued on disk
// (the health messages say so once the link is back), nothing is lost, and the arrival order is the
// live lane's and the backlog's, each in id order.
TEST_F(UplinkBroker, BrokerAwaySixtySecondsLosesNothingAndKeepsOrder) {
  const fs::path cfg = config("away", "truck-7");
  test::ProcessGroup vehicle({RUTD_BINARY, "run", "--config", cfg.string(), "--candump", "", "--frames", "2400"},
                             dir() / "away.log");
  std::this_thread::sleep_for(5s);
  stop_broker();
  std::this_thread::sleep_for(60s);
  start_broker();
  for (int i = 0; i < 600 && !vehicle.ended(); ++i) std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(vehicle.ended()) << "rutd did not finish its 2400 frames";
  const std::string log = read_text(dir() / "away.log");
  const std::string report = received(3000ms);
  EXPECT_EQ(test::json_number(report, "invalid"), 0);
  EXPECT_EQ(test::json_number(report, "missing"), 0) << log;
  // A shortfall here once came with no other failure (9 ids, none after the outage): the vehicle's, the
  // subscriber's and the restarted broker's logs say which side did not come back.
  EXPECT_GE(test::json_number(report, "distinct_ids"), 110)
      << "about two messages a second for 80 s\n--- vehicle:\n"
      << log << "--- subscriber:\n"
      << read_text(dir() / "subscriber.log") << "--- broker after the outage:\n"
      << read_text(dir() / "broker-2.log");
  EXPECT_LE(test::json_number(report, "decreasing"), 2) << "live and backlog lanes, each in id order";
  EXPECT_EQ(test::json_number(report, "duplicates_differ"), 0);
  // The outage as the vehicle saw it: one warning, the backlog drained, the queue empty at the end.
  EXPECT_GE(count_lines(log, "uplink: lost the broker"), 1) << log;
  const std::regex reconnected(R"(uplink: connected to [^;]*; (\d+) messages queued)");
  std::smatch m;
  std::string rest = log;
  std::vector<int> queued_at_connect;
  while (std::regex_search(rest, m, reconnected)) {
    queued_at_connect.push_back(std::stoi(m[1]));
    rest = m.suffix();
  }
  ASSERT_GE(queued_at_connect.size(), 2u) << log;
  EXPECT_GE(queued_at_connect.back(), 100) << "60 s of messages waited on disk";
  EXPECT_NE(log.find("link down, 0 queued"), std::string::npos) << log;
  EXPECT_EQ(summary_number(log, "not queued"), 0) << log;
}

// rutd killed with SIGKILL while its backlog drains, then started again on the same queue: every id
// arrives; an id that arrives twice carries the same payload both times (at-least-once, deduplicated by id).
// The backlog is 20,000 messages in the queue's own format (a long time out of range, prefill_queue.py),
// drained one in flight at a time, so that the kill lands in the middle of the drain.
TEST_F(UplinkBroker, KilledWhileDrainingLosesNothingAndRepeatsOnlyWholeMessages) {
  ASSERT_EQ(run_shell(std::string(kPython) + " " + test::quoted(kDir + "/prefill_queue.py") + " " +
                      test::quoted(dir() / "truck-7.sqlite") + " 20000 truck-7"),
            0);
  const fs::path cfg = config("killed", "truck-7", "  inflight: 1\n");
  {
    test::ProcessGroup vehicle({RUTD_BINARY, "run", "--config", cfg.string(), "--candump", ""}, dir() / "killed.log");
    // Kill once the subscriber has had a thousand of them.
    for (int i = 0; i < 600; ++i) {
      std::ifstream in(dir() / "received.jsonl");
      int lines = 0;
      for (std::string l; std::getline(in, l);) ++lines;
      if (lines >= 1000) break;
      std::this_thread::sleep_for(50ms);
    }
    ::kill(-vehicle.pid(), SIGKILL);
  }
  const std::string first = read_text(dir() / "killed.log");
  ASSERT_NE(first.find("uplink: connected"), std::string::npos) << first;
  const fs::path resumed = config("resumed", "truck-7", "  inflight: 32\n");
  test::ProcessGroup vehicle({RUTD_BINARY, "run", "--config", resumed.string(), "--candump", ""},
                             dir() / "resumed.log");
  for (int i = 0; i < 1200 && read_text(dir() / "resumed.log").find("uplink: connected") == std::string::npos; ++i)
    std::this_thread::sleep_for(50ms);
  // Until the queue is empty (the periodic summary says so), then a clean stop.
  std::string second;
  for (int i = 0; i < 1200; ++i) {
    std::this_thread::sleep_for(100ms);
    second = read_text(dir() / "resumed.log");
    if (second.find("link up, 0 queued") != std::string::npos) break;
  }
  vehicle.stop();
  second = read_text(dir() / "resumed.log");
  const std::string report = received(3000ms);
  EXPECT_EQ(test::json_number(report, "invalid"), 0);
  EXPECT_EQ(test::json_number(report, "first_id"), 1);
  EXPECT_EQ(test::json_number(report, "missing"), 0) << first << second;
  EXPECT_EQ(test::json_number(report, "duplicates_differ"), 0);
  EXPECT_GE(test::json_number(report, "distinct_ids"), 20000);
  // The second run found what the first had not had acknowledged, and sent it.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(second, m, std::regex(R"(connected to [^;]*; (\d+) messages queued)"))) << second;
  std::printf("[ resumed  ] %s messages were still queued after the SIGKILL; %g duplicates\n", m[1].str().c_str(),
              test::json_number(report, "duplicates"));
  EXPECT_GT(std::stoi(m[1]), 1000) << "the kill came after the drain: nothing left to resume";
}

// The disk full under the queue (a file-size limit makes its writes fail, as ENOSPC would): flagged in
// the log and counted, and every pair is measured and published all the same.
TEST_F(UplinkBroker, DiskFullUnderTheQueueIsFlaggedAndMeasuringGoesOn) {
  stop_broker();  // nothing leaves, so the queue only grows
  const fs::path cfg = config("full", "truck-7");
  const fs::path log = dir() / "full.log";
  // The limit is rutd's alone: its candump log (stdout, through fd 3) and its own log (stderr) each go
  // through a pipe to a writer without it. Written by rutd directly, the log would hit the limit too on
  // a slow build (about 1 kB a second), and its last lines, the final summary, would be lost.
  ASSERT_EQ(run_shell("bash -c 'set -o pipefail; { prlimit --fsize=40000 \"$0\" run --config \"$1\" --candump - "
                      "--frames 240 2>&1 1>&3 | cat >\"$2\"; } 3>&1 | cat >\"$3\"' " +
                      test::quoted(RUTD_BINARY) + " " + test::quoted(cfg) + " " + test::quoted(log) + " " +
                      test::quoted(dir() / "can.log")),
            0)
      << read_text(log);
  const std::string text = read_text(log);
  EXPECT_GE(count_lines(text, "cannot queue"), 1) << text;
  EXPECT_GT(summary_number(text, "queue write errors"), 0) << text;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"(stopped: acquired \d+ \([^)]*\) published (\d+))"))) << text;
  EXPECT_GE(std::stoi(m[1]), 240) << text;
  // On CAN, decoded by canmatrix: RutUplinkStatus after every status, link down, the queue growing, and
  // the queue write error flagged.
  bool ok = false;
  const auto frames = test::decode_candump(dir() / "can.log", ok);
  EXPECT_TRUE(ok);
  const auto uplink = test::frames_of(frames, "RutUplinkStatus");
  EXPECT_EQ(uplink.size(), test::frames_of(frames, "RutSensorStatus").size());
  ASSERT_GE(uplink.size(), 50u);
  int queue_errors = 0;
  for (const auto& f : uplink) {
    EXPECT_EQ(f.named.at("UplinkLink"), "DOWN");
    queue_errors += f.phys.at("UplinkQueueError") == 1;
  }
  EXPECT_GE(queue_errors, 1);
  EXPECT_GT(uplink.back().phys.at("UplinkQueued"), 0);
  EXPECT_GT(uplink.back().phys.at("UplinkOldestUnsent"), 1);
}

// Wrong credentials, a CA that did not sign the broker's certificate, a server that accepts and drops:
// one clear error each in the log however often it is retried, with back-off; measuring unaffected.
TEST_F(UplinkBroker, RefusalsGiveOneClearErrorEachAndAreRetried) {
  struct Case {
    std::string name, extra, credentials, expect;
  };
  const int dropper = test::free_loopback_port();
  test::ProcessGroup drop(
      {kPython, "-c",
       "import socket\ns=socket.socket()\ns.setsockopt(socket.SOL_SOCKET,socket.SO_REUSEADDR,1)\n"
       "s.bind(('127.0.0.1'," +
           std::to_string(dropper) + "))\ns.listen(8)\nwhile True:\n  c,_=s.accept()\n  c.recv(4096)\n  c.close()\n"},
      dir() / "dropper.log");
  ASSERT_TRUE(test::wait_for_port(dropper, 5s));
  const Case cases[] = {
      {"wrong-password", "", "wrong", "refused the connection: Connection Refused: not authorised."},
      {"wrong-ca", "  ca_file: " + (dir() / "other-ca.crt").string() + "\n", "", "the TLS handshake with"},
      {"dropper", "  port: " + std::to_string(dropper) + "\n  ca_file: \"\"\n", "",
       "closed the connection before accepting it"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    // Later keys of the same name win in the YAML written: the case's port or CA replace the defaults.
    const fs::path cfg = dir() / (c.name + ".yaml");
    std::string text = read_text(config(c.name, "truck-7", "", c.credentials));
    if (!c.extra.empty()) {
      for (const std::string key : {"  port: ", "  ca_file: "}) {
        const auto at = c.extra.find(key);
        if (at == std::string::npos) continue;
        const auto from = text.find(key);
        text.replace(from, text.find('\n', from) - from + 1, c.extra.substr(at, c.extra.find('\n', at) - at + 1));
      }
    }
    std::ofstream(cfg) << text;
    const std::string log = run(cfg, "--frames 150");
    EXPECT_EQ(count_lines(log, c.expect), 1) << log;
    EXPECT_EQ(count_lines(log, "warning uplink: "), 1) << "one warning, however many attempts\n" << log;
    EXPECT_GE(summary_number(log, "failed connections"), 3) << "retried with back-off\n" << log;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(log, m, std::regex(R"(stopped: acquired \d+ \([^)]*\) published (\d+))"))) << log;
    EXPECT_GE(std::stoi(m[1]), 150);
  }
}

// A client certificate instead of a password (the broker's second listener requires one and takes its
// common name as the user name, so the ACL applies as with passwords).
TEST_F(UplinkBroker, AClientCertificateAuthenticatesTheVehicle) {
  const fs::path cfg = dir() / "certificate.yaml";
  std::string text = read_text(config("certificate", "truck-7"));
  auto set = [&](const std::string& key, const std::string& value) {
    const auto from = text.find("  " + key + ": ");
    text.replace(from, text.find('\n', from) - from, "  " + key + ": " + value);
  };
  set("port", std::to_string(cert_port_));
  set("credentials_file", "\"\"");
  text.replace(
      text.find("  health_period_s"), 0,
      "  cert_file: " + (dir() / "truck-7.crt").string() + "\n  key_file: " + (dir() / "truck-7.key").string() + "\n");
  std::ofstream(cfg) << text;
  const std::string log = run(cfg, "--frames 90");
  EXPECT_EQ(count_lines(log, "warning uplink: "), 0) << log;
  const std::string report = received();
  EXPECT_GE(test::json_number(report, "distinct_ids"), 3) << log;
  EXPECT_EQ(test::json_number(report, "missing"), 0);
  EXPECT_EQ(test::json_number(report, "invalid"), 0);
}

// The ACL: truck-8's credentials may publish only under rutd/truck-8/, so a vehicle configured as
// truck-7 with them reaches no subscriber (the broker drops what the ACL refuses); as truck-8 it does.
TEST_F(UplinkBroker, AVehiclePublishesOnlyUnderItsOwnPrefix) {
  run(config("impostor", "truck-7", "", "truck-8"), "--frames 90");
  run(config("itself", "truck-8"), "--frames 90");
  const std::string report = received();
  EXPECT_EQ(report.find("\"truck-7\""), std::string::npos) << "the ACL let truck-8 publish as truck-7";
  EXPECT_NE(report.find("\"truck-8\""), std::string::npos);
  EXPECT_EQ(test::json_number(report, "invalid"), 0);
}

}  // namespace
}  // namespace rutd
