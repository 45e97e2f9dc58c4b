// The simulated EMA node: the EMA side of the ICD (can_dbc/ema.dbc) on top of sim_backend.
#include "emadiag/node/ema_node.hpp"

#include "emadiag/can/can_error.hpp"

#include <algorithm>
#include <cmath>
#ifdef __linux__
#include <pthread.h>
#include <sched.h>
#include <unistd.h>
#endif
#include <future>
#include <thread>
#include <sstream>

namespace emadiag::node {

using can::icd::AckResult;
using can::icd::Command;
using can::icd::FaultCode;
using can::icd::Mode;
using can::icd::SequenceState;
using can::icd::TestSequence;

namespace {

/// The loop wakes at least this often, so the watchdog fires within this much of its deadline.
constexpr std::chrono::milliseconds kMaxLoopSleep{2};
/// Telemetry pacing: a sample is sent no earlier than its due time and at most this much after
/// it, so one wake-up and one transmit call carry every sample due in the window (can_dbc/ICD.md).
constexpr std::chrono::microseconds kTelemetryBatchWindow{1000};
/// Within this much of the heartbeat deadline the EMA sends frame by frame, checking its watchdog
/// before each, instead of one batched call.
constexpr std::chrono::milliseconds kBatchGuard{40};
/// Frames taken from the bus per receive call.
constexpr std::size_t kReceiveBatch = 64;
constexpr double kMaxTimeScale = 1000.0;
/// XOR applied to the CRC byte of a frame chosen for corruption (any non-zero value is detected).
constexpr std::uint8_t kCrcCorruption = 0x5A;

can::icd::LoadCase icd_load_case(sim::LoadCase c) {
    switch (c) {
        case sim::LoadCase::A: return can::icd::LoadCase::A;
        case sim::LoadCase::AExt: return can::icd::LoadCase::AExt;
        case sim::LoadCase::B: return can::icd::LoadCase::B;
    }
    return can::icd::LoadCase::A;
}

std::string ms_text(std::chrono::steady_clock::duration d) {
    std::ostringstream s;
    s.precision(1);
    s << std::fixed << std::chrono::duration<double, std::milli>(d).count() << " ms";
    return s.str();
}

/// The simulation worker runs under ordinary scheduling, which undoes a real-time policy inherited
/// from the bus loop (ema-sim --realtime-priority). It is not demoted further: the simulation of a
/// whole sequence takes milliseconds, and a demoted worker (SCHED_IDLE or nice 19) starves for
/// seconds on a busy machine, which delays the start of the sequence.
void lower_this_thread_priority() {
#ifdef __linux__
    sched_param none{};
    none.sched_priority = 0;
    (void)::pthread_setschedparam(::pthread_self(), SCHED_OTHER, &none);
#endif
}

}  // namespace

Interlock parse_interlock(const std::string& s) {
    if (s == "none" || s.empty()) return Interlock::None;
    if (s == "wow") return Interlock::WeightOffWheels;
    if (s == "maintenance") return Interlock::MaintenanceDisabled;
    throw NodeError("interlock '" + s + "': expected none, wow or maintenance");
}

void EmaNodeFaults::validate() const {
    auto fraction = [](const char* name, double v) {
        if (!(v >= 0.0 && v <= 1.0)) throw NodeError(std::string(name) + " = " + std::to_string(v) + " outside [0, 1]");
    };
    fraction("drop_fraction", drop_fraction);
    fraction("corrupt_crc_fraction", corrupt_crc_fraction);
    fraction("drop_burst_at_fraction", drop_burst_at_fraction);
    fraction("duplicate_fraction", duplicate_fraction);
    fraction("reorder_fraction", reorder_fraction);
    if (silent_after_fraction) fraction("silent_after_fraction", *silent_after_fraction);
}

struct EmaNode::Running {
    std::future<sim::SimResult> simulation;
    std::vector<sim::Sample> samples;
    bool streaming = false;
    Clock::time_point stream_start;
    std::size_t next = 0;
    std::size_t silent_at = 0;
    std::uint8_t counter_a = 0;
    std::uint8_t counter_b = 0;
    std::size_t frames_made = 0;   ///< telemetry frames produced so far (the burst counts in them)
    std::size_t burst_first = 0;   ///< first frame of the injected burst of drops
    std::optional<can::CanFrame> held;  ///< a frame held back to go out after the next one
};

const NodeClock& steady_node_clock() {
    static const SteadyNodeClock clock;
    return clock;
}

EmaNode::EmaNode(can::CanBus& bus, EmaNodeConfig config, const NodeClock& clock)
    : bus_(bus), clock_(clock), config_(std::move(config)), fault_rng_(config_.faults.seed) {
    config_.faults.validate();
    config_.sim.params.validate();
    if (!(config_.time_scale >= 1.0 && config_.time_scale <= kMaxTimeScale))
        throw NodeError("time_scale = " + std::to_string(config_.time_scale) + " outside [1, 1000]");
    const sim::EmaParams& p = config_.sim.params;
    config_.ident.k_t_nm_per_a = p.k_t_nm_per_a;
    config_.ident.j_kgm2 = p.j_kgm2;  // the characterised (datasheet) inertia, not the plant's true one
    config_.ident.tau = p.tau;
    config_.ident.sample_period_s = sim::kSamplePeriodS;
    status_.mode = Mode::Normal;
    status_.weight_on_wheels = config_.faults.refuse_ground_test != Interlock::WeightOffWheels;
    status_.maintenance_enable = config_.faults.refuse_ground_test != Interlock::MaintenanceDisabled;
    status_.load_case = icd_load_case(config_.sim.load_case);
    next_status_ = now();
}

void EmaNode::event(const std::string& what) {
    if (on_event) on_event(what);
}

void EmaNode::send(const can::CanFrame& f) {
    if (silent_) return;
    tx_.push_back(f);
}

void EmaNode::flush_tx() {
    if (tx_.empty()) return;
    // The watchdog on a fresh clock reading right before the transmit call: past the deadline the
    // queued telemetry is dropped, and only the ABORTED status (queued by finish) goes out.
    const std::size_t queued = tx_.size();
    if (watchdog_expired()) {
        // finish() appended the ABORTED status; telemetry and status queued before it stay unsent.
        const auto is_stream = [](const can::CanFrame& f) {
            return f.id == can::icd::kTelemetryAId || f.id == can::icd::kTelemetryBId || f.id == can::icd::kStatusId;
        };
        tx_.erase(std::remove_if(tx_.begin(), tx_.begin() + static_cast<std::ptrdiff_t>(queued), is_stream),
                  tx_.begin() + static_cast<std::ptrdiff_t>(queued));
    }
    const auto is_telemetry = [](const can::CanFrame& f) { return f.id == can::icd::kTelemetryAId || f.id == can::icd::kTelemetryBId; };
    // Near the watchdog deadline, frame by frame with a check before each: a process descheduled
    // between a check and its write then leaks at most one frame past the deadline, never a batch.
    const bool near_deadline = status_.mode == Mode::GroundTest && status_.state == SequenceState::Running &&
                               now() - last_heartbeat_ > config_.heartbeat_timeout - kBatchGuard;
    if (near_deadline) {
        const std::size_t queued_before = tx_.size();
        bool expired = false;
        for (std::size_t i = 0; i < tx_.size(); ++i) {
            // Past the deadline only what finish() appended (the ABORTED status) goes out.
            const bool stream = is_telemetry(tx_[i]) || tx_[i].id == can::icd::kStatusId;
            if (i < queued_before && stream && (expired || (expired = watchdog_expired()))) continue;
            ++stats_.send_calls;
            if (bus_.send(tx_[i]) != can::SendStatus::Sent) ++stats_.send_failures;
            else if (is_telemetry(tx_[i])) ++stats_.telemetry_frames_sent;
        }
        tx_.clear();
        return;
    }
    const can::BatchSendResult r = bus_.send_batch(tx_);
    ++stats_.send_calls;
    for (std::size_t i = 0; i < r.sent; ++i)
        if (is_telemetry(tx_[i])) ++stats_.telemetry_frames_sent;
    stats_.send_failures += tx_.size() - r.sent;
    tx_.clear();
}

bool EmaNode::faults_active() const {
    return config_.faults.fault_sequences == 0 || stats_.sequences_started <= config_.faults.fault_sequences;
}

HeartbeatGapStats EmaNode::heartbeat_gaps() const {
    HeartbeatGapStats g;
    g.count = heartbeat_gaps_ms_.size();
    if (g.count == 0) return g;
    std::vector<double> v = heartbeat_gaps_ms_;
    std::sort(v.begin(), v.end());
    auto q = [&](double p) { return v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1)]; };
    g.p50_ms = q(0.50);
    g.p99_ms = q(0.99);
    g.max_ms = v.back();
    return g;
}

