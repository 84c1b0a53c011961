// The SocketCAN sink and the vehicle speed receiver. The pure helpers are checked against the constants of
// <linux/can.h> and <linux/can/error.h> written out as numbers (the kernel ABI), so they run everywhere. The tests of
// the sink itself need a kernel with CAN and a virtual bus (RUTD_TEST_CAN_INTERFACE, default vcan0):
// they skip on a machine without them, and test_socketcan_qemu runs them inside a guest kernel that
// has both (the receiver's decoding and queue are tested without a kernel in test_vehicle_speed and
// test_trafficability_live). An independent CAN_RAW socket opened by the test is the truth for what reached the bus.
//
// Environment: RUTD_TEST_CAN_INTERFACE  the virtual CAN interface to use (default vcan0)
//              RUTD_SOCKETCAN_SENT_LOG  if set, EncodedFramesArriveUnchanged also writes the frames it
//                                       sent there as a candump log (for the qemu test's candump check)
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <streambuf>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "can/can_encoder.hpp"
#include "can/candump_log.hpp"
#include "can/socketcan_bus.hpp"
#include "can/vehicle_speed.hpp"
#include "can/vehicle_speed_receiver.hpp"
#include "skip_policy.hpp"

namespace rutd {
namespace {

// ---------------------------------------------------------------------------------------------------
// Pure helpers: kernel ABI values written out (can_id flags: EFF 0x80000000, RTR 0x40000000,
// ERR 0x20000000; error classes: TX_TIMEOUT 0x1, CRTL 0x4, BUSOFF 0x40, BUSERROR 0x80, RESTARTED 0x100).

CanFrame frame(std::uint32_t id, bool extended, std::vector<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

struct can_frame kernel_frame(canid_t can_id, std::vector<std::uint8_t> bytes) {
  struct can_frame k;
  std::memset(&k, 0, sizeof k);
  k.can_id = can_id;
  k.len = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), k.data);
  return k;
}

TEST(SocketCanFrameConversion, ExtendedIdentifierCarriesEffFlag) {
  const auto k = to_kernel_frame(frame(0x18FF50A0, true, {1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(k.can_id, 0x98FF50A0u);
  ASSERT_EQ(k.len, 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(k.data[i], i + 1);
}

TEST(SocketCanFrameConversion, StandardIdentifierHasNoFlags) {
  const auto k = to_kernel_frame(frame(0x350, false, {0xA1, 0xB2}));
  EXPECT_EQ(k.can_id, 0x350u);
  ASSERT_EQ(k.len, 2);
  EXPECT_EQ(k.data[0], 0xA1);
  EXPECT_EQ(k.data[1], 0xB2);
  for (int i = 2; i < 8; ++i) EXPECT_EQ(k.data[i], 0) << "byte " << i;
}

TEST(SocketCanFrameConversion, IdentifierBitsBeyondTheFormatAreDropped) {
  EXPECT_EQ(to_kernel_frame(frame(0xFFFFFFFF, true, {})).can_id, 0x9FFFFFFFu);
  EXPECT_EQ(to_kernel_frame(frame(0xFFFFFFFF, false, {})).can_id, 0x7FFu);
}

TEST(SocketCanFrameConversion, LengthIsCappedAtEight) {
  CanFrame f = frame(0x123, false, {1, 2, 3, 4, 5, 6, 7, 8});
  f.len = 12;
  EXPECT_EQ(to_kernel_frame(f).len, 8);
}

TEST(SocketCanFrameConversion, RoundTripsEveryLengthAndBothFormats) {
  for (bool extended : {false, true}) {
    for (std::uint8_t len = 0; len <= 8; ++len) {
      CanFrame f;
      f.id = extended ? 0x1ABCDE12 : 0x5A5;
      f.extended = extended;
      f.len = len;
      for (int i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(0x10 * i + len);
      const auto back = from_kernel_frame(to_kernel_frame(f));
      ASSERT_TRUE(back.has_value());
      EXPECT_EQ(*back, f) << "extended " << extended << " len " << int(len);
    }
  }
}

TEST(SocketCanFrameConversion, FromKernelRejectsWhatRutdNeverSends) {
  EXPECT_FALSE(from_kernel_frame(kernel_frame(0x20000040, {0, 0, 0, 0, 0, 0, 0, 0})));  // error frame
  EXPECT_FALSE(from_kernel_frame(kernel_frame(0x40000123, {})));                        // remote frame
  auto too_long = kernel_frame(0x123, {1, 2, 3, 4, 5, 6, 7, 8});
  too_long.len = 9;
  EXPECT_FALSE(from_kernel_frame(too_long));
  const auto ok = from_kernel_frame(kernel_frame(0x98FF52A0, {9}));
  ASSERT_TRUE(ok);
  EXPECT_TRUE(ok->extended);
  EXPECT_EQ(ok->id, 0x18FF52A0u);
}

TEST(SocketCanErrorFrames, DataFrameIsNotAnErrorFrame) {
  EXPECT_FALSE(classify_error_frame(kernel_frame(0x98FF50A0, {1})));
  EXPECT_FALSE(classify_error_frame(kernel_frame(0x040, {})));  // BUSOFF's bit without the ERR flag
}

TEST(SocketCanErrorFrames, ClassesAreRecognised) {
  const auto bus_off = classify_error_frame(kernel_frame(0x20000040, {0, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(bus_off);
  EXPECT_TRUE(bus_off->bus_off);
  EXPECT_FALSE(bus_off->restarted || bus_off->controller || bus_off->tx_timeout);

  const auto restarted = classify_error_frame(kernel_frame(0x20000100, {0, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(restarted);
  EXPECT_TRUE(restarted->restarted);
  EXPECT_FALSE(restarted->bus_off);

  // Controller problem: TX error passive (0x20) in data[1].
  const auto passive = classify_error_frame(kernel_frame(0x20000004, {0, 0x20, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(passive);
  EXPECT_TRUE(passive->controller);
  EXPECT_EQ(passive->controller_status, 0x20);

  const auto timeout = classify_error_frame(kernel_frame(0x20000001, {0, 0x20, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(timeout);
  EXPECT_TRUE(timeout->tx_timeout);
  EXPECT_EQ(timeout->controller_status, 0) << "data[1] only means something with the CRTL class";

  const auto both = classify_error_frame(kernel_frame(0x20000044, {0, 0x40, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(both);
  EXPECT_TRUE(both->bus_off && both->controller);
}

TEST(SocketCanErrorFrames, SubscribedClassesAreTheControllerStateOnes) {
  EXPECT_EQ(socketcan_error_mask(), 0x145u);  // TX_TIMEOUT | CRTL | BUSOFF | RESTARTED
}

TEST(SocketCanSendErrors, QueueFullIsADropAnythingElseAWriteError) {
  EXPECT_EQ(classify_send_errno(ENOBUFS), SendOutcome::Dropped);
  EXPECT_EQ(classify_send_errno(EAGAIN), SendOutcome::Dropped);
  EXPECT_EQ(classify_send_errno(ENETDOWN), SendOutcome::Failed);
  EXPECT_EQ(classify_send_errno(ENXIO), SendOutcome::Failed);
  EXPECT_EQ(classify_send_errno(EINVAL), SendOutcome::Failed);
}

TEST(SocketCanBusState, BusOffSetByErrorFrameClearedByRestartOrSend) {
  CanBusState state;
  EXPECT_FALSE(state.bus_off());
  CanErrorEvent bus_off;
  bus_off.bus_off = true;
  CanErrorEvent restarted;
  restarted.restarted = true;
  CanErrorEvent warning;
  warning.controller = true;

  state.on_error_frame(warning);
  EXPECT_FALSE(state.bus_off());
  state.on_error_frame(bus_off);
  EXPECT_TRUE(state.bus_off());
  state.on_send(SendOutcome::Dropped);
  state.on_send(SendOutcome::Failed);
  EXPECT_TRUE(state.bus_off()) << "failed sends say nothing about recovery";
  state.on_error_frame(restarted);
  EXPECT_FALSE(state.bus_off());
  state.on_error_frame(bus_off);
  EXPECT_TRUE(state.bus_off());
  state.on_send(SendOutcome::Sent);
  EXPECT_FALSE(state.bus_off()) << "a controller that takes frames again is back on the bus";

  const SocketCanStats& s = state.stats();
  EXPECT_EQ(s.sent, 1u);
  EXPECT_EQ(s.dropped, 1u);
  EXPECT_EQ(s.write_errors, 1u);
  EXPECT_EQ(s.error_frames, 4u);
  EXPECT_EQ(s.bus_off_events, 2u);
}

// Needs no CAN support: without it socket() fails, with it if_nametoindex() does; either way the
// error must name the interface.
TEST(SocketCanBusOpen, FailureNamesTheInterface) {
  try {
    SocketCanBus sink("rutdnosuch0");
    FAIL() << "opened a non-existent interface";
  } catch (const std::system_error& e) {
    EXPECT_NE(std::string(e.what()).find("rutdnosuch0"), std::string::npos) << e.what();
  }
  try {
    SocketCanBus sink("an-interface-name-too-long");
    FAIL() << "accepted a name longer than IFNAMSIZ - 1";
  } catch (const std::system_error& e) {
    EXPECT_NE(std::string(e.what()).find("an-interface-name-too-long"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------------
// On a kernel with CAN and a virtual CAN interface.

std::string test_interface() {
  const char* name = std::getenv("RUTD_TEST_CAN_INTERFACE");
  return name != nullptr && *name != '\0' ? name : "vcan0";
}

// Empty if the kernel tests can run, else why not.
std::string kernel_can_unavailable() {
  const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return "kernel without CAN support: socket(AF_CAN) failed: " + std::string(std::strerror(errno));
  ::close(fd);
  if (if_nametoindex(test_interface().c_str()) == 0) {
    return "no CAN interface " + test_interface() +
           " (ip link add dev vcan0 type vcan; or set RUTD_TEST_CAN_INTERFACE)";
  }
  return {};
}

// A plain CAN_RAW socket on the test interface: the independent observer of the bus. Receives data
// frames (and the error classes in `error_mask`), with a 2 s receive timeout.
class BusObserver {
 public:
  explicit BusObserver(can_err_mask_t error_mask = 0) {
    fd_ = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "observer socket");
    setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof error_mask);
    const timeval timeout{2, 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(if_nametoindex(test_interface().c_str()));
    if (bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::system_error(errno, std::generic_category(), "observer bind");
    }
  }
  ~BusObserver() { ::close(fd_); }
  BusObserver(const BusObserver&) = delete;
  BusObserver& operator=(const BusObserver&) = delete;

  // The next frame on the bus, or nothing after the timeout.
  std::optional<struct can_frame> receive() {
    struct can_frame k;
    if (::read(fd_, &k, sizeof k) != static_cast<ssize_t>(sizeof k)) return std::nullopt;
    return k;
  }

  // Puts a frame on the bus as a controller driver would (vcan loops error frames back like any).
  bool inject(const struct can_frame& k) { return ::write(fd_, &k, sizeof k) == static_cast<ssize_t>(sizeof k); }

 private:
  int fd_ = -1;
};

class SocketCanBusOnKernel : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string why = kernel_can_unavailable();
    if (!why.empty()) RUTD_SKIP_NEEDS_HARDWARE(why);
  }
};

// Measurements and status frames as rutd encodes them go out unchanged and in order; the sink's
// socket receives neither its own frames nor other data frames.
TEST_F(SocketCanBusOnKernel, EncodedFramesArriveUnchanged) {
  BusObserver observer;
  SocketCanBus sink(test_interface());
  CanEncoder encoder;
  std::vector<CanFrame> sent;
  for (int i = 0; i < 5; ++i) {
    RutMeasurement m;
    m.status = i == 3 ? RutStatus::NoRut : RutStatus::Ok;
    m.depth_mm = 40.0 + i;
    m.width_mm = 250.0;
    m.left_pile_mm = 12.5;
    m.right_pile_mm = 9.0;
    m.area_mm2 = 6000.0 + 100.0 * i;
    m.ground_slope_deg = -1.5;
    m.center_x_mm = 20.0;
    m.quality = 0.9;
    std::array<CanFrame, 2> frames;
    const int n = encoder.encode_measurement(m, frames);
    for (int k = 0; k < n; ++k) sent.push_back(frames[k]);
    SensorHealth health;
    health.frame_rate_hz = 30.0;
    health.last_status = m.status;
    sent.push_back(encoder.encode_status(health));
  }
  for (const CanFrame& f : sent) ASSERT_TRUE(sink.send(f)) << "write failed: " << std::strerror(errno);

  for (std::size_t i = 0; i < sent.size(); ++i) {
    const auto k = observer.receive();
    ASSERT_TRUE(k.has_value()) << "frame " << i << " never reached the bus";
    const auto seen = from_kernel_frame(*k);
    ASSERT_TRUE(seen.has_value()) << "frame " << i << " arrived as can_id " << std::hex << k->can_id;
    EXPECT_EQ(*seen, sent[i]) << "frame " << i;
  }
  sink.poll_errors();
  EXPECT_EQ(sink.stats().sent, sent.size());
  EXPECT_EQ(sink.stats().dropped + sink.stats().write_errors + sink.stats().error_frames, 0u);
  EXPECT_FALSE(sink.bus_off());

  if (const char* log_path = std::getenv("RUTD_SOCKETCAN_SENT_LOG")) {
    std::ofstream log(log_path);
    CandumpLogWriter writer(log, test_interface());
    for (std::size_t i = 0; i < sent.size(); ++i) {
      ASSERT_TRUE(writer.write(sent[i], static_cast<std::int64_t>(i) * 1000)) << log_path;
    }
  }
}

TEST_F(SocketCanBusOnKernel, StandardIdentifiersAndShortFramesArriveUnchanged) {
  BusObserver observer;
  SocketCanBus sink(test_interface());
  const std::vector<CanFrame> sent = {frame(0x350, false, {}), frame(0x351, false, {0xFF}),
                                      frame(0x7FF, false, {1, 2, 3}), frame(0x00000001, true, {4, 5, 6, 7})};
  for (const CanFrame& f : sent) ASSERT_TRUE(sink.send(f));
  for (const CanFrame& want : sent) {
    const auto k = observer.receive();
    ASSERT_TRUE(k.has_value());
    EXPECT_EQ(from_kernel_frame(*k), want);
  }
}

// Error frames as a controller driver raises them: bus-off sets the state, restart clears it, and
// classes the sink did not subscribe to (bus errors) do not reach it.
TEST_F(SocketCanBusOnKernel, ErrorFramesDriveBusOff) {
  BusObserver injector;
  // vcan hands a frame to its receivers in a softirq that a loaded machine can run after write() returns.
  // The witness is bound before the sink, and the kernel delivers to the newest receiver first, so once
  // the witness has a frame the sink has it too.
  BusObserver witness(CAN_ERR_MASK);
  SocketCanBus sink(test_interface());
  auto inject = [&](can_err_mask_t error_class) {
    if (!injector.inject(kernel_frame(CAN_ERR_FLAG | error_class, {0, 0, 0, 0, 0, 0, 0, 0}))) return false;
    const std::optional<struct can_frame> seen = witness.receive();
    return seen.has_value() && (seen->can_id & CAN_ERR_MASK) == error_class;
  };
  ASSERT_TRUE(inject(CAN_ERR_BUSERROR)) << std::strerror(errno);
  ASSERT_TRUE(inject(CAN_ERR_BUSOFF));
  sink.poll_errors();
  EXPECT_TRUE(sink.bus_off());
  EXPECT_EQ(sink.stats().error_frames, 1u) << "the bus-error frame is not subscribed";
  EXPECT_EQ(sink.stats().bus_off_events, 1u);

  ASSERT_TRUE(inject(CAN_ERR_RESTARTED));
  sink.poll_errors();
  EXPECT_FALSE(sink.bus_off());

  ASSERT_TRUE(inject(CAN_ERR_BUSOFF));
  sink.poll_errors();
  EXPECT_TRUE(sink.bus_off());
  EXPECT_TRUE(sink.send(frame(0x18FF52A0, true, {0})));
  EXPECT_FALSE(sink.bus_off()) << "a successful send ends bus-off";
  EXPECT_EQ(sink.stats().error_frames, 3u);
  EXPECT_EQ(sink.stats().bus_off_events, 2u);
  sink.poll_errors();  // nothing pending: must return at once
  EXPECT_EQ(sink.stats().error_frames, 3u);
}

// Sets an interface's administrative state; restores the original on destruction.
class InterfaceState {
 public:
  explicit InterfaceState(const std::string& name) : fd_(socket(AF_INET, SOCK_DGRAM, 0)) {
    std::memset(&request_, 0, sizeof request_);
    std::strncpy(request_.ifr_name, name.c_str(), IFNAMSIZ - 1);
    ok_ = fd_ >= 0 && ioctl(fd_, SIOCGIFFLAGS, &request_) == 0;
    original_flags_ = request_.ifr_flags;
  }
  ~InterfaceState() {
    if (ok_) set_flags(original_flags_);
    if (fd_ >= 0) ::close(fd_);
  }
  InterfaceState(const InterfaceState&) = delete;
  InterfaceState& operator=(const InterfaceState&) = delete;

  bool set_up(bool up) {
    return ok_ && set_flags(static_cast<short>(up ? (original_flags_ | IFF_UP) : (original_flags_ & ~IFF_UP)));
  }

 private:
  bool set_flags(short flags) {
    request_.ifr_flags = flags;
    return ioctl(fd_, SIOCSIFFLAGS, &request_) == 0;
  }
  int fd_;
  ifreq request_;
  short original_flags_ = 0;
  bool ok_ = false;
};

// A write to an interface that is down fails at once and is counted, without blocking or throwing.
TEST_F(SocketCanBusOnKernel, InterfaceDownIsAWriteError) {
  SocketCanBus sink(test_interface());
  InterfaceState state(test_interface());
  if (!state.set_up(false))
    RUTD_SKIP_NEEDS_HARDWARE("cannot set " << test_interface() << " down (needs CAP_NET_ADMIN)");
  EXPECT_FALSE(sink.send(frame(0x18FF50A0, true, {1})));
  EXPECT_EQ(sink.stats().write_errors, 1u);
  EXPECT_EQ(sink.stats().dropped, 0u);
  ASSERT_TRUE(state.set_up(true));
  EXPECT_TRUE(sink.send(frame(0x18FF50A0, true, {1})));
  EXPECT_EQ(sink.stats().sent, 1u);
}

// ---------------------------------------------------------------------------------------------------
// The vehicle speed receiver on a kernel: what its kernel filters pass, and the kernel's count of the
// frames its full receive queue dropped (SO_RXQ_OVFL).

class VehicleSpeedOnKernel : public SocketCanBusOnKernel {
 protected:
  // Waits up to 5 s (the guest is emulated) for the receiver to have read `frames` frames.
  static bool wait_for_frames(const VehicleSpeedReceiver& receiver, std::uint64_t frames) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (receiver.stats().decoded.frames < frames) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }
};

// The speed (CCVS1) and gear (ETC2) messages from any sender pass; the same identifiers as standard
// frames or remote requests, other parameter groups and error frames do not reach the decoder (its
// count of other identifiers stays 0), and what passed is logged in candump format in order.
TEST_F(VehicleSpeedOnKernel, FiltersPassOnlyTheSpeedAndTheGear) {
  BusObserver bus;
  VehicleSpeedConfig config;
  config.direction_from_gear = true;
  // No burst window: the receiver stamps a frame when it reads it, and a thread descheduled for more
  // than the 10 ms between two speed frames (ASan in the emulated guest on CI) reads them back to back,
  // which the decoder rightly counts as a burst. This test is about what the filters pass; the burst
  // rule has its own tests on the decoder.
  config.min_interval_ns = 0;
  std::ostringstream log;
  VehicleSpeedReceiver receiver(test_interface(), config, &log, "can0");
  const CanFrame ccvs = encode_ccvs1(10.8, 0x00);
  const CanFrame etc2 = encode_etc2_gear(1, 0x03);
  std::vector<struct can_frame> foreign = {
      kernel_frame(0x98FEF200, {1, 2, 3, 4, 5, 6, 7, 8}),  // another parameter group (the flood's)
      kernel_frame(0x0F1, {0xFF, 0x00, 0x19, 0xFF}),       // a standard frame with CCVS1's low bits
      kernel_frame(0xD8FEF100, {}),                        // a remote request for CCVS1 (EFF | RTR)
      kernel_frame(0x20000040, {0, 0, 0, 0, 0, 0, 0, 0}),  // an error frame (bus off)
      kernel_frame(0x98FEF000, {0xFF, 0x00, 0x19, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}),  // PGN 0xFEF0
  };
  std::vector<CanFrame> passed;
  for (int i = 0; i < 6; ++i) {
    const CanFrame& wanted = i % 3 == 0 ? etc2 : ccvs;
    ASSERT_TRUE(bus.inject(to_kernel_frame(wanted))) << std::strerror(errno);
    passed.push_back(wanted);
    for (const auto& k : foreign) ASSERT_TRUE(bus.inject(k)) << std::hex << k.can_id << ": " << std::strerror(errno);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(wait_for_frames(receiver, passed.size())) << "read " << receiver.stats().decoded.frames;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // a foreign frame would be read by now
  receiver.stop();
  const VehicleSpeedReceiverStats s = receiver.stats();
  EXPECT_EQ(s.decoded.frames, passed.size());
  EXPECT_EQ(s.decoded.other_id, 0u);
  EXPECT_EQ(s.decoded.gear_frames, 2u);
  EXPECT_EQ(s.decoded.ok, 4u);
  EXPECT_EQ(s.kernel_dropped + s.read_errors + s.log_errors + s.queue_full, 0u);
  std::istringstream lines(log.str());
  std::size_t n = 0;
  for (std::string line; std::getline(lines, line); ++n) {
    const auto parsed = parse_candump_line(line);
    ASSERT_TRUE(parsed) << line;
    ASSERT_LT(n, passed.size()) << line;
    EXPECT_EQ(parsed->first, passed[n]) << line;
  }
  EXPECT_EQ(n, passed.size()) << log.str();
}

// A stream buffer whose writes wait while its gate is closed: the receiver's thread, writing the log
// line of the first frame, stops there, and its socket's queue fills as a stalled process's would.
class GatedBuffer : public std::streambuf {
 public:
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  // Waits up to 5 s for a writer to wait at the gate.
  bool wait_for_writer() {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(5), [this] { return waiting_; });
  }

 protected:
  std::streamsize xsputn(const char*, std::streamsize n) override {
    wait_open();
    return n;
  }
  int_type overflow(int_type c) override {
    wait_open();
    return traits_type::not_eof(c);
  }

 private:
  void wait_open() {
    std::unique_lock lock(mutex_);
    waiting_ = true;
    changed_.notify_all();
    changed_.wait(lock, [this] { return open_; });
  }
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
  bool waiting_ = false;
};

// The receiver stalls (its log waits) while the vehicle sends: the kernel drops what the socket's
// queue cannot hold, and reports its count with the next frame queued. Every frame sent is either read
// or counted as dropped by the kernel, none twice; and the queue held frames, not nothing.
TEST_F(VehicleSpeedOnKernel, FramesTheKernelDroppedAreCountedExactly) {
  BusObserver bus;
  GatedBuffer gate;
  std::ostream log(&gate);
  VehicleSpeedReceiver receiver(test_interface(), VehicleSpeedConfig{}, &log, "can0");
  struct OpenAtExit {  // before the receiver's destructor joins its thread, whatever fails
    GatedBuffer& gate;
    ~OpenAtExit() { gate.open(); }
  } open_at_exit{gate};
  const struct can_frame ccvs = to_kernel_frame(encode_ccvs1(10.8, 0x00));
  std::uint64_t sent = 0;
  auto send = [&] {
    for (int attempt = 0; attempt < 1000; ++attempt) {
      if (bus.inject(ccvs)) return true;
      if (errno != ENOBUFS && errno != EAGAIN) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  };
  ASSERT_TRUE(send()) << std::strerror(errno);
  ++sent;
  ASSERT_TRUE(gate.wait_for_writer()) << "the receiver never logged its first frame";
  constexpr int kBurst = 5000;  // far beyond a default receive queue (about 200 frames)
  for (int i = 0; i < kBurst; ++i) {
    ASSERT_TRUE(send()) << "frame " << i << ": " << std::strerror(errno);
    ++sent;
  }
  EXPECT_EQ(receiver.stats().decoded.frames, 0u) << "the receiver read while its log waited";
  gate.open();
  // Drained when the count stops moving; then one more frame, queued after the drops, carries their count.
  std::uint64_t read = 0;
  for (int quiet = 0; quiet < 20; std::this_thread::sleep_for(std::chrono::milliseconds(10))) {
    const std::uint64_t now = receiver.stats().decoded.frames;
    quiet = now == read ? quiet + 1 : 0;
    read = now;
  }
  ASSERT_TRUE(send()) << std::strerror(errno);
  ++sent;
  ASSERT_TRUE(wait_for_frames(receiver, read + 1)) << "the frame after the drain was not read";
  receiver.stop();
  const VehicleSpeedReceiverStats s = receiver.stats();
  std::printf("[ kernel   ] sent %llu, read %llu, dropped by the kernel %llu\n", static_cast<unsigned long long>(sent),
              static_cast<unsigned long long>(s.decoded.frames), static_cast<unsigned long long>(s.kernel_dropped));
  EXPECT_GT(s.kernel_dropped, 0u);
  EXPECT_GT(s.decoded.frames, 10u) << "the socket's queue held next to nothing";
  EXPECT_EQ(s.decoded.frames + s.kernel_dropped, sent);
  EXPECT_EQ(s.read_errors, 0u);
}

}  // namespace
}  // namespace rutd
