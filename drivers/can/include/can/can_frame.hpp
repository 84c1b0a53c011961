#pragma once
// One classic CAN data frame (no CAN FD, no remote frames) as rutd sends it, independent of any bus
// driver: the encoder produces these, SocketCAN and candump-log sinks consume them.
#include <array>
#include <cstdint>

namespace rutd {

struct CanFrame {
  std::uint32_t id = 0;                // 29-bit identifier if `extended`, else 11-bit; no flag bits
  bool extended = false;               // 29-bit (CAN 2.0B) identifier
  std::uint8_t len = 0;                // payload length in bytes, 0..8
  std::array<std::uint8_t, 8> data{};  // bytes [len, 8) are zero

  friend bool operator==(const CanFrame&, const CanFrame&) = default;
};

}  // namespace rutd
