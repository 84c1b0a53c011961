// BusOff and CanTxDrops on the status frame, propagated by the CAN sink from the bus it sends on. The
// bus is a SocketCanBus on one end of a datagram socketpair instead of a CAN_RAW socket (CI has no
// kernel CAN): the sink's frames go through the same write call, a full queue makes that write fail
// with EAGAIN as a full CAN transmit queue does, and error frames written into the other end arrive
// through the same recv. The candump log the sink writes is decoded with config/rutd.dbc by canmatrix.
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "can/can_sink.hpp"
#include "decoded_candump.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

void write_error_frame(int fd, canid_t error_class) {
  struct can_frame f {};
  f.can_id = CAN_ERR_FLAG | error_class;
  f.len = CAN_ERR_DLC;
  ASSERT_EQ(::write(fd, &f, sizeof f), static_cast<ssize_t>(sizeof f));
}

// Reads and discards everything the bus sent.
int drain(int fd) {
  int n = 0;
  struct can_frame f {};
  while (::recv(fd, &f, sizeof f, MSG_DONTWAIT) > 0) ++n;
  return n;
}

TEST(CanSinkStatus, BusOffAndTransmitDropsReachTheStatusFrame) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, sv), 0);
  const test::TempDir tmp;
  const auto log_path = tmp.path() / "can.log";
  {
    std::ofstream log_stream(log_path);
    CandumpLogWriter log(log_stream, "fake0");
    const std::unique_ptr<SocketCanBus> owned = SocketCanBus::adopt(sv[0], "fake0");  // owns sv[0]
    SocketCanBus& bus = *owned;
    CanSink sink(CanIdConfig{}, &bus, &log, &log_stream);
    SensorHealth healthy;
    healthy.last_status = RutStatus::Ok;

    sink.publish_status(healthy, 0);  // 0: nothing wrong
    write_error_frame(sv[1], CAN_ERR_BUSOFF);
    sink.publish_status(healthy, 0);  // 1: bus off
    write_error_frame(sv[1], CAN_ERR_RESTARTED);
    sink.publish_status(healthy, 0);  // 2: back on the bus
    // Fill the queue: measurements go out until the write fails with EAGAIN (counted as dropped).
    PublishedFrame frame;
    frame.measurement.status = RutStatus::NoRut;
    frame.health = healthy;
    int published = 0;
    while (bus.stats().dropped == 0 && published < 1'000'000) {
      sink.publish(frame);
      ++published;
    }
    ASSERT_GT(bus.stats().dropped, 0u) << "the queue never filled";
    drain(sv[1]);
    sink.publish_status(healthy, 0);  // 3: drops in this period
    sink.publish_status(healthy, 0);  // 4: none since
  }
  ::close(sv[1]);

  bool ok = false;
  const auto status = test::frames_of(test::decode_candump(log_path, ok), "RutSensorStatus");
  // The drops happened mid-measurement, so the log may end a RutMeasurement1 without its partner:
  // only the status frames are judged here, and their CRCs and counters by the decoder's own report.
  ASSERT_EQ(status.size(), 5u);
  const int want_bus_off[] = {0, 1, 0, 0, 0};
  const int want_drops[] = {0, 0, 0, 1, 0};
  for (std::size_t i = 0; i < status.size(); ++i) {
    EXPECT_EQ(status[i].phys.at("BusOff"), want_bus_off[i]) << "status frame " << i;
    EXPECT_EQ(status[i].phys.at("CanTxDrops"), want_drops[i]) << "status frame " << i;
    EXPECT_EQ(status[i].named.at("RutS_LastStatus"), "OK") << "status frame " << i;
  }
}

