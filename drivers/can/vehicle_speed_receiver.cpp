#include "can/vehicle_speed_receiver.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <system_error>
#include <vector>

#include "can/socketcan_bus.hpp"
#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

[[noreturn]] void throw_for(int error_number, const std::string& interface, const char* what) {
  throw std::system_error(error_number, std::generic_category(),
                          "SocketCAN interface '" + interface + "' (vehicle speed): " + what);
}

int open_socket(const std::string& interface, const VehicleSpeedConfig& c) {
  if (interface.empty() || interface.size() >= IFNAMSIZ)
    throw_for(EINVAL, interface, "interface names are 1 to 15 characters");
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) throw_for(errno, interface, "socket(AF_CAN) failed (kernel without CAN support?)");
  try {
    // Only the speed message and, with the direction from the gear, ETC2: the kernel drops the rest.
    std::vector<can_filter> filters;
    const SpeedSignalLayout& s = c.signal;
    const canid_t flags = s.extended ? CAN_EFF_FLAG : 0;
    filters.push_back(
        {s.id | flags, (s.id_mask & (s.extended ? CAN_EFF_MASK : CAN_SFF_MASK)) | CAN_EFF_FLAG | CAN_RTR_FLAG});
    if (c.direction_from_gear) filters.push_back({kEtc2Id | CAN_EFF_FLAG, kJ1939PgnMask | CAN_EFF_FLAG | CAN_RTR_FLAG});
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                   static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0)
      throw_for(errno, interface, "setsockopt(CAN_RAW_FILTER)");
    const int on = 1;
    if (setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0) throw_for(errno, interface, "SO_RXQ_OVFL");
    const unsigned index = if_nametoindex(interface.c_str());
    if (index == 0) throw_for(errno, interface, "no such network interface");
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(index);
    if (bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
      throw_for(errno, interface, "bind failed");
  } catch (...) {
    ::close(fd);
    throw;
  }
  return fd;
}

}  // namespace

VehicleSpeedReceiver::VehicleSpeedReceiver(const std::string& interface, VehicleSpeedConfig config, std::ostream* log,
                                           const std::string& log_interface)
    : VehicleSpeedReceiver(-1, interface, std::move(config), log, log_interface, Adopted{}) {}

VehicleSpeedReceiver::VehicleSpeedReceiver(int fd, const std::string& interface, VehicleSpeedConfig config,
                                           std::ostream* log, const std::string& log_interface, Adopted)
    : interface_(interface), decoder_(std::move(config)), log_stream_(log) {
  if (log != nullptr) log_ = std::make_unique<CandumpLogWriter>(*log, log_interface);
  if (fd >= 0) {
    fd_ = fd;
    adopted_ = true;
  } else {
    fd_ = open_socket(interface, decoder_.config());
  }
  thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
}

std::unique_ptr<VehicleSpeedReceiver> VehicleSpeedReceiver::adopt(int fd, const std::string& interface,
                                                                  VehicleSpeedConfig config, std::ostream* log) {
  return std::unique_ptr<VehicleSpeedReceiver>(
      new VehicleSpeedReceiver(fd, interface, std::move(config), log, interface, Adopted{}));
}

VehicleSpeedReceiver::~VehicleSpeedReceiver() {
  stop();
  ::close(fd_);
}

void VehicleSpeedReceiver::stop() noexcept {
  if (thread_.joinable()) {
    thread_.request_stop();
    thread_.join();
  }
}

void VehicleSpeedReceiver::run(std::stop_token stop) noexcept {
  pollfd p{fd_, POLLIN, 0};
  while (!stop.stop_requested()) {
    const int ready = ::poll(&p, 1, kPollMs);
    if (ready > 0) read_pending();
  }
  if (log_stream_ != nullptr) log_stream_->flush();
}

void VehicleSpeedReceiver::read_pending() noexcept {
  // At most a bounded batch per wake-up, then the stop flag is looked at again.
  for (int i = 0; i < 256; ++i) {
    struct can_frame in;
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(std::uint32_t))];
    iovec iov{&in, sizeof in};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = adopted_ ? nullptr : control;
    msg.msg_controllen = adopted_ ? 0 : sizeof control;
    const ssize_t got = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
    // Microseconds, as candump logs them: replay of vehicle.log then decodes at exactly the same times.
    const std::int64_t t_ns = monotonic_now_ns() / 1000 * 1000;
    if (got < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        std::lock_guard lock(stats_mutex_);
        ++stats_.read_errors;
      }
      break;
    }
    std::optional<std::uint32_t> dropped;  // the kernel's running count of this socket's drops, when sent
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t count = 0;
        std::memcpy(&count, CMSG_DATA(c), sizeof count);
        dropped = count;
      }
    }
    // The log and the decoder are this thread's alone: the counters' lock is taken after them, so that a
    // log write that waits on the disk never holds up a reader of stats(). Error and remote frames (no
    // filter passes them) are skipped.
    const bool whole = got == static_cast<ssize_t>(sizeof in);
    const auto frame = whole ? from_kernel_frame(in) : std::nullopt;
    const bool log_failed = frame && log_ && !log_->write(*frame, t_ns);
    const auto sample = frame ? decoder_.on_frame(*frame, t_ns) : std::nullopt;
    const bool queue_full = sample && !queue_.push(*sample);
    std::lock_guard lock(stats_mutex_);
    if (dropped) stats_.kernel_dropped = *dropped;
    stats_.read_errors += !whole;
    stats_.log_errors += log_failed;
    stats_.queue_full += queue_full;
    stats_.decoded = decoder_.stats();
  }
  if (log_stream_ != nullptr) log_stream_->flush();
}

bool VehicleSpeedReceiver::next(std::int64_t up_to_ns, SpeedSample& out) noexcept {
  if (queue_.read_available() == 0 || queue_.front().t_ns > up_to_ns) return false;
  out = queue_.front();
  queue_.pop();
  return true;
}

VehicleSpeedReceiverStats VehicleSpeedReceiver::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

}  // namespace rutd
