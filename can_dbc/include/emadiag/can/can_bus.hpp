#pragma once
// A CAN bus as the tool and the simulated EMA see it. Run-time failures (timeout, bus-off, a full
// transmit queue) come back as [[nodiscard]] results; misuse and setup failures throw CanError.
#include "emadiag/can/can_frame.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace emadiag::can {

enum class ReceiveStatus {
    Frame,       ///< `frame` holds a data frame
    Timeout,     ///< nothing arrived within the timeout
    ErrorFrame,  ///< the controller reported an error frame (`frame` and `detail` say which)
    BusOff,      ///< the controller went bus-off
    EndOfLog,    ///< replay only: the log has no more frames
};

struct [[nodiscard]] ReceiveResult {
    ReceiveStatus status = ReceiveStatus::Timeout;
    CanFrame frame;
    std::string detail;
    [[nodiscard]] bool has_frame() const { return status == ReceiveStatus::Frame; }
};

enum class [[nodiscard]] SendStatus {
    Sent,
    QueueFull,  ///< the transmit queue stayed full for the whole send timeout
    BusOff,     ///< the interface is down or bus-off
    ReadOnly,   ///< a replayed log cannot transmit
};

[[nodiscard]] std::string to_string(SendStatus s);
[[nodiscard]] std::string to_string(ReceiveStatus s);

/// Acceptance filter: a frame passes when (frame id & mask) == (id & mask) and the id kinds match.
struct CanFilter {
    std::uint32_t id = 0;
    std::uint32_t mask = 0;
    bool extended = false;
};

/// Result of a batched send: how many frames went out, and why the rest did not.
struct [[nodiscard]] BatchSendResult {
    std::size_t sent = 0;
    SendStatus status = SendStatus::Sent;  ///< Sent when every frame went out
};

/// Thread safety: one thread may send (send, send_batch) while another receives (receive,
/// receive_batch) on the same bus; the tool's heartbeat thread relies on it. Two threads may not
/// receive at once.
class CanBus {
public:
    virtual ~CanBus() = default;
    CanBus() = default;
    CanBus(const CanBus&) = delete;
    CanBus& operator=(const CanBus&) = delete;

    virtual SendStatus send(const CanFrame& frame) = 0;
    virtual ReceiveResult receive(std::chrono::microseconds timeout) = 0;
    /// Sends `frames` in order, as few system calls as the bus allows (sendmmsg on SocketCAN).
    /// Stops at the first frame that cannot go out.
    virtual BatchSendResult send_batch(const std::vector<CanFrame>& frames);
    /// Waits at most `timeout` for the first result, then appends everything already queued, up
    /// to `max_results` in all (recvmmsg on SocketCAN), in bus order: an error frame, bus-off or
    /// end of log sits where it happened. Returns the count appended; 0 is a timeout.
    virtual std::size_t receive_batch(std::vector<ReceiveResult>& out, std::size_t max_results, std::chrono::microseconds timeout);
    /// Replaces the acceptance filters; an empty list accepts every frame.
    virtual void set_filters(const std::vector<CanFilter>& filters) = 0;
    /// The spec the bus was opened with ("socketcan:vcan0", "candump:run.log").
    [[nodiscard]] virtual const std::string& spec() const = 0;
    /// Interface name written to candump logs ("vcan0").
    [[nodiscard]] virtual const std::string& interface_name() const = 0;
};

/// Opens "socketcan:IFACE" or "candump:FILE.log" (replay). Throws CanError naming the spec.
[[nodiscard]] std::unique_ptr<CanBus> open_bus(const std::string& spec);

}  // namespace emadiag::can
