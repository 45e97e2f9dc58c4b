#pragma once
// Worst-case bus load of the cyclic messages of a DBC on classic CAN.
#include "emadiag/can/dbc.hpp"

#include <string>
#include <vector>

namespace emadiag::can {

/// Bits on the wire of a classic CAN data frame with `len` data bytes, worst-case bit stuffing,
/// including the 3-bit interframe space (Davis, Burns, Bril, Lukkien 2007, eq. 2):
///   11-bit id: 8n + 47 + floor((34 + 8n - 1) / 4);   29-bit id: 8n + 67 + floor((54 + 8n - 1) / 4).
[[nodiscard]] constexpr unsigned worst_case_frame_bits(unsigned len, bool extended) {
    return extended ? 8 * len + 67 + (54 + 8 * len - 1) / 4 : 8 * len + 47 + (34 + 8 * len - 1) / 4;
}

struct BusLoadLine {
    std::string message;
    double frames_per_s = 0;
    unsigned bits_per_frame = 0;
    double bits_per_s = 0;
};

struct BusLoad {
    std::vector<BusLoadLine> lines;  ///< cyclic messages only (event messages are sporadic)
    double bits_per_s = 0;
    double bitrate_bit_s = 0;
    [[nodiscard]] double fraction() const { return bits_per_s / bitrate_bit_s; }
    /// A table with one line per message and the total, for READMEs and benchmarks.
    [[nodiscard]] std::string table() const;
};

/// Load of every message with a cycle time (GenMsgCycleTimeUs, else GenMsgCycleTime in ms).
[[nodiscard]] BusLoad cyclic_bus_load(const Database& db, double bitrate_bit_s);

}  // namespace emadiag::can
