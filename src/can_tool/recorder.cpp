#include "can_tool/recorder.hpp"

#include "core/emadiag_error.hpp"

#include <ctime>

namespace emadiag::can_tool {

using can::icd::Command;

namespace {
constexpr std::chrono::milliseconds kAbortWait{300};
constexpr std::chrono::milliseconds kLeaveWait{200};
constexpr std::chrono::milliseconds kMaxReceiveWait{5};
/// Frames taken from the bus per receive call (one recvmmsg on SocketCAN).
constexpr std::size_t kReceiveBatch = 64;
/// A heartbeat older than this is written to the log even when no later frame has come to order
/// it against (the EMA may be silent).
constexpr std::chrono::milliseconds kHeartbeatLogHold{100};

bool is_ema_frame(const can::CanFrame& f) {
    return !f.extended && (f.id == can::icd::kStatusId || f.id == can::icd::kCommandAckId || f.id == can::icd::kIdentId ||
                           f.id == can::icd::kTelemetryAId || f.id == can::icd::kTelemetryBId);
}

/// A tool's frame that this recorder did not send (the bus never returns a socket's own frames).
bool is_tool_frame(const can::CanFrame& f) {
    return !f.extended && !f.error && (f.id == can::icd::kToolCommandId || f.id == can::icd::kToolHeartbeatId);
}

bool is_abort(const can::CanFrame& f) {
    return f.id == can::icd::kToolCommandId && f.len >= 1 && f.data[0] == static_cast<std::uint8_t>(can::icd::Command::Abort);
}

std::chrono::nanoseconds unix_now() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch());
}

