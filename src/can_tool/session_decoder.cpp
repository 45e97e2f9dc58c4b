#include "can_tool/session_decoder.hpp"

#include "can_tool/bus_sequence.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/sim/simulator.hpp"

#include <cstdio>

namespace emadiag::can_tool {
namespace {

/// Percentages in messages: 4 significant digits.
std::string pct(double fraction) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.4g", fraction * 100.0);
    return buf;
}

constexpr std::size_t kMaxSamples = 65536;  // 16-bit sample index

}  // namespace

SessionDecoder::SessionDecoder() = default;

void SessionDecoder::feed(const can::CanFrame& f) {
    ++frames_seen_;
    if (f.error || f.extended) return;
    switch (f.id) {
        case can::icd::kTelemetryAId:
        case can::icd::kTelemetryBId: {
            const bool is_a = f.id == can::icd::kTelemetryAId;
            std::uint16_t index = 0;
            std::uint8_t counter = 0;
            Half h;
            h.present = true;
            if (is_a) {
                can::TelemetryA t;
                if (!icd.decode_telemetry_a(f, t)) return;
                index = t.index, counter = t.counter, h.crc_ok = t.crc_ok, h.v1 = t.current_a, h.v2 = t.speed_rad_s;
            } else {
                can::TelemetryB t;
                if (!icd.decode_telemetry_b(f, t)) return;
                index = t.index, counter = t.counter, h.crc_ok = t.crc_ok, h.v1 = t.theta_m_rad, h.v2 = t.hinge_moment_nm;
            }
            ++received_;
            if (!h.crc_ok) {
                ++crc_failures_;
                // A corrupt frame's index and counter cannot be trusted: count it, use nothing from it.
                return;
            }
            auto& halves = is_a ? a_ : b_;
            if (index >= halves.size()) halves.resize(std::min<std::size_t>(kMaxSamples, index + 1u));
            if (halves[index].present) {
                // A retransmission repeats index and counter: counted, the first copy kept.
                ++duplicates_;
                return;
            }
            int& last = is_a ? last_counter_a_ : last_counter_b_;
            if (last >= 0) counter_gaps_ += static_cast<std::uint64_t>((counter - last - 1 + 16) % 16);
            last = counter;
            halves[index] = h;
            return;
        }
        case can::icd::kStatusId:
            if (auto s = icd.decode_status(f)) last_status_ = s;
            return;
        case can::icd::kIdentId:
            (void)icd.decode_ident(f, ident_);
            return;
        case can::icd::kToolCommandId:
            if (auto c = icd.decode_command(f)) {
                if (c->command == can::icd::Command::StartSequence) {
                    start_ = c;
                    abort_sent_ = false;
                    a_.clear();
                    b_.clear();
                    received_ = crc_failures_ = counter_gaps_ = duplicates_ = 0;
                    last_counter_a_ = last_counter_b_ = -1;
                } else if (c->command == can::icd::Command::Abort && start_) {
                    abort_sent_ = true;
                }
            }
            return;
        default: return;
    }
}

SessionStats SessionDecoder::stats() const {
    SessionStats s;
    std::size_t n = std::max(a_.size(), b_.size());
    if (last_status_ && start_ && last_status_->session_id == start_->session_id)
        n = std::max<std::size_t>(n, last_status_->samples_sent);
    s.samples_expected = n;
    s.frames_expected = 2 * n;
    s.frames_received = received_;
    s.crc_failures = crc_failures_;
    s.counter_gaps = counter_gaps_;
    s.duplicates = duplicates_;
    std::uint64_t present = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const bool ha = k < a_.size() && a_[k].present;
        const bool hb = k < b_.size() && b_[k].present;
        present += ha + hb;
        s.samples_complete += ha && hb;
    }
    // Frames neither received intact nor received corrupt are lost.
    const std::uint64_t accounted = present + crc_failures_;
    s.frames_lost = s.frames_expected > accounted ? s.frames_expected - accounted : 0;
    return s;
}

