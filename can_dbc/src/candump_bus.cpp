#include "emadiag/can/candump_bus.hpp"

namespace emadiag::can {

bool passes_filters(const CanFrame& f, const std::vector<CanFilter>& filters) {
    if (filters.empty()) return true;
    for (const auto& flt : filters)
        if (flt.extended == f.extended && (f.id & flt.mask) == (flt.id & flt.mask)) return true;
    return false;
}

CandumpBus::CandumpBus(const std::string& path) : records_(read_candump_file(path)), spec_("candump:" + path) {
    iface_ = records_.empty() ? "can0" : records_.front().iface;
}

SendStatus CandumpBus::send(const CanFrame&) { return SendStatus::ReadOnly; }

ReceiveResult CandumpBus::receive(std::chrono::microseconds) {
    while (next_ < records_.size()) {
        const CanFrame& f = records_[next_++].frame;
        if (f.error) return ReceiveResult{ReceiveStatus::ErrorFrame, f, "error frame in the log"};
        if (passes_filters(f, filters_)) return ReceiveResult{ReceiveStatus::Frame, f, {}};
    }
    return ReceiveResult{ReceiveStatus::EndOfLog, {}, "end of " + spec_};
}

}  // namespace emadiag::can