double process_cpu_s() {
    timespec ts{};
    ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

Recorder::Recorder(can::CanBus& bus, RecorderOptions options)
    : bus_(bus),
      options_(std::move(options)),
      writer_(options_.log_path),
      own_heartbeat_(options_.shared_heartbeat ? nullptr : std::make_unique<HeartbeatSender>(bus_)),
      heartbeat_(options_.shared_heartbeat ? *options_.shared_heartbeat : *own_heartbeat_) {}

void Recorder::fail(const std::string& message) {
    // Nothing more goes out once the session has failed (bus-off, no answer, a refusal): the
    // heartbeat stops too, shared or not, and the EMA's watchdog holds a running sequence.
    heartbeat_.stop();
    log_heartbeats(std::nullopt);
    writer_.flush();
    throw EmadiagError(message);
}

void Recorder::log(const can::CanFrame& f) {
    writer_.write(f, bus_.interface_name());
    decoder_.feed(f);
}

void Recorder::log_heartbeats(std::optional<std::chrono::nanoseconds> upto, bool take) {
    if (take) heartbeat_.take_sent(heartbeats_pending_);
    if (heartbeats_pending_.empty()) return;
    std::size_t n = 0;
    while (n < heartbeats_pending_.size() && (!upto || heartbeats_pending_[n].timestamp <= *upto)) log(heartbeats_pending_[n++]);
    heartbeats_pending_.erase(heartbeats_pending_.begin(), heartbeats_pending_.begin() + static_cast<std::ptrdiff_t>(n));
}

void Recorder::check_heartbeat() const {
    if (auto why = heartbeat_.failure())
        throw EmadiagError("cannot send TOOL_Heartbeat (0x011) on " + bus_.spec() + ": " + *why);
}

void Recorder::transmit(const can::CanFrame& frame) {
    can::CanFrame f = frame;
    f.timestamp = unix_now();
    const can::SendStatus s = bus_.send(f);
    if (s != can::SendStatus::Sent) fail("cannot send " + can::format_id(f.id, f.extended) + " on " + bus_.spec() + ": " + can::to_string(s));
    log_heartbeats(f.timestamp);
    log(f);
}

bool Recorder::pump(Clock::time_point deadline, const std::function<bool()>& done, const std::atomic<bool>* interrupt) {
    for (;;) {
        if (done()) return true;
        auto now = Clock::now();
        if (now >= deadline) return false;
        if (interrupt && interrupt->load()) return false;
        if (heartbeat_.failure()) {
            log_heartbeats(std::nullopt);
            writer_.flush();
            check_heartbeat();
        }
        const auto wait = std::chrono::duration_cast<std::chrono::microseconds>(std::min(deadline, now + kMaxReceiveWait) - now);
        batch_.clear();
        (void)bus_.receive_batch(batch_, kReceiveBatch, std::max(wait, std::chrono::microseconds{0}));
        if (!batch_.empty()) {
            ++loop_.receive_calls;
            heartbeat_.take_sent(heartbeats_pending_);  // once per batch: merged below by time
        }
        bool ema_seen = false;
        for (auto& r : batch_) {
            ++loop_.frames_received;
            // The heartbeats this tool sent before the frame arrived go into the log before it.
            if (r.frame.timestamp.count() > 0) log_heartbeats(r.frame.timestamp, false);
            if (r.status == can::ReceiveStatus::Frame) {
                log(r.frame);
                if (is_ema_frame(r.frame)) {
                    ++ema_frames_;
                    ema_seen = true;
                } else if (is_tool_frame(r.frame) && !other_tool_ && !is_abort(r.frame)) {
                    // (An ABORT from anyone, e.g. `cansend` from a shell, is a safety action that
                    // ends the run ABORTED like Ctrl-C, not a conflict.)
                    other_tool_ = (r.frame.id == can::icd::kToolCommandId ? "TOOL_Command (0x010)" : "TOOL_Heartbeat (0x011)") +
                                  std::string(" from another tool");
                }
                if (auto a = decoder_.icd.decode_ack(r.frame)) last_ack_ = a;
            } else if (r.status == can::ReceiveStatus::ErrorFrame) {
                log(r.frame);
            } else if (r.status == can::ReceiveStatus::BusOff) {
                if (r.frame.error) log(r.frame);
                fail(bus_.spec() + ": bus-off: " + r.detail);
            } else if (r.status == can::ReceiveStatus::EndOfLog) {
                fail(bus_.spec() + ": the replayed log ended while waiting");
            }
        }
        if (ema_seen) last_ema_frame_ = Clock::now();
        log_heartbeats(unix_now() - std::chrono::duration_cast<std::chrono::nanoseconds>(kHeartbeatLogHold));
    }
}

std::string Recorder::no_answer(const std::string& awaited, const std::string& after) const {
    return "no EMA answered on " + bus_.spec() + " within " + std::to_string(options_.answer_timeout.count()) + " ms: waited for " +
           awaited + " after " + after + (ema_frames_ == 0 ? " (no EMA frame seen at all)" : "");
}

RecordOutcome Recorder::record(const std::atomic<bool>& interrupt) {
    const can::EmaIcd& icd = decoder_.icd;
    const auto wall_start = Clock::now();
    const double cpu_start = process_cpu_s();
    auto send_command = [&](Command c) {
        can::ToolCommand tc{c, can::icd::TestSequence::None, 0};
        if (c == Command::StartSequence) tc = can::ToolCommand{c, options_.sequence, options_.session_id};
        last_ack_.reset();
        transmit(icd.encode_command(tc));
    };
    auto acked = [&](Command c) { return [this, c] { return last_ack_ && last_ack_->command == c; }; };
    // 0. Nobody else may be commanding this EMA: listen before the first command. Heartbeats a
    // shared sender sent before this sequence belong to no sequence's log.
    {
        std::vector<can::CanFrame> before;
        heartbeat_.take_sent(before);
    }
    (void)pump(Clock::now() + options_.listen_before_command, [&] { return other_tool_.has_value(); });
    if (other_tool_)
        fail("another tool is active on " + bus_.spec() + ": heard " + *other_tool_ +
             " before sending anything; nothing was commanded. Disconnect the other tool, then run again");
    if (options_.send_heartbeat) heartbeat_.start();

    // 1. Identification (the constants of the Run).
    send_command(Command::RequestIdent);
    if (!pump(Clock::now() + options_.answer_timeout, [&] { return decoder_.ident_complete(); }))
        fail(no_answer("EMA_Ident (0x022, 5 pages)", "TOOL_Command REQUEST_IDENT (0x010)"));

    // 2. Ground test mode: the interlocks decide.
    send_command(Command::EnterGroundTest);
    if (!pump(Clock::now() + options_.answer_timeout, acked(Command::EnterGroundTest)))
        fail(no_answer("EMA_CommandAck (0x021)", "TOOL_Command ENTER_GROUND_TEST (0x010)"));
    if (last_ack_->result != can::icd::AckResult::Accepted) {
        std::string why = icd.value_name(icd.ack, "AckResult", static_cast<int>(last_ack_->result));
        // The interlock states come with the 50 Hz status: wait for one if none has arrived yet.
        (void)pump(Clock::now() + 2 * can::icd::kStatusPeriod + kMaxReceiveWait, [&] { return decoder_.last_status().has_value(); });
        if (const auto& s = decoder_.last_status())
            why += " (interlocks: WeightOnWheels=" + icd.value_name(icd.status, "WeightOnWheels", s->weight_on_wheels) +
                   ", MaintenanceEnable=" + icd.value_name(icd.status, "MaintenanceEnable", s->maintenance_enable) + ")";
        fail("the EMA on " + bus_.spec() + " refused ENTER_GROUND_TEST: " + why);
    }
    // The acknowledgement is not enough: the EMA's own 50 Hz status must say GROUND_TEST before
    // anything moves the surface.
    const auto in_ground_test = [&] { const auto& s = decoder_.last_status(); return s && s->mode == can::icd::Mode::GroundTest; };
    if (!pump(Clock::now() + options_.answer_timeout, in_ground_test)) {
        const auto& s = decoder_.last_status();
        fail("the EMA on " + bus_.spec() + " acknowledged ENTER_GROUND_TEST but its EMA_Status (0x020) " +
             (s ? "reports Mode=" + icd.value_name(icd.status, "Mode", static_cast<int>(s->mode)) : std::string("never arrived")) +
             " after " + std::to_string(options_.answer_timeout.count()) +
             " ms; no sequence was started");
    }

    // 3. Start the sequence.
    send_command(Command::StartSequence);
    if (!pump(Clock::now() + options_.answer_timeout, acked(Command::StartSequence)))
        fail(no_answer("EMA_CommandAck (0x021)", "TOOL_Command START_SEQUENCE (0x010)"));
    if (last_ack_->result != can::icd::AckResult::Accepted)
        fail("the EMA on " + bus_.spec() + " refused START_SEQUENCE: " + icd.value_name(icd.ack, "AckResult", static_cast<int>(last_ack_->result)));

    // 4. Collect telemetry until the EMA reports DONE or ABORTED for our session.
    std::string status = "complete";
    std::string problem;
    last_ema_frame_ = Clock::now();
    const auto seq_deadline = Clock::now() + options_.sequence_timeout;
    auto finished = [&] {
        const auto& s = decoder_.last_status();
        return s && s->session_id == options_.session_id &&
               (s->state == can::icd::SequenceState::Done || s->state == can::icd::SequenceState::Aborted);
    };
    auto finished_or_conflict = [&] { return finished() || other_tool_.has_value(); };
    bool transient = false;
    for (;;) {
        const auto silence_deadline = last_ema_frame_ + options_.silence_timeout;
        if (pump(std::min(seq_deadline, silence_deadline), finished_or_conflict, &interrupt)) {
            if (!finished()) {
                // Another tool commands the same EMA: its commands and ours cannot both be obeyed.
                status = "incomplete";
                problem = "another tool commanded on " + bus_.spec() + " during the sequence (" + *other_tool_ + "); ABORT sent";
                send_command(Command::Abort);
                (void)pump(Clock::now() + kAbortWait, finished);
            }
            break;
        }
        if (interrupt.load()) {
            status = "aborted";
            send_command(Command::Abort);
            (void)pump(Clock::now() + kAbortWait, finished);
            break;
        }
        if (Clock::now() >= seq_deadline) {
            status = "incomplete";
            problem = "the sequence did not finish within " + std::to_string(options_.sequence_timeout.count()) + " ms";
            break;
        }
        if (Clock::now() >= last_ema_frame_ + options_.silence_timeout) {
            status = "incomplete";
            problem = "the EMA on " + bus_.spec() + " went silent: no frame for " + std::to_string(options_.silence_timeout.count()) +
                      " ms during the sequence";
            transient = true;
            break;
        }
    }
    if (status == "complete") (void)pump(Clock::now() + options_.trailing_grace, [] { return false; });

    // 5. Leave ground test (best effort: the EMA may be gone).
    send_command(Command::LeaveGroundTest);
    (void)pump(Clock::now() + kLeaveWait, acked(Command::LeaveGroundTest));
    if (own_heartbeat_) own_heartbeat_->stop();
    log_heartbeats(std::nullopt);
    writer_.flush();

    RecordOutcome out;
    out.run = decoder_.build_run("emadiag record");
    out.run.set_meta("bus", bus_.spec());
    out.run.set_meta("log_file", options_.log_path);
    if (status == "aborted") out.run.set_meta("status", "aborted");
    if (!problem.empty()) {
        out.run.set_meta("status", "incomplete");
        out.run.set_meta("valid", "false");
        out.run.set_meta("invalid_reason", problem);
    }
    out.stats = decoder_.stats();
    out.status = out.run.meta_value("status").value_or("incomplete");
    out.valid = out.run.meta_value("valid").value_or("false") == "true";
    out.invalid_reason = out.run.meta_value("invalid_reason").value_or("");
    out.log_lines = writer_.lines();
    loop_.heartbeat = heartbeat_.stats();
    loop_.wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
    loop_.cpu_s = process_cpu_s() - cpu_start;
    out.loop = loop_;
    // Lost or corrupted frames, the EMA's watchdog and a silent EMA pass; a refusal, a fault of
    // the actuator, Ctrl-C or another tool do not.
    const auto& last = decoder_.last_status();
    const bool watchdog = last && last->fault == can::icd::FaultCode::HeartbeatLost;
    out.transient_loss = !out.valid && status != "aborted" && !other_tool_ &&
                         (transient || watchdog || out.stats.frames_lost > 0 || out.stats.crc_failures > 0);
    return out;
}

}  // namespace emadiag::can_tool
