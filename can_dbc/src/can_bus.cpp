#include "emadiag/can/can_bus.hpp"

#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_bus.hpp"
#include "emadiag/can/socketcan_bus.hpp"

namespace emadiag::can {

std::string to_string(SendStatus s) {
    switch (s) {
        case SendStatus::Sent: return "sent";
        case SendStatus::QueueFull: return "transmit queue full";
        case SendStatus::BusOff: return "bus-off or interface down";
        case SendStatus::ReadOnly: return "read-only bus (log replay)";
    }
    return "?";
}

std::string to_string(ReceiveStatus s) {
    switch (s) {
        case ReceiveStatus::Frame: return "frame";
        case ReceiveStatus::Timeout: return "timeout";
        case ReceiveStatus::ErrorFrame: return "error frame";
        case ReceiveStatus::BusOff: return "bus-off";
        case ReceiveStatus::EndOfLog: return "end of log";
    }
    return "?";
}

BatchSendResult CanBus::send_batch(const std::vector<CanFrame>& frames) {
    BatchSendResult r;
    for (const auto& f : frames) {
        r.status = send(f);
        if (r.status != SendStatus::Sent) return r;
        ++r.sent;
    }
    return r;
}

std::size_t CanBus::receive_batch(std::vector<ReceiveResult>& out, std::size_t max_results, std::chrono::microseconds timeout) {
    std::size_t n = 0;
    auto wait = timeout;
    while (n < max_results) {
        ReceiveResult r = receive(wait);
        if (r.status == ReceiveStatus::Timeout) break;
        const bool last = r.status != ReceiveStatus::Frame;
        out.push_back(std::move(r));
        ++n;
        if (last) break;
        wait = std::chrono::microseconds{0};
    }
    return n;
}

std::unique_ptr<CanBus> open_bus(const std::string& spec) {
    const auto colon = spec.find(':');
    const std::string kind = spec.substr(0, colon);
    const std::string arg = colon == std::string::npos ? std::string() : spec.substr(colon + 1);
    if (colon == std::string::npos || arg.empty())
        throw CanError("bus spec '" + spec + "': expected socketcan:IFACE or candump:FILE.log");
    if (kind == "socketcan") return std::make_unique<SocketCanBus>(arg);
    if (kind == "candump") return std::make_unique<CandumpBus>(arg);
    throw CanError("bus spec '" + spec + "': unknown kind '" + kind + "' (expected socketcan or candump)");
}

}  // namespace emadiag::can
