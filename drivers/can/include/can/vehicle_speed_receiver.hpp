#pragma once
// Receives the vehicle's speed on a SocketCAN interface on a thread of its own and hands the decoded
// samples (can/vehicle_speed.hpp) to one consumer, the daemon's publish thread. Linux only.
//
// The kernel filters (CAN_RAW_FILTER) pass only the speed message's identifier (and ETC2's when the
// direction comes from the gear), so foreign traffic costs this process nothing; frames the kernel had
// to drop because this socket's queue was full are counted (SO_RXQ_OVFL). The thread sleeps in poll(2)
// (a bounded wait, so stop() returns within kPollMs), never spins. Each frame is stamped on
// CLOCK_MONOTONIC when read (the frames' clock; whole microseconds, as the log keeps them), decoded, and, when a log is
// given, written there in candump format before decoding (a recording's vehicle.log: replay decodes the same frames at
// the same times). Samples travel through a bounded lock-free queue of kQueueSamples; a full queue (the consumer
// stopped draining for longer than the queue holds) drops the sample and counts it.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>
#include <thread>

#include <boost/lockfree/spsc_queue.hpp>

#include "can/candump_log.hpp"
#include "can/vehicle_speed.hpp"
#include "core/track.hpp"

namespace rutd {

struct VehicleSpeedReceiverStats {
  VehicleSpeedStats decoded;
  std::uint64_t kernel_dropped = 0;  // frames the kernel dropped: this socket's receive queue was full
  std::uint64_t queue_full = 0;      // samples dropped: the consumer's queue was full
  std::uint64_t read_errors = 0;     // failed reads other than "nothing pending"
  std::uint64_t log_errors = 0;      // vehicle.log lines that could not be written
};

class VehicleSpeedReceiver {
 public:
  static constexpr int kPollMs = 50;
  static constexpr std::size_t kQueueSamples = 4096;  // at 100 Hz, 40 s without a consumer

  // Opens a CAN_RAW socket on `interface` with the filters above and starts the thread. log: candump
  // log of every frame received (not owned, outlives the receiver; written from the thread only);
  // log_interface: the interface name written there. Throws std::system_error naming the interface,
  // std::invalid_argument for a bad configuration.
  VehicleSpeedReceiver(const std::string& interface, VehicleSpeedConfig config, std::ostream* log = nullptr,
                       const std::string& log_interface = "can0");
  // Tests only: takes ownership of an open datagram socket that delivers struct can_frame records (a
  // socketpair(AF_UNIX, SOCK_SEQPACKET) end); no kernel filters there, the decoder counts the rest.
  static std::unique_ptr<VehicleSpeedReceiver> adopt(int fd, const std::string& interface, VehicleSpeedConfig config,
                                                     std::ostream* log = nullptr);
  ~VehicleSpeedReceiver();  // stops the thread
  VehicleSpeedReceiver(const VehicleSpeedReceiver&) = delete;
  VehicleSpeedReceiver& operator=(const VehicleSpeedReceiver&) = delete;

  // Consumer (one thread): the next sample received at or before up_to_ns, in order, if any.
  bool next(std::int64_t up_to_ns, SpeedSample& out) noexcept;
  void stop() noexcept;
  // Any thread: a copy of the counters.
  VehicleSpeedReceiverStats stats() const;
  const std::string& interface() const noexcept { return interface_; }

 private:
  struct Adopted {};
  VehicleSpeedReceiver(int fd, const std::string& interface, VehicleSpeedConfig config, std::ostream* log,
                       const std::string& log_interface, Adopted);
  void run(std::stop_token stop) noexcept;
  void read_pending() noexcept;

  std::string interface_;
  int fd_ = -1;
  bool adopted_ = false;
  VehicleSpeedDecoder decoder_;
  std::ostream* log_stream_ = nullptr;
  std::unique_ptr<CandumpLogWriter> log_;
  boost::lockfree::spsc_queue<SpeedSample, boost::lockfree::capacity<kQueueSamples>> queue_;
  mutable std::mutex stats_mutex_;  // guards stats_ (written by the thread, copied by stats())
  VehicleSpeedReceiverStats stats_;
  std::jthread thread_;
};

}  // namespace rutd
