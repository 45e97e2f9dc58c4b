#pragma once
// Replays a candump log as a bus ("candump:FILE.log"): receive() returns the logged frames in
// order with their logged timestamps, then EndOfLog. It cannot transmit.
#include "emadiag/can/can_bus.hpp"
#include "emadiag/can/candump_log.hpp"

#include <vector>

namespace emadiag::can {

class CandumpBus final : public CanBus {
public:
    /// Reads the whole log; throws CanError listing every bad line.
    explicit CandumpBus(const std::string& path);

    SendStatus send(const CanFrame& frame) override;
    ReceiveResult receive(std::chrono::microseconds timeout) override;
    void set_filters(const std::vector<CanFilter>& filters) override { filters_ = filters; }
    [[nodiscard]] const std::string& spec() const override { return spec_; }
    [[nodiscard]] const std::string& interface_name() const override { return iface_; }

private:
    std::vector<CandumpRecord> records_;
    std::size_t next_ = 0;
    std::vector<CanFilter> filters_;
    std::string spec_;
    std::string iface_;
};

/// True when `f` passes `filters` (an empty list passes everything).
[[nodiscard]] bool passes_filters(const CanFrame& f, const std::vector<CanFilter>& filters);

}  // namespace emadiag::can
