#include "gige_probe.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <ctime>

#include "core/monotonic_clock.hpp"

namespace rutd {
namespace {

constexpr std::uint16_t kGvcpPort = 3956;
constexpr std::uint16_t kDiscoveryCmd = 0x0002;
constexpr std::uint16_t kDiscoveryAck = 0x0003;

std::uint16_t be16(const std::uint8_t* p) noexcept { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

}  // namespace

void gvcp_discovery_command(std::uint16_t request_id, std::span<std::uint8_t, 8> out) noexcept {
  out[0] = 0x42;  // GVCP key
  out[1] = 0x11;  // acknowledge required | broadcast acknowledge allowed
  out[2] = kDiscoveryCmd >> 8;
  out[3] = kDiscoveryCmd & 0xff;
  out[4] = 0;  // payload length
  out[5] = 0;
  out[6] = static_cast<std::uint8_t>(request_id >> 8);
  out[7] = static_cast<std::uint8_t>(request_id & 0xff);
}

bool gvcp_is_discovery_ack(std::span<const std::uint8_t> d, std::uint16_t request_id) noexcept {
  return d.size() >= 8 && be16(&d[0]) == 0 && be16(&d[2]) == kDiscoveryAck && be16(&d[6]) == request_id;
}

bool gige_camera_answers(const std::string& ipv4, std::chrono::milliseconds timeout) noexcept {
  sockaddr_in camera{};
  camera.sin_family = AF_INET;
  camera.sin_port = htons(kGvcpPort);
  if (inet_pton(AF_INET, ipv4.c_str(), &camera.sin_addr) != 1) return false;
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  static std::atomic<std::uint16_t> next_id{0};  // any id but 0 will do: it tells our answer from a stray one
  const std::uint16_t id = static_cast<std::uint16_t>(next_id.fetch_add(1) % 0xffff + 1);
  std::array<std::uint8_t, 8> command{};
  gvcp_discovery_command(id, command);
  bool answered = false;
  if (sendto(fd, command.data(), command.size(), 0, reinterpret_cast<const sockaddr*>(&camera), sizeof camera) ==
      static_cast<ssize_t>(command.size())) {
    const std::int64_t deadline = (monotonic_now_ns() / 1'000'000) + timeout.count();
    std::array<std::uint8_t, 576> reply{};
    for (std::int64_t left = timeout.count(); !answered && left > 0;
         left = deadline - (monotonic_now_ns() / 1'000'000)) {
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left)) <= 0) break;
      const ssize_t n = recv(fd, reply.data(), reply.size(), 0);
      if (n > 0) answered = gvcp_is_discovery_ack(std::span(reply.data(), static_cast<std::size_t>(n)), id);
    }
  }
  close(fd);
  return answered;
}

}  // namespace rutd
