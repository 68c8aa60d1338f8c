#pragma once
// CRC-32C (Castagnoli), the checksum that ends every page of an E57 file (ASTM E2807).

#include <array>
#include <cstddef>
#include <cstdint>

namespace piperun::io {

namespace detail {
constexpr std::array<std::uint32_t, 256> makeCrc32cTable() {
  constexpr std::uint32_t kReflectedPolynomial = 0x82F63B78u;
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t crc = i;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ ((crc & 1u) ? kReflectedPolynomial : 0u);
    table[i] = crc;
  }
  return table;
}
inline constexpr std::array<std::uint32_t, 256> kCrc32cTable = makeCrc32cTable();
}  // namespace detail

/// CRC-32C of `size` bytes. An E57 page stores it big-endian in its last 4 bytes.
inline std::uint32_t crc32c(const unsigned char* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) crc = (crc >> 8) ^ detail::kCrc32cTable[(crc ^ data[i]) & 0xFFu];
  return crc ^ 0xFFFFFFFFu;
}

}  // namespace piperun::io