std::optional<std::chrono::steady_clock::duration> EmaNode::tool_idle() const {
    if (!last_tool_frame_) return std::nullopt;
    return now() - *last_tool_frame_;
}

void EmaNode::send_status() {
    send(icd_.encode_status(status_));
    status_.counter = static_cast<std::uint8_t>((status_.counter + 1) % can::icd::kCounterModulo);
}

void EmaNode::run(const std::atomic<bool>& stop) {
    while (!stop.load()) poll(kMaxLoopSleep);
}

void EmaNode::poll(std::chrono::microseconds max_wait) {
    auto now = clock_.now();
    // Sleep until the next thing that is due (status, a window of samples), at most max_wait.
    Clock::time_point due = std::min(next_status_, now + max_wait);
    if (run_ && run_->streaming && run_->next < run_->samples.size()) {
        const auto sample_due = run_->stream_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                                                         static_cast<double>(run_->next + 1) * sim::kSamplePeriodS * config_.time_scale));
        due = std::min(due, sample_due + kTelemetryBatchWindow);
    }
    const auto wait = std::chrono::duration_cast<std::chrono::microseconds>(due - now);
    // Everything queued in one receive call (recvmmsg on SocketCAN).
    rx_.clear();
    (void)bus_.receive_batch(rx_, kReceiveBatch, std::max(wait, std::chrono::microseconds{0}));
    now = clock_.now();
    for (const auto& r : rx_) {
        if (r.status == can::ReceiveStatus::Frame) handle(r.frame, now);
        else if (r.status == can::ReceiveStatus::BusOff) event("bus-off: " + r.detail);
    }

    (void)watchdog_expired();

    if (run_ && !run_->streaming && run_->simulation.valid() &&
        run_->simulation.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
        sim::SimResult result;
        try {
            result = run_->simulation.get();
        } catch (const std::exception& e) {
            finish(SequenceState::Aborted, FaultCode::SimulationFailed, std::string("simulation failed: ") + e.what());
            flush_tx();
            return;
        }
        if (!result.finite) {
            finish(SequenceState::Aborted, FaultCode::SimulationFailed, "simulation diverged (NaN or inf)");
            flush_tx();
            return;
        }
        run_->samples = std::move(result.samples);
        run_->streaming = true;
        run_->stream_start = now;
        run_->silent_at = config_.faults.silent_after_fraction
                              ? static_cast<std::size_t>(std::floor(*config_.faults.silent_after_fraction * static_cast<double>(run_->samples.size())))
                              : run_->samples.size() + 1;
        run_->burst_first = static_cast<std::size_t>(
            std::floor(config_.faults.drop_burst_at_fraction * 2.0 * static_cast<double>(run_->samples.size())));
        event("streaming " + std::to_string(run_->samples.size()) + " samples");
    }
    if (run_ && run_->streaming) stream_due(now);

    if (now >= next_status_) {
        send_status();
        next_status_ += can::icd::kStatusPeriod;
        if (next_status_ < now) next_status_ = now + can::icd::kStatusPeriod;
    }
    flush_tx();
}

