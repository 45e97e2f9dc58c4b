#pragma once
// The simulated EMA node (sim_backend/node/README.md).
#include "emadiag/can/can_bus.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/node/node_clock.hpp"
#include "emadiag/sim/simulator.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace emadiag::node {

/// The one exception type of the node; messages start with "[ema_node] ".
class NodeError : public std::runtime_error {
public:
    explicit NodeError(const std::string& message) : std::runtime_error("[ema_node] " + message) {}
};

enum class Interlock { None, WeightOffWheels, MaintenanceDisabled };
/// Parses "none", "wow" (weight off wheels), "maintenance"; throws NodeError naming the value.
[[nodiscard]] Interlock parse_interlock(const std::string& s);

struct EmaNodeFaults {
    Interlock refuse_ground_test = Interlock::None;  ///< this interlock is open: ENTER_GROUND_TEST is refused
    double drop_fraction = 0.0;         ///< probability that a telemetry frame is not transmitted
    double corrupt_crc_fraction = 0.0;  ///< probability that a telemetry frame carries a wrong CRC
    std::optional<double> silent_after_fraction;  ///< stop transmitting after this fraction of a sequence
    bool ack_without_ground_test = false;  ///< accept ENTER_GROUND_TEST but stay in NORMAL (a faulty mode switch)
    std::uint32_t drop_burst_frames = 0;   ///< drop this many consecutive telemetry frames ...
    double drop_burst_at_fraction = 0.5;   ///< ... starting at this fraction of the sequence
    double duplicate_fraction = 0.0;       ///< probability that a telemetry frame is sent twice
    double reorder_fraction = 0.0;         ///< probability that a telemetry frame is sent after the next one
    /// The faults above act on the first this-many sequences only (0 = every sequence): a transient
    /// disturbance, which a retry of the sequence gets past.
    std::uint32_t fault_sequences = 0;
    std::uint64_t seed = 1;                       ///< seed of the fault draws (std::mt19937_64)
    void validate() const;
};

struct EmaNodeConfig {
    sim::SimConfig sim;  ///< sequence is set by each START_SEQUENCE
    can::EmaIdentification ident;  ///< k_t, J, tau and sample period are filled from sim.params by the constructor
    double time_scale = 1.0;       ///< 1 = real time; 4 = stream four times slower
    std::chrono::milliseconds heartbeat_timeout = can::icd::kHeartbeatTimeout;
    EmaNodeFaults faults;
};

struct EmaNodeStats {
    std::uint64_t sequences_started = 0;
    std::uint64_t sequences_done = 0;
    std::uint64_t sequences_aborted = 0;
    std::uint64_t telemetry_frames_sent = 0;
    std::uint64_t telemetry_frames_dropped = 0;
    std::uint64_t telemetry_crc_corrupted = 0;
    std::uint64_t telemetry_frames_duplicated = 0;
    std::uint64_t telemetry_frames_reordered = 0;
    std::uint64_t send_failures = 0;
    std::uint64_t send_calls = 0;  ///< batched transmit calls (one sendmmsg on SocketCAN)
};

/// The gaps between TOOL_Heartbeat arrivals the EMA saw in GROUND_TEST (the watchdog's view).
struct HeartbeatGapStats {
    std::size_t count = 0;
    double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
};

class EmaNode {
public:
    /// Validates the configuration (throws NodeError or SimError naming the bad field). `clock` is
    /// read for every time the node keeps (steady_clock by default; tests pass a ManualNodeClock)
    /// and must outlive the node.
    EmaNode(can::CanBus& bus, EmaNodeConfig config, const NodeClock& clock = steady_node_clock());

    /// Serves the bus until `stop` becomes true.
    void run(const std::atomic<bool>& stop);
    /// One pass of the loop: waits at most `max_wait` for a frame, then does what is due.
    void poll(std::chrono::microseconds max_wait);

    [[nodiscard]] const can::EmaStatus& status() const { return status_; }
    [[nodiscard]] const EmaNodeStats& stats() const { return stats_; }
    [[nodiscard]] HeartbeatGapStats heartbeat_gaps() const;
    /// Time since a tool last sent anything (command or heartbeat); nullopt before the first.
    [[nodiscard]] std::optional<std::chrono::steady_clock::duration> tool_idle() const;
    [[nodiscard]] bool silent() const { return silent_; }

    /// Called with a one-line description of each state change (the library never prints).
    std::function<void(const std::string&)> on_event;

private:
    using Clock = std::chrono::steady_clock;
    [[nodiscard]] Clock::time_point now() const { return clock_.now(); }
    void handle(const can::CanFrame& f, Clock::time_point now);
    void handle_command(const can::ToolCommand& c, Clock::time_point now);
    void start_sequence(const can::ToolCommand& c, Clock::time_point now);
    void stream_due(Clock::time_point now);
    /// The heartbeat watchdog, checked on a fresh clock reading right before anything is sent while
    /// a sequence runs; aborts (and returns true) when the heartbeat is more than 100 ms overdue.
    bool watchdog_expired();
    void finish(can::icd::SequenceState state, can::icd::FaultCode fault, const std::string& why);
    void send(const can::CanFrame& f);
    /// Sends what is queued in tx_ in one batched call.
    void flush_tx();
    void send_status();
    [[nodiscard]] bool faults_active() const;
    void event(const std::string& what);

    can::CanBus& bus_;
    const NodeClock& clock_;
    EmaNodeConfig config_;
    can::EmaIcd icd_;
    can::EmaStatus status_;
    EmaNodeStats stats_;
    std::mt19937_64 fault_rng_;
    Clock::time_point next_status_;
    Clock::time_point last_heartbeat_;
    std::optional<Clock::time_point> last_heartbeat_arrival_;
    std::optional<Clock::time_point> last_tool_frame_;
    std::vector<double> heartbeat_gaps_ms_;
    std::vector<can::CanFrame> tx_;
    std::vector<can::ReceiveResult> rx_;
    bool silent_ = false;

    // The running sequence.
    struct Running;
    std::shared_ptr<Running> run_;
};

}  // namespace emadiag::node