Run SessionDecoder::build_run(const std::string& source) const {
    if (!ident_.complete())
        throw EmadiagError(source + ": no complete EMA_Ident (0x022, all 5 pages) in the session; the constants k_t, J, tau are unknown");
    if (!start_) throw EmadiagError(source + ": no TOOL_Command START_SEQUENCE (0x010) in the session");
    const can::EmaIdentification& id = ident_.identification();
    const sim::Sequence seq = run_sequence_of(start_->sequence);
    Run run;
    run.constants = RunConstants{id.k_t_nm_per_a, id.j_kgm2, id.tau, id.sample_period_s};
    run.sequence = seq;
    run.load_case = sim::LoadCase::A;
    if (last_status_) {
        switch (last_status_->load_case) {
            case can::icd::LoadCase::A: run.load_case = sim::LoadCase::A; break;
            case can::icd::LoadCase::AExt: run.load_case = sim::LoadCase::AExt; break;
            case can::icd::LoadCase::B: run.load_case = sim::LoadCase::B; break;
        }
    }
    const SessionStats st = stats();
    std::string status = "incomplete";
    if (abort_sent_ || (last_status_ && last_status_->state == can::icd::SequenceState::Aborted)) status = "aborted";
    else if (last_status_ && last_status_->state == can::icd::SequenceState::Done && last_status_->session_id == start_->session_id)
        status = "complete";
    const double loss = st.loss_fraction();
    std::string invalid;
    if (st.samples_expected == 0) invalid = "no telemetry";
    else if (loss > kMaxLossFraction)
        invalid = "telemetry loss " + pct(loss) + " % above " + pct(kMaxLossFraction) + " % (" + std::to_string(st.frames_lost) +
                  " frames lost, " + std::to_string(st.crc_failures) + " CRC failures of " + std::to_string(st.frames_expected) + ")";
    else if (status != "complete") invalid = "sequence " + status;
    if (invalid.empty() && last_status_ && last_status_->fault != can::icd::FaultCode::None)
        invalid = "EMA fault " + icd.value_name(icd.status, "FaultCode", static_cast<int>(last_status_->fault));

    run.set_meta("source", source);
    run.set_required_meta();
    run.set_meta("ema_serial_number", std::to_string(id.serial_number));
    run.set_meta("ema_part_number", std::to_string(id.part_number));
    run.set_meta("ema_firmware", std::to_string(id.firmware_major) + "." + std::to_string(id.firmware_minor) + "." +
                                     std::to_string(id.firmware_patch));
    run.set_meta("session_id", std::to_string(start_->session_id));
    run.set_meta("status", status);
    run.set_meta("samples_expected", std::to_string(st.samples_expected));
    run.set_meta("samples_complete", std::to_string(st.samples_complete));
    run.set_meta("frames_expected", std::to_string(st.frames_expected));
    run.set_meta("frames_lost", std::to_string(st.frames_lost));
    run.set_meta("crc_failures", std::to_string(st.crc_failures));
    run.set_meta("counter_gaps", std::to_string(st.counter_gaps));
    run.set_meta("duplicates", std::to_string(st.duplicates));
    run.set_meta("loss_fraction", format_exact(loss));
    run.set_meta("valid", invalid.empty() ? "true" : "false");
    if (!invalid.empty()) run.set_meta("invalid_reason", invalid);
    run.set_meta("command_deg_source", "tool-side sim::command_deg(sequence, t); not in the telemetry");

    for (std::size_t k = 0; k < st.samples_expected; ++k) {
        if (k >= a_.size() || k >= b_.size() || !a_[k].present || !b_[k].present) continue;  // gap: left out
        const double t = static_cast<double>(k + 1) * id.sample_period_s;
        run.samples.push_back(RunSample{t, a_[k].v1, a_[k].v2, b_[k].v1, b_[k].v2, sim::command_deg(seq, t)});
    }
    return run;
}

}  // namespace emadiag::can_tool
