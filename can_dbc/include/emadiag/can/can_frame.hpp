#pragma once
// One CAN or CAN FD frame as it travels on the bus or sits in a candump log.
#include <array>
#include <chrono>
#include <cstdint>
#include <string>

namespace emadiag::can {

inline constexpr std::uint32_t kStandardIdMask = 0x7FFu;
inline constexpr std::uint32_t kExtendedIdMask = 0x1FFFFFFFu;
/// DBC marks extended identifiers with bit 31 of the BO_ id.
inline constexpr std::uint32_t kDbcExtendedFlag = 0x80000000u;
inline constexpr std::size_t kClassicMaxLen = 8;
inline constexpr std::size_t kFdMaxLen = 64;

struct CanFrame {
    std::uint32_t id = 0;      ///< 11- or 29-bit identifier (error class bits for error frames)
    bool extended = false;
    bool fd = false;           ///< CAN FD frame
    bool brs = false;          ///< FD bit-rate switch
    bool esi = false;          ///< FD error state indicator
    bool rtr = false;          ///< remote request (classic only)
    bool error = false;        ///< error frame reported by the controller
    std::uint8_t len = 0;      ///< payload bytes: 0..8 classic, FD lengths up to 64
    std::array<std::uint8_t, kFdMaxLen> data{};
    /// Receive time since the Unix epoch (kernel timestamp on SocketCAN, log time on replay).
    std::chrono::nanoseconds timestamp{0};
};

/// True for the payload lengths CAN FD allows: 0..8, 12, 16, 20, 24, 32, 48, 64.
[[nodiscard]] constexpr bool is_valid_fd_len(std::size_t len) {
    return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 || len == 64;
}

/// "0x1A2" style text of an id, for messages.
[[nodiscard]] std::string format_id(std::uint32_t id, bool extended);

}  // namespace emadiag::can
