// CRC-8/SAE-J1850 against the CRC catalogue's check value, the AUTOSAR CRC library's published
// examples, and a plain bit-by-bit implementation of the definition.
#include <cstdint>
#include <random>
#include <span>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "can/crc8.hpp"

namespace rutd {
namespace {

std::uint8_t crc_of(std::initializer_list<std::uint8_t> bytes) {
  return crc8_sae_j1850(std::span<const std::uint8_t>(bytes.begin(), bytes.size()));
}

// The definition, one bit at a time: MSB first, poly 0x1D, init 0xFF, xor-out 0xFF.
std::uint8_t bitwise_reference(std::span<const std::uint8_t> data) {
  unsigned reg = 0xFF;
  for (const std::uint8_t byte : data) {
    for (int bit = 7; bit >= 0; --bit) {
      const unsigned in = (byte >> bit) & 1U;
      const unsigned top = (reg >> 7) & 1U;
      reg = (reg << 1) & 0xFFU;
      if (top ^ in) reg ^= 0x1DU;
    }
  }
  return static_cast<std::uint8_t>(reg ^ 0xFFU);
}

TEST(Crc8, CatalogueCheckValue) {
  constexpr std::string_view check = "123456789";
  const std::vector<std::uint8_t> bytes(check.begin(), check.end());
  EXPECT_EQ(crc8_sae_j1850(bytes), 0x4B);
}

TEST(Crc8, AutosarCrcLibraryExamples) {
  EXPECT_EQ(crc_of({0x00, 0x00, 0x00, 0x00}), 0x59);
  EXPECT_EQ(crc_of({0xF2, 0x01, 0x83}), 0x37);
  EXPECT_EQ(crc_of({0x0F, 0xAA, 0x00, 0x55}), 0x79);
  EXPECT_EQ(crc_of({0x00, 0xFF, 0x55, 0x11}), 0xB8);
  EXPECT_EQ(crc_of({0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF}), 0xCB);
  EXPECT_EQ(crc_of({0x92, 0x6B, 0x55}), 0x8C);
  EXPECT_EQ(crc_of({0xFF, 0xFF, 0xFF, 0xFF}), 0x74);
}

TEST(Crc8, EmptyInputIsInitXorOut) { EXPECT_EQ(crc8_sae_j1850({}), 0x00); }

TEST(Crc8, MatchesBitwiseDefinitionOnRandomData) {
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> length(0, 40);
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<std::uint8_t> data(static_cast<std::size_t>(length(rng)));
    for (auto& b : data) b = static_cast<std::uint8_t>(byte(rng));
    ASSERT_EQ(crc8_sae_j1850(data), bitwise_reference(data)) << "trial " << trial;
  }
}

TEST(Crc8, ChainedCallsEqualOneCallOverTheConcatenation) {
  const std::vector<std::uint8_t> data{0x50, 0xFF, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE};
  const std::span<const std::uint8_t> all(data);
  for (std::size_t split = 0; split <= data.size(); ++split) {
    const std::uint8_t head = crc8_sae_j1850(all.first(split));
    EXPECT_EQ(crc8_sae_j1850_update(head, all.subspan(split)), crc8_sae_j1850(all)) << "split " << split;
  }
}

TEST(Crc8, DetectsEverySingleBitError) {
  std::vector<std::uint8_t> data{0x50, 0xFF, 0x05, 0x3A, 0x9C, 0x41, 0x00, 0xFF, 0x7E};
  const std::uint8_t good = crc8_sae_j1850(data);
  for (std::size_t i = 0; i < data.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      data[i] ^= static_cast<std::uint8_t>(1U << bit);
      EXPECT_NE(crc8_sae_j1850(data), good) << "byte " << i << " bit " << bit;
      data[i] ^= static_cast<std::uint8_t>(1U << bit);
    }
  }
}

}  // namespace
}  // namespace rutd
