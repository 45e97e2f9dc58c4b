#pragma once
// CRC-8 SAE J1850: polynomial 0x1D, initial value 0xFF, final XOR 0xFF, no reflection.
// Check value over "123456789" is 0x4B.
#include <cstddef>
#include <cstdint>

namespace emadiag::can {

inline constexpr std::uint8_t kCrc8J1850Poly = 0x1D;
inline constexpr std::uint8_t kCrc8J1850Init = 0xFF;
inline constexpr std::uint8_t kCrc8J1850XorOut = 0xFF;

/// Table-driven CRC-8 SAE J1850 over `len` bytes.
[[nodiscard]] std::uint8_t crc8_j1850(const std::uint8_t* data, std::size_t len);
/// Bit-by-bit reference implementation (for tests).
[[nodiscard]] std::uint8_t crc8_j1850_bitwise(const std::uint8_t* data, std::size_t len);

}  // namespace emadiag::can
