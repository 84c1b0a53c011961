#pragma once
// CRC-8/SAE-J1850 as catalogued (poly 0x1D, init 0xFF, no reflection, xor-out 0xFF, check value 0x4B
// for "123456789"); the same CRC as AUTOSAR's Crc_CalculateCRC8. Pure functions, thread-safe, no
// allocation.
#include <cstdint>
#include <span>

namespace rutd {

// CRC of `data` alone.
std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data) noexcept;

// CRC of (earlier bytes ++ data), given `previous` = the CRC of the earlier bytes as returned by either
// function. Chaining calls gives the CRC of the concatenation, as AUTOSAR's Crc_CalculateCRC8 does with
// Crc_IsFirstCall = FALSE and the previous result as start value.
std::uint8_t crc8_sae_j1850_update(std::uint8_t previous, std::span<const std::uint8_t> data) noexcept;

}  // namespace rutd
