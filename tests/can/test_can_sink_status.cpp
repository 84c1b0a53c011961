// BusOff and CanTxDrops on the status frame, propagated by the CAN sink from the bus it sends on. The
// bus is a SocketCanBus on one end of a datagram socketpair instead of a CAN_RAW socket (CI has no
// kernel CAN): the sink's frames go through the same write call, a full queue makes that write fail
// with EAGAIN as a full CAN transmit queue does, and error frames written into the other end arrive
// through the same recv. The candump log the sink writes is decoded with config/rutd.dbc by canmatrix.
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

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
    FrameWork work;
    work.measurement.status = RutStatus::NoRut;
    int published = 0;
    while (bus.stats().dropped == 0 && published < 1'000'000) {
      sink.publish(work, healthy);
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

}  // namespace
}  // namespace rutd