void EmaNode::handle(const can::CanFrame& f, Clock::time_point now) {
    if (f.extended || f.error) return;
    if (f.id == can::icd::kToolHeartbeatId || f.id == can::icd::kToolCommandId) last_tool_frame_ = now;
    if (f.id == can::icd::kToolHeartbeatId) {
        // Date the heartbeat from its arrival on the bus (receive timestamp), not from when this loop
        // got to it, so a late pass cannot stretch the 100 ms deadline.
        Clock::time_point arrival = now;
        if (f.timestamp.count() > 0) {
            const auto age = clock_.since_epoch() - f.timestamp;
            if (age > Clock::duration::zero() && age < config_.heartbeat_timeout)
                arrival = now - std::chrono::duration_cast<Clock::duration>(age);
        }
        if (status_.mode == Mode::GroundTest) {
            // The gap the watchdog sees: since the previous heartbeat, or since entry to ground test.
            const Clock::time_point since = last_heartbeat_arrival_ ? std::max(*last_heartbeat_arrival_, last_heartbeat_) : last_heartbeat_;
            if (arrival > since) heartbeat_gaps_ms_.push_back(std::chrono::duration<double, std::milli>(arrival - since).count());
        }
        // Never backwards: a heartbeat that reached the bus before ENTER_GROUND_TEST but is handled
        // after it in the same late batch must not move the watchdog's start before the entry.
        last_heartbeat_ = std::max(last_heartbeat_, arrival);
        last_heartbeat_arrival_ = last_heartbeat_arrival_ ? std::max(*last_heartbeat_arrival_, arrival) : arrival;
        return;
    }
    if (auto c = icd_.decode_command(f)) handle_command(*c, now);
}

