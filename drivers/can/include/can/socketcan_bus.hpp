#pragma once
// Sends CAN frames on a Linux SocketCAN interface (can0, vcan0 ...) through a CAN_RAW socket, and
// watches the controller's error frames for bus-off. Linux only.
//
// The pure helpers below (frame conversion, error-frame classification, the bus state) need no
// kernel support and are what SocketCanBus is made of.
#include <linux/can.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "can/can_frame.hpp"
#include "core/io_faults.hpp"

namespace rutd {

// rutd's frame as the kernel's: 29-bit identifiers get CAN_EFF_FLAG, identifier bits above the
// frame's width are dropped, len is capped at 8.
struct can_frame to_kernel_frame(const CanFrame& frame) noexcept;

// The kernel's frame as rutd's, or nothing for what rutd never sends: error frames, remote frames,
// lengths above 8.
std::optional<CanFrame> from_kernel_frame(const struct can_frame& frame) noexcept;

// What one error frame (can_id with CAN_ERR_FLAG, see <linux/can/error.h>) says about the bus.
struct CanErrorEvent {
  bool bus_off = false;                // CAN_ERR_BUSOFF: the controller left the bus
  bool restarted = false;              // CAN_ERR_RESTARTED: the controller is back after bus-off
  bool controller = false;             // CAN_ERR_CRTL: error-warning/passive, overflow ...; details in data[1]
  bool tx_timeout = false;             // CAN_ERR_TX_TIMEOUT
  std::uint8_t controller_status = 0;  // data[1] with CAN_ERR_CRTL (CAN_ERR_CRTL_* bits), else 0
};

// Nothing if `frame` is not an error frame.
std::optional<CanErrorEvent> classify_error_frame(const struct can_frame& frame) noexcept;

// The error classes SocketCanBus subscribes to (CAN_RAW_ERR_FILTER). Bus errors and arbitration
// losses are left out: they can arrive at bus speed and say nothing the controller state does not.
std::uint32_t socketcan_error_mask() noexcept;

struct SocketCanStats {
  std::uint64_t sent = 0;
  std::uint64_t dropped = 0;         // transmit queue full (ENOBUFS/EAGAIN): the frame was not sent
  std::uint64_t write_errors = 0;    // any other failed write (interface down, short write ...)
  std::uint64_t error_frames = 0;    // error frames received, of the subscribed classes
  std::uint64_t bus_off_events = 0;  // error frames reporting bus-off
};

enum class SendOutcome { Sent, Dropped, Failed };

// How a failed write's errno counts: the queue-full errors are drops, anything else a write error.
SendOutcome classify_send_errno(int error_number) noexcept;

// Bus-off state and counters, driven by send outcomes and error frames. Bus-off is set by a bus-off
// error frame and cleared by a restarted one or by any successful send (a controller that takes
// frames again is back on the bus, even if its restart notice was missed).
class CanBusState {
 public:
  void on_send(SendOutcome outcome) noexcept;
  void on_error_frame(const CanErrorEvent& event) noexcept;
  bool bus_off() const noexcept { return bus_off_; }
  const SocketCanStats& stats() const noexcept { return stats_; }

 private:
  SocketCanStats stats_;
  bool bus_off_ = false;
};

class SocketCanBus {  // not thread-safe: owned by the publisher thread
 public:
  // Opens a CAN_RAW socket bound to `interface`, non-blocking, subscribed to socketcan_error_mask()'s
  // error frames and to no data frames, not receiving its own frames. Other sockets on the host still
  // see what it sends (CAN_RAW_LOOPBACK stays on, so candump on the same machine works). Throws
  // std::system_error whose what() names the interface if the socket cannot be opened or bound
  // (kernel without CAN support, no such interface, name too long).
  // faults: tests only (core/io_faults.hpp), IoPoint::CanWrite; not owned, must outlive the bus.
  explicit SocketCanBus(const std::string& interface, IoFaults* faults = nullptr);
  // Tests only: takes ownership of an open, connected, non-blocking datagram socket that stands in for
  // the CAN socket (a socketpair(AF_UNIX, SOCK_SEQPACKET) end: each write is one struct can_frame, which
  // the other end reads), named `interface` in messages. Machines without CAN kernel support can then
  // run the daemon's CAN path.
  static std::unique_ptr<SocketCanBus> adopt(int fd, const std::string& interface, IoFaults* faults = nullptr);
  ~SocketCanBus();
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  // Writes one frame. Never blocks: a full transmit queue (ENOBUFS/EAGAIN) drops the frame and counts
  // it; any other failure (ENETDOWN: interface down ...) counts as a write error. Returns true only if
  // the frame was queued.
  bool send(const CanFrame& frame) noexcept;

  // Reads the pending error frames without blocking (at most kMaxErrorFramesPerPoll a call, so a
  // flood cannot stall the caller) and updates the bus-off state and counters.
  void poll_errors() noexcept;
  static constexpr int kMaxErrorFramesPerPoll = 64;

  bool bus_off() const noexcept { return state_.bus_off(); }
  const SocketCanStats& stats() const noexcept { return state_.stats(); }
  const std::string& interface() const noexcept { return interface_; }

 private:
  SocketCanBus(int fd, const std::string& interface, IoFaults* faults) noexcept;
  std::string interface_;
  int fd_ = -1;
  IoFaults* faults_ = nullptr;
  CanBusState state_;
};

}  // namespace rutd
