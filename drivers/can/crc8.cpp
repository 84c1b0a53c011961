#include "can/crc8.hpp"

#include <array>

namespace rutd {
namespace {

constexpr std::uint8_t kPoly = 0x1D;
constexpr std::uint8_t kInit = 0xFF;
constexpr std::uint8_t kXorOut = 0xFF;

// table[i] = the register after shifting byte i through the polynomial division (MSB first).
constexpr std::array<std::uint8_t, 256> make_table() {
  std::array<std::uint8_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    auto reg = static_cast<std::uint8_t>(i);
    for (int bit = 0; bit < 8; ++bit) {
      reg = (reg & 0x80U) ? static_cast<std::uint8_t>((reg << 1) ^ kPoly) : static_cast<std::uint8_t>(reg << 1);
    }
    table[i] = reg;
  }
  return table;
}

constexpr std::array<std::uint8_t, 256> kTable = make_table();

std::uint8_t run_register(std::uint8_t reg, std::span<const std::uint8_t> data) noexcept {
  for (const std::uint8_t byte : data) reg = kTable[reg ^ byte];
  return reg;
}

}  // namespace

std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data) noexcept {
  return static_cast<std::uint8_t>(run_register(kInit, data) ^ kXorOut);
}

std::uint8_t crc8_sae_j1850_update(std::uint8_t previous, std::span<const std::uint8_t> data) noexcept {
  // Undo the previous call's xor-out to recover its register, continue, then apply xor-out again.
  return static_cast<std::uint8_t>(run_register(static_cast<std::uint8_t>(previous ^ kXorOut), data) ^ kXorOut);
}

}  // namespace rutd
