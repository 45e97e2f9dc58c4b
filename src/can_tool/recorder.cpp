#include "can_tool/recorder.hpp"

#include "core/emadiag_error.hpp"

namespace emadiag::can_tool {

using can::icd::Command;

namespace {
constexpr std::chrono::milliseconds kAbortWait{300};
constexpr std::chrono::milliseconds kLeaveWait{200};
constexpr std::chrono::milliseconds kMaxReceiveWait{5};

bool is_ema_frame(const can::CanFrame& f) {
    return !f.extended && (f.id == can::icd::kStatusId || f.id == can::icd::kCommandAckId || f.id == can::icd::kIdentId ||
                           f.id == can::icd::kTelemetryAId || f.id == can::icd::kTelemetryBId);
}
}  // namespace

Recorder::Recorder(can::CanBus& bus, RecorderOptions options)
    : bus_(bus), options_(std::move(options)), writer_(options_.log_path) {}

void Recorder::log(const can::CanFrame& f) {
    writer_.write(f, bus_.interface_name());
    decoder_.feed(f);
}

void Recorder::transmit(const can::CanFrame& frame) {
    can::CanFrame f = frame;
    f.timestamp = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch());
    const can::SendStatus s = bus_.send(f);
    if (s != can::SendStatus::Sent) {
        writer_.flush();
        throw EmadiagError("cannot send " + can::format_id(f.id, f.extended) + " on " + bus_.spec() + ": " + can::to_string(s));
    }
    log(f);
}

bool Recorder::pump(Clock::time_point deadline, const std::function<bool()>& done, const std::atomic<bool>* interrupt) {
    for (;;) {
        if (done()) return true;
        auto now = Clock::now();
        if (now >= deadline) return false;
        if (interrupt && interrupt->load()) return false;
        if (options_.send_heartbeat && now >= next_heartbeat_) {
            transmit(decoder_.icd.encode_heartbeat(heartbeat_counter_++));
            next_heartbeat_ += can::icd::kHeartbeatPeriod;
            if (next_heartbeat_ < now) next_heartbeat_ = now + can::icd::kHeartbeatPeriod;
        }
        const auto until = std::min({deadline, next_heartbeat_, now + kMaxReceiveWait});
        const auto wait = std::chrono::duration_cast<std::chrono::microseconds>(until - now);
        can::ReceiveResult r = bus_.receive(std::max(wait, std::chrono::microseconds{0}));
        if (r.status == can::ReceiveStatus::Frame) {
            log(r.frame);
            if (is_ema_frame(r.frame)) {
                ++ema_frames_;
                last_ema_frame_ = Clock::now();
            }
            if (auto a = decoder_.icd.decode_ack(r.frame)) last_ack_ = a;
        } else if (r.status == can::ReceiveStatus::ErrorFrame) {
            log(r.frame);
        } else if (r.status == can::ReceiveStatus::BusOff) {
            writer_.flush();
            throw EmadiagError(bus_.spec() + ": bus-off: " + r.detail);
        } else if (r.status == can::ReceiveStatus::EndOfLog) {
            writer_.flush();
            throw EmadiagError(bus_.spec() + ": the replayed log ended while waiting");
        }
    }
}

std::string Recorder::no_answer(const std::string& awaited, const std::string& after) const {
    return "no EMA answered on " + bus_.spec() + " within " + std::to_string(options_.answer_timeout.count()) + " ms: waited for " +
           awaited + " after " + after + (ema_frames_ == 0 ? " (no EMA frame seen at all)" : "");
}

RecordOutcome Recorder::record(const std::atomic<bool>& interrupt) {
    const can::EmaIcd& icd = decoder_.icd;
    next_heartbeat_ = Clock::now();
    auto send_command = [&](Command c) {
        can::ToolCommand tc{c, can::icd::TestSequence::None, 0};
        if (c == Command::StartSequence) tc = can::ToolCommand{c, options_.sequence, options_.session_id};
        last_ack_.reset();
        transmit(icd.encode_command(tc));
    };
    auto acked = [&](Command c) { return [this, c] { return last_ack_ && last_ack_->command == c; }; };
    auto fail = [&](const std::string& message) -> void {
        writer_.flush();
        throw EmadiagError(message);
    };

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
    for (;;) {
        const auto silence_deadline = last_ema_frame_ + options_.silence_timeout;
        if (pump(std::min(seq_deadline, silence_deadline), finished, &interrupt)) break;
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
            break;
        }
    }
    if (status == "complete") (void)pump(Clock::now() + options_.trailing_grace, [] { return false; });

    // 5. Leave ground test (best effort: the EMA may be gone).
    send_command(Command::LeaveGroundTest);
    (void)pump(Clock::now() + kLeaveWait, acked(Command::LeaveGroundTest));
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
    return out;
}

}  // namespace emadiag::can_tool
