#include "emadiag/can/bus_load.hpp"

#include <cstdio>

namespace emadiag::can {

BusLoad cyclic_bus_load(const Database& db, double bitrate_bit_s) {
    BusLoad load;
    load.bitrate_bit_s = bitrate_bit_s;
    for (const auto& m : db.messages) {
        double period_s = 0;
        if (auto it = m.attributes.find("GenMsgCycleTimeUs"); it != m.attributes.end() && it->second.number > 0)
            period_s = it->second.number * 1e-6;
        else if (m.cycle_time_ms() && *m.cycle_time_ms() > 0)
            period_s = *m.cycle_time_ms() * 1e-3;
        if (period_s <= 0) continue;
        BusLoadLine l;
        l.message = m.name;
        l.frames_per_s = 1.0 / period_s;
        l.bits_per_frame = worst_case_frame_bits(m.length, m.extended);
        l.bits_per_s = l.frames_per_s * l.bits_per_frame;
        load.bits_per_s += l.bits_per_s;
        load.lines.push_back(l);
    }
    return load;
}

std::string BusLoad::table() const {
    std::string s;
    char buf[160];
    for (const auto& l : lines) {
        std::snprintf(buf, sizeof buf, "  %-16s %7.0f frames/s x %3u bits = %8.0f bit/s\n", l.message.c_str(), l.frames_per_s,
                      l.bits_per_frame, l.bits_per_s);
        s += buf;
    }
    std::snprintf(buf, sizeof buf, "  total %.0f bit/s of %.0f bit/s = %.2f %% worst-case bus load\n", bits_per_s, bitrate_bit_s,
                  100.0 * fraction());
    s += buf;
    return s;
}

}  // namespace emadiag::can