void EmaNode::handle_command(const can::ToolCommand& c, Clock::time_point now) {
    can::CommandAck ack{c.command, AckResult::Accepted, c.session_id};
    const bool running = status_.state == SequenceState::Running;
    switch (c.command) {
        case Command::EnterGroundTest:
            if (!status_.weight_on_wheels) ack.result = AckResult::RefusedWeightOnWheels;
            else if (!status_.maintenance_enable) ack.result = AckResult::RefusedMaintenanceDisabled;
            else if (config_.faults.ack_without_ground_test) {
                event("accepted ENTER_GROUND_TEST but stayed in NORMAL (fault injection)");
            } else {
                status_.mode = Mode::GroundTest;
                last_heartbeat_ = now;  // the watchdog counts from entry
                event("entered GROUND_TEST");
            }
            if (ack.result != AckResult::Accepted)
                event("refused ENTER_GROUND_TEST: " + icd_.value_name(icd_.ack, "AckResult", static_cast<int>(ack.result)));
            break;
        case Command::LeaveGroundTest:
            if (running) ack.result = AckResult::RefusedBusy;
            else if (status_.mode == Mode::GroundTest) {
                status_.mode = Mode::Normal;
                event("left GROUND_TEST");
            }
            break;
        case Command::StartSequence:
            if (status_.mode != Mode::GroundTest) ack.result = AckResult::RefusedNotInGroundTest;
            else if (running) ack.result = AckResult::RefusedBusy;
            else if (c.sequence != TestSequence::Dyn && c.sequence != TestSequence::Brk) ack.result = AckResult::RefusedBadArgument;
            break;
        case Command::Abort:
            if (running) finish(SequenceState::Aborted, FaultCode::AbortedByTool, "aborted by the tool; holding position");
            break;
        case Command::RequestIdent: break;
        default: ack.result = AckResult::RefusedUnknownCommand;
    }
    send(icd_.encode_ack(ack));
    if (c.command == Command::RequestIdent)
        for (const auto& f : icd_.encode_ident(config_.ident)) send(f);
    if (c.command == Command::StartSequence && ack.result == AckResult::Accepted) start_sequence(c, now);
}

void EmaNode::start_sequence(const can::ToolCommand& c, Clock::time_point) {
    sim::SimConfig cfg = config_.sim;
    cfg.sequence = c.sequence == TestSequence::Dyn ? sim::Sequence::Dyn : sim::Sequence::Brk;
    cfg.duration_s = 0.0;
    cfg.record_truth = false;
    status_.state = SequenceState::Running;
    status_.sequence = c.sequence;
    status_.session_id = c.session_id;
    status_.samples_sent = 0;
    status_.fault = FaultCode::None;
    run_ = std::make_shared<Running>();
    run_->simulation = std::async(std::launch::async, [cfg] {
        lower_this_thread_priority();  // the bus loop (status, watchdog, pacing) must never wait for it
        return sim::simulate(cfg);
    });
    ++stats_.sequences_started;
    event("START_SEQUENCE " + sim::to_string(cfg.sequence) + " session " + std::to_string(c.session_id) + ": simulating");
    send_status();
}

