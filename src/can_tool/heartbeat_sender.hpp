#pragma once
// The tool's 50 Hz TOOL_Heartbeat from a thread of its own. The EMA's 100 ms watchdog is a safety
// function: the heartbeat must never wait on the loop that receives, decodes and logs telemetry
// (a slow or busy laptop, a host that makes every system call expensive). The thread sleeps to
// absolute deadlines, runs under SCHED_FIFO where the OS allows it (quietly at normal priority
// where it does not), and only sends; the frames it sent are handed to the receiving loop, which
// writes them to the raw log in time order.
#include "emadiag/can/can_bus.hpp"
#include "emadiag/can/ema_icd.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace emadiag::can_tool {

/// SCHED_FIFO priority of the heartbeat thread: above ordinary work, far below the kernel's own
/// threads (1..99).
inline constexpr int kHeartbeatRealtimePriority = 20;

struct HeartbeatStats {
    std::uint64_t sent = 0;
    std::uint64_t send_failures = 0;
    std::chrono::microseconds max_gap{0};  ///< longest time between two heartbeats sent
    bool realtime = false;                 ///< the thread runs under SCHED_FIFO
};

class HeartbeatSender {
public:
    /// `bus` must outlive the sender; it is used only to send (CanBus allows one sending thread
    /// beside the receiving one).
    HeartbeatSender(can::CanBus& bus, std::chrono::milliseconds period = can::icd::kHeartbeatPeriod);
    ~HeartbeatSender();
    HeartbeatSender(const HeartbeatSender&) = delete;
    HeartbeatSender& operator=(const HeartbeatSender&) = delete;

    /// Sends the first heartbeat at once, then one per period.
    void start();
    /// Stops and joins the thread (idempotent).
    void stop();
    /// Appends the heartbeats sent since the last call (timestamp = send time, Unix epoch) to `out`.
    void take_sent(std::vector<can::CanFrame>& out);
    /// The first send that failed, named ("transmit queue full"), if any.
    [[nodiscard]] std::optional<std::string> failure() const;
    [[nodiscard]] HeartbeatStats stats() const;

private:
    void loop();

    can::CanBus& bus_;
    std::chrono::milliseconds period_;
    const can::EmaIcd icd_;
    std::thread thread_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    bool stop_ = false;
    std::vector<can::CanFrame> sent_;
    std::optional<std::string> failure_;
    HeartbeatStats stats_;
};

}  // namespace emadiag::can_tool
