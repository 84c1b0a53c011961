#include "can/socketcan_bus.hpp"

#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>
#include <utility>

namespace rutd {

struct can_frame to_kernel_frame(const CanFrame& frame) noexcept {
  struct can_frame out;
  std::memset(&out, 0, sizeof out);
  out.can_id = frame.extended ? (frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG : frame.id & CAN_SFF_MASK;
  out.len = std::min<std::uint8_t>(frame.len, CAN_MAX_DLEN);
  std::copy_n(frame.data.begin(), out.len, out.data);
  return out;
}

std::optional<CanFrame> from_kernel_frame(const struct can_frame& frame) noexcept {
  if ((frame.can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) != 0 || frame.len > CAN_MAX_DLEN) return std::nullopt;
  CanFrame out;
  out.extended = (frame.can_id & CAN_EFF_FLAG) != 0;
  out.id = frame.can_id & (out.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  out.len = frame.len;
  std::copy_n(frame.data, frame.len, out.data.begin());
  return out;
}

std::optional<CanErrorEvent> classify_error_frame(const struct can_frame& frame) noexcept {
  if ((frame.can_id & CAN_ERR_FLAG) == 0) return std::nullopt;
  CanErrorEvent event;
  event.bus_off = (frame.can_id & CAN_ERR_BUSOFF) != 0;
  event.restarted = (frame.can_id & CAN_ERR_RESTARTED) != 0;
  event.controller = (frame.can_id & CAN_ERR_CRTL) != 0;
  event.tx_timeout = (frame.can_id & CAN_ERR_TX_TIMEOUT) != 0;
  if (event.controller) event.controller_status = frame.data[1];
  return event;
}

std::uint32_t socketcan_error_mask() noexcept {
  return CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED;
}

SendOutcome classify_send_errno(int error_number) noexcept {
  return error_number == ENOBUFS || error_number == EAGAIN || error_number == EWOULDBLOCK ? SendOutcome::Dropped
                                                                                          : SendOutcome::Failed;
}

void CanBusState::on_send(SendOutcome outcome) noexcept {
  switch (outcome) {
    case SendOutcome::Sent:
      ++stats_.sent;
      bus_off_ = false;
      break;
    case SendOutcome::Dropped: ++stats_.dropped; break;
    case SendOutcome::Failed: ++stats_.write_errors; break;
  }
}

void CanBusState::on_error_frame(const CanErrorEvent& event) noexcept {
  ++stats_.error_frames;
  if (event.bus_off) {
    ++stats_.bus_off_events;
    bus_off_ = true;
  } else if (event.restarted) {
    bus_off_ = false;
  }
}

namespace {

[[noreturn]] void throw_for(int error_number, const std::string& interface, const char* what) {
  throw std::system_error(error_number, std::generic_category(), "SocketCAN interface '" + interface + "': " + what);
}

template <typename T>
void set_option(int fd, int option, const T* value, socklen_t size, const std::string& interface) {
  if (setsockopt(fd, SOL_CAN_RAW, option, value, size) != 0) throw_for(errno, interface, "setsockopt(SOL_CAN_RAW)");
}

// Configures and binds `fd`; throws on failure (the caller closes it).
void configure(int fd, const std::string& interface) {
  set_option<can_filter>(fd, CAN_RAW_FILTER, nullptr, 0, interface);  // no data frames: we only send
  const can_err_mask_t errors = socketcan_error_mask();
  set_option(fd, CAN_RAW_ERR_FILTER, &errors, sizeof errors, interface);
  const int own = 0;
  set_option(fd, CAN_RAW_RECV_OWN_MSGS, &own, sizeof own, interface);

  const unsigned index = if_nametoindex(interface.c_str());
  if (index == 0) throw_for(errno, interface, "no such network interface");
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    throw_for(errno, interface, "bind failed");
  }
}

}  // namespace

SocketCanBus::SocketCanBus(const std::string& interface, IoFaults* faults) : interface_(interface), faults_(faults) {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    throw_for(EINVAL, interface, "interface names are 1 to 15 characters");
  }
  fd_ = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) throw_for(errno, interface, "socket(AF_CAN) failed (kernel without CAN support?)");
  try {
    configure(fd_, interface);
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

SocketCanBus::SocketCanBus(int fd, const std::string& interface, IoFaults* faults) noexcept
    : interface_(interface), fd_(fd), faults_(faults) {}

std::unique_ptr<SocketCanBus> SocketCanBus::adopt(int fd, const std::string& interface, IoFaults* faults) {
  return std::unique_ptr<SocketCanBus>(new SocketCanBus(fd, interface, faults));
}

SocketCanBus::~SocketCanBus() { ::close(fd_); }

bool SocketCanBus::send(const CanFrame& frame) noexcept {
  const struct can_frame out = to_kernel_frame(frame);
  ssize_t written;
  do {
    const int fault = faults_ != nullptr ? faults_->check(IoPoint::CanWrite) : 0;
    if (fault > 0) {
      errno = fault;
      written = -1;
    } else if (fault == io_fault::kShort) {
      written = sizeof out / 2;
    } else {
      written = ::write(fd_, &out, sizeof out);
    }
  } while (written < 0 && errno == EINTR);
  // CAN_RAW writes whole frames or nothing; a short count would be a kernel contract change.
  const SendOutcome outcome = written == static_cast<ssize_t>(sizeof out) ? SendOutcome::Sent
                              : written < 0                               ? classify_send_errno(errno)
                                                                          : SendOutcome::Failed;
  state_.on_send(outcome);
  return outcome == SendOutcome::Sent;
}

void SocketCanBus::poll_errors() noexcept {
  for (int i = 0; i < kMaxErrorFramesPerPoll; ++i) {
    struct can_frame in;
    const ssize_t got = ::recv(fd_, &in, sizeof in, MSG_DONTWAIT);
    if (got < 0) {
      if (errno == EINTR) continue;
      return;  // EAGAIN: nothing pending; anything else: nothing readable now either
    }
    if (got != static_cast<ssize_t>(sizeof in)) continue;
    if (const auto event = classify_error_frame(in)) state_.on_error_frame(*event);
  }
}

}  // namespace rutd