bool EmaNode::watchdog_expired() {
    // Heartbeat watchdog (ICD: TOOL_Heartbeat missing > 100 ms in GROUND_TEST aborts and holds).
    const auto now = clock_.now();
    if (status_.mode == Mode::GroundTest && status_.state == SequenceState::Running &&
        now - last_heartbeat_ > config_.heartbeat_timeout) {
        finish(SequenceState::Aborted, FaultCode::HeartbeatLost,
               "heartbeat lost: none for " + ms_text(now - last_heartbeat_) + "; holding position");
        return true;
    }
    return false;
}

void EmaNode::stream_due(Clock::time_point now) {
    Running& r = *run_;
    const double period_s = sim::kSamplePeriodS * config_.time_scale;
    const bool faults = faults_active();
    std::uniform_real_distribution<double> u(0.0, 1.0);  // only compared against fractions
    auto draw = [&](double fraction) { return fraction > 0 && u(fault_rng_) < fraction; };
    while (r.next < r.samples.size()) {
        const auto due = r.stream_start + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(static_cast<double>(r.next + 1) * period_s));
        if (due > now) break;
        if (r.next == r.silent_at && !silent_) {
            event("going silent at sample " + std::to_string(r.next) + " (fault injection)");
            silent_ = true;  // what is already queued (due before this sample) still goes out
        }
        const sim::Sample& s = r.samples[r.next];
        const auto index = static_cast<std::uint16_t>(r.next);
        can::CanFrame a, b;
        try {
            a = icd_.encode_telemetry_a(index, r.counter_a, s.current_a, s.speed_rad_s);
            b = icd_.encode_telemetry_b(index, r.counter_b, s.theta_m_rad, s.hinge_moment_nm);
        } catch (const can::CanError& e) {
            finish(SequenceState::Aborted, FaultCode::SimulationFailed, std::string("sample out of the ICD range: ") + e.what());
            return;
        }
        r.counter_a = static_cast<std::uint8_t>((r.counter_a + 1) % can::icd::kCounterModulo);
        r.counter_b = static_cast<std::uint8_t>((r.counter_b + 1) % can::icd::kCounterModulo);
        for (can::CanFrame* f : {&a, &b}) {
            const std::size_t k = r.frames_made++;
            // Two draws per frame, always, so the fault pattern depends only on the seed.
            const bool corrupt = draw(config_.faults.corrupt_crc_fraction);
            const bool drop = draw(config_.faults.drop_fraction);
            const bool duplicate = draw(config_.faults.duplicate_fraction);
            const bool reorder = draw(config_.faults.reorder_fraction);
            if (silent_ || !faults) {
                if (!silent_) send(*f);
                continue;
            }
            const bool in_burst = config_.faults.drop_burst_frames > 0 && k >= r.burst_first && k < r.burst_first + config_.faults.drop_burst_frames;
            if (drop || in_burst) {
                ++stats_.telemetry_frames_dropped;
                continue;
            }
            if (corrupt) {
                f->data[can::icd::kTelemetryCrcBytes] ^= kCrcCorruption;
                ++stats_.telemetry_crc_corrupted;
            }
            if (r.held) {  // the frame held back goes out after this one
                send(*f);
                send(*r.held);
                r.held.reset();
                ++stats_.telemetry_frames_reordered;
            } else if (reorder) {
                r.held = *f;
            } else {
                send(*f);
            }
            if (duplicate) {
                send(*f);
                ++stats_.telemetry_frames_duplicated;
            }
        }
        ++r.next;
        status_.samples_sent = static_cast<std::uint16_t>(r.next);
    }
    if (r.next < r.samples.size()) return;
    if (r.held) {
        send(*r.held);
        r.held.reset();
    }
    finish(SequenceState::Done, FaultCode::None, "sequence done: " + std::to_string(r.samples.size()) + " samples");
}

void EmaNode::finish(SequenceState state, FaultCode fault, const std::string& why) {
    status_.state = state;
    status_.fault = fault;
    if (state == SequenceState::Done) ++stats_.sequences_done;
    else ++stats_.sequences_aborted;
    if (run_ && run_->simulation.valid()) {
        // Detach from a simulation still running: keep it alive in the shared state until done.
        auto keep = run_;
        std::thread([keep] { keep->simulation.wait(); }).detach();
    }
    run_.reset();
    event(why);
    send_status();  // report the change at once, not at the next 20 ms tick
}

}  // namespace emadiag::node