// RutSoftwareVersion: with the first status frame, then with the first status frame a second or more after
// the last one (status time), decoded by canmatrix; a sink given no version sends none.
TEST(CanSinkStatus, SoftwareVersionGoesOutWithTheFirstStatusThenOnceASecond) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const auto with_path = tmp.path() / "with.log";
  const auto without_path = tmp.path() / "without.log";
  const SoftwareVersion version{2, 17, 3, 4, 0xC0FFE, true, true};
  {
    std::ofstream with_stream(with_path);
    std::ofstream without_stream(without_path);
    CandumpLogWriter with_log(with_stream, "can0");
    CandumpLogWriter without_log(without_stream, "can0");
    CanSink with(CanIdConfig{}, nullptr, &with_log, &with_stream, {}, CandumpTime::WallClock, version);
    CanSink without(CanIdConfig{}, nullptr, &without_log, &without_stream);
    // 100 ms status period from t = 5 s for 2.55 s: versions at 5.0, 6.0 and 7.0 s.
    for (std::int64_t t = 5'000'000'000; t <= 7'550'000'000; t += 100'000'000) {
      with.publish_status(SensorHealth{}, t);
      without.publish_status(SensorHealth{}, t);
    }
  }
  bool ok = false;
  const auto frames = test::decode_candump(with_path, ok);
  EXPECT_TRUE(ok) << "the decoder reported a CRC, counter or unknown frame";
  std::vector<std::size_t> version_at;  // index among the status frames of the frame each version follows
  std::size_t statuses = 0;
  for (const auto& f : frames) {
    if (f.message == "RutSensorStatus") ++statuses;
    if (f.message != "RutSoftwareVersion") continue;
    version_at.push_back(statuses - 1);
    EXPECT_EQ(f.phys.at("SwVersionMajor"), 2);
    EXPECT_EQ(f.phys.at("SwVersionMinor"), 17);
    EXPECT_EQ(f.phys.at("SwVersionPatch"), 3);
    EXPECT_EQ(f.phys.at("SwPackageRevision"), 4);
    EXPECT_EQ(f.phys.at("SwCommit"), 0xC0FFE);
    EXPECT_EQ(f.phys.at("SwModified"), 1);
    EXPECT_EQ(f.phys.at("SwCommitUnknown"), 0);
  }
  EXPECT_EQ(statuses, 26u);
  EXPECT_EQ(version_at, (std::vector<std::size_t>{0, 10, 20}));
  bool without_ok = false;
  EXPECT_TRUE(test::frames_of(test::decode_candump(without_path, without_ok), "RutSoftwareVersion").empty());
  EXPECT_TRUE(without_ok);
}

// RutMotion follows each measurement's RutConditions (same counter) once enabled, with the frame's motion
// and fix, decoded by canmatrix; a sink not enabled sends three frames a measurement, as before.
TEST(CanSinkStatus, MotionFollowsEveryMeasurementOnceEnabled) {
  if (!test::have_canmatrix()) RUTD_SKIP_NEEDS_INSTALLED("needs /usr/bin/python3 with canmatrix (python3-canmatrix)");
  const test::TempDir tmp;
  const auto with_path = tmp.path() / "with.log", without_path = tmp.path() / "without.log";
  {
    std::ofstream with_stream(with_path), without_stream(without_path);
    CandumpLogWriter with_log(with_stream, "can0"), without_log(without_stream, "can0");
    CanSink with(CanIdConfig{}, nullptr, &with_log, &with_stream);
    CanSink without(CanIdConfig{}, nullptr, &without_log, &without_stream);
    with.enable_motion();
    PublishedFrame frame;
    for (int k = 0; k < 20; ++k) {
      frame.t_ns = 1'000'000'000 + k * 33'333'333LL;
      frame.motion.state = k < 10 ? SpeedState::Ok : SpeedState::Stale;
      frame.motion.speed_mm_s = k < 10 ? -1000.0 * k : 0.0;
      frame.motion.distance_m = k < 10 ? 0.25 * k : std::nan("");
      frame.position.mode = k % 2 ? GeoFix::Mode::Fix2d : GeoFix::Mode::NoFix;
      with.publish(frame);
      without.publish(frame);
    }
  }
  bool ok = false, without_ok = false;
  const auto frames = test::decode_candump(with_path, ok);
  EXPECT_TRUE(ok) << "the decoder reported a CRC, counter or unknown frame";
  ASSERT_EQ(frames.size(), 80u);
  for (int k = 0; k < 20; ++k) {
    const auto& conditions = frames[static_cast<std::size_t>(4 * k + 2)];
    const auto& f = frames[static_cast<std::size_t>(4 * k + 3)];
    ASSERT_EQ(conditions.message, "RutConditions");
    ASSERT_EQ(f.message, "RutMotion") << k;
    EXPECT_EQ(f.raw.at("RutMo_Counter"), conditions.raw.at("RutC_Counter"));
    EXPECT_EQ(f.named.at("SpeedState"), k < 10 ? "OK" : "STALE") << k;
    EXPECT_EQ(f.named.at("PositionFix"), k % 2 ? "FIX_2D" : "NO_FIX") << k;
    if (k < 10) {
      EXPECT_NEAR(f.phys.at("VehicleSpeed"), -3.6 * k, 0.005) << k;
      EXPECT_NEAR(f.phys.at("TrackDistance"), 0.25 * k, 0.005) << k;
    } else {
      EXPECT_TRUE(f.na.at("VehicleSpeed")) << k;
      EXPECT_TRUE(f.na.at("TrackDistance")) << k;
    }
  }
  const auto plain = test::decode_candump(without_path, without_ok);
  EXPECT_TRUE(without_ok);
  EXPECT_EQ(plain.size(), 60u);
  EXPECT_TRUE(test::frames_of(plain, "RutMotion").empty());
}

}  // namespace
}  // namespace rutd
