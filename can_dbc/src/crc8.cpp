#include "emadiag/can/crc8.hpp"

#include <array>

namespace emadiag::can {
namespace {

constexpr std::array<std::uint8_t, 256> make_table() {
    std::array<std::uint8_t, 256> t{};
    for (int i = 0; i < 256; ++i) {
        auto c = static_cast<std::uint8_t>(i);
        for (int b = 0; b < 8; ++b) c = static_cast<std::uint8_t>((c & 0x80) ? (c << 1) ^ kCrc8J1850Poly : c << 1);
        t[static_cast<std::size_t>(i)] = c;
    }
    return t;
}
constexpr auto kTable = make_table();

}  // namespace

std::uint8_t crc8_j1850(const std::uint8_t* data, std::size_t len) {
    std::uint8_t crc = kCrc8J1850Init;
    for (std::size_t i = 0; i < len; ++i) crc = kTable[crc ^ data[i]];
    return static_cast<std::uint8_t>(crc ^ kCrc8J1850XorOut);
}

std::uint8_t crc8_j1850_bitwise(const std::uint8_t* data, std::size_t len) {
    std::uint8_t crc = kCrc8J1850Init;
    for (std::size_t i = 0; i < len; ++i) {
        crc ^= data[i];
        for (int b = 0; b < 8; ++b) crc = static_cast<std::uint8_t>((crc & 0x80) ? (crc << 1) ^ kCrc8J1850Poly : crc << 1);
    }
    return static_cast<std::uint8_t>(crc ^ kCrc8J1850XorOut);
}

}  // namespace emadiag::can
