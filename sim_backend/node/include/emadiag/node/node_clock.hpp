#pragma once
// The clock the simulated EMA node reads (sim_backend/node/README.md). The production clock is
// std::chrono::steady_clock (and the system clock to age a frame's receive timestamp); tests drive a
// ManualNodeClock, so no node test depends on how long the machine takes to run it.
#include <atomic>
#include <chrono>

namespace emadiag::node {

class NodeClock {
public:
    using time_point = std::chrono::steady_clock::time_point;
    using duration = std::chrono::steady_clock::duration;
    virtual ~NodeClock() = default;
    /// Monotonic time: status period, telemetry pacing, the heartbeat watchdog.
    [[nodiscard]] virtual time_point now() const = 0;
    /// Wall time since the Unix epoch, the reference of a frame's receive timestamp (CanFrame::timestamp).
    [[nodiscard]] virtual std::chrono::nanoseconds since_epoch() const = 0;
};

/// The production clock: steady_clock and system_clock.
class SteadyNodeClock final : public NodeClock {
public:
    [[nodiscard]] time_point now() const override { return std::chrono::steady_clock::now(); }
    [[nodiscard]] std::chrono::nanoseconds since_epoch() const override {
        return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch());
    }
};

/// The one SteadyNodeClock every node uses unless it is given another.
[[nodiscard]] const NodeClock& steady_node_clock();

/// A clock that moves only when told (tests). Its wall time is `epoch` plus the time advanced, so a
/// frame stamped with `since_epoch()` is exactly as old as the test says. Thread-safe.
class ManualNodeClock final : public NodeClock {
public:
    explicit ManualNodeClock(std::chrono::nanoseconds epoch = std::chrono::seconds(1'700'000'000)) : epoch_(epoch) {}
    [[nodiscard]] time_point now() const override { return time_point(duration(ticks_.load())); }
    [[nodiscard]] std::chrono::nanoseconds since_epoch() const override {
        return epoch_ + std::chrono::duration_cast<std::chrono::nanoseconds>(duration(ticks_.load()));
    }
    void advance(duration d) { ticks_.fetch_add(d.count()); }

private:
    std::chrono::nanoseconds epoch_;
    /// Starts at one hour, not zero: a default time_point reads as "never".
    std::atomic<duration::rep> ticks_{std::chrono::duration_cast<duration>(std::chrono::hours(1)).count()};
};

}  // namespace emadiag::node
