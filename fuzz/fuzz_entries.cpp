// The parsers' fuzz entry points (fuzz_entries.hpp). Each accepts the project's own errors and lets
// everything else escape, so libFuzzer (and the regression unit test) sees it as a finding.
// Beyond "no crash" they check round trips where the format defines one: a run CSV or candump line
// that was read must be written and read back to the same thing.
#include "fuzz/fuzz_entries.hpp"

#include "can_tool/recorder.hpp"
#include "can_tool/session_decoder.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "diagnosis/health_limits.hpp"
#include "discovery/model/augmented_model.hpp"
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/crc8.hpp"
#include "emadiag/can/dbc.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "estimation/dataset.hpp"
#include "estimation/network_model.hpp"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <sstream>
#include <string_view>

namespace emadiag::fuzz {
namespace {

/// A broken property (not a crash): report and abort, so both the fuzzer and the test see it.
[[noreturn]] void property_failed(const char* what, const std::string& detail) {
    std::fprintf(stderr, "fuzz property failed: %s: %s\n", what, detail.c_str());
    std::abort();
}

std::string as_text(const std::uint8_t* data, std::size_t size) {
    return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs `f`, accepting the project's error types (a clean rejection of the input).
template <class F>
void accepting_project_errors(F&& f) {
    try {
        f();
    } catch (const EmadiagError&) {
    } catch (const can::CanError&) {
    } catch (const sim::SimError&) {
    }
}

/// A CAN bus that answers the recorder with a scripted frame stream, then reports the end of the
/// log (the recorder's pump turns that into an EmadiagError at once, so no wall-clock wait).
class ScriptedBus final : public can::CanBus {
public:
    explicit ScriptedBus(std::vector<can::CanFrame> frames) : frames_(frames.begin(), frames.end()) {}
    can::SendStatus send(const can::CanFrame&) override { return can::SendStatus::Sent; }
    can::ReceiveResult receive(std::chrono::microseconds) override {
        can::ReceiveResult r;
        if (frames_.empty()) {
            r.status = can::ReceiveStatus::EndOfLog;
            return r;
        }
        r.frame = frames_.front();
        frames_.pop_front();
        r.status = r.frame.error ? can::ReceiveStatus::ErrorFrame : can::ReceiveStatus::Frame;
        return r;
    }
    void set_filters(const std::vector<can::CanFilter>&) override {}
    [[nodiscard]] const std::string& spec() const override { return spec_; }
    [[nodiscard]] const std::string& interface_name() const override { return name_; }

private:
    std::deque<can::CanFrame> frames_;
    std::string spec_ = "scripted:fuzz", name_ = "fuzz0";
};

}  // namespace

std::vector<can::CanFrame> frame_stream_frames(const std::uint8_t* data, std::size_t size) {
    // Per frame: selector byte (bits 0-2: the ICD id, or 7 = an arbitrary 16-bit id that follows;
    // bit 3: write a correct CRC-8 into byte 7; bit 4 extended, bit 5 remote, bit 6 error frame,
    // bit 7 CAN FD), a length byte, then the payload.
    static constexpr std::uint32_t kIds[7] = {can::icd::kToolCommandId, can::icd::kToolHeartbeatId, can::icd::kStatusId,
                                              can::icd::kCommandAckId,  can::icd::kIdentId,         can::icd::kTelemetryAId,
                                              can::icd::kTelemetryBId};
    static constexpr std::uint8_t kFdLens[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
    std::vector<can::CanFrame> frames;
    std::size_t i = 0;
    while (i + 2 <= size && frames.size() < 100000) {
        const std::uint8_t sel = data[i++];
        can::CanFrame f;
        if ((sel & 7) < 7) {
            f.id = kIds[sel & 7];
        } else {
            if (i + 2 > size) break;
            f.id = (std::uint32_t{data[i]} << 8 | data[i + 1]) & can::kStandardIdMask;
            i += 2;
        }
        f.extended = (sel & 0x10) != 0;
        f.rtr = (sel & 0x20) != 0;
        f.error = (sel & 0x40) != 0;
        f.fd = (sel & 0x80) != 0;
        if (i >= size) break;
        const std::uint8_t len_byte = data[i++];
        f.len = f.fd ? kFdLens[len_byte & 15] : static_cast<std::uint8_t>(len_byte % 9);
        for (std::size_t k = 0; k < f.len && i < size; ++k) f.data[k] = data[i++];
        if ((sel & 0x08) && f.len >= 8) f.data[7] = can::crc8_j1850(f.data.data(), can::icd::kTelemetryCrcBytes);
        f.timestamp = std::chrono::milliseconds(static_cast<long long>(frames.size()));
        frames.push_back(f);
    }
    return frames;
}

void dbc(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    // What strict reading accepts, lenient reading accepts without a warning.
    bool strict_ok = false;
    try {
        (void)can::parse_dbc(text, "fuzz.dbc", can::DbcMode::Strict);
        strict_ok = true;
    } catch (const can::CanError&) {
    }
    accepting_project_errors([&] {
        const can::Database db = can::parse_dbc(text, "fuzz.dbc");
        if (strict_ok && !db.warnings.empty()) property_failed("DBC accepted strictly gives lenient warnings", db.warnings.front());
        // Every parsed message decodes any payload of its length, and re-encodes what it decoded
        // (a value the message cannot represent is a CanError, never a crash).
        std::array<std::uint8_t, can::kFdMaxLen> payload{};
        for (std::size_t k = 0; k < payload.size() && k < size; ++k) payload[k] = data[size - 1 - k];
        std::vector<can::DecodedSignal> decoded;
        for (const auto& m : db.messages) {
            std::string error;
            if (!m.decode(payload.data(), m.length, decoded, &error)) continue;
            std::vector<std::pair<std::string, double>> values;
            for (const auto& d : decoded) values.emplace_back(d.signal->name, d.value);
            try {
                (void)m.encode(values);
            } catch (const can::CanError&) {
            }
        }
    });
}

void candump(const std::uint8_t* data, std::size_t size) {
    // Lenient reading (a session's log) keeps every good line; strict reading of the same text
    // either refuses it or gives the same frames.
    std::vector<can::CandumpRecord> records;
    can::CandumpReport report;
    try {
        std::istringstream in(as_text(data, size));
        records = can::read_candump(in, "fuzz.log", can::CandumpMode::Lenient, &report);
    } catch (const can::CanError&) {
        return;
    }
    if (records.size() != report.frames + report.error_frames)
        property_failed("candump report counts", std::to_string(records.size()) + " records, report " + report.summary());
    try {
        std::istringstream in(as_text(data, size));
        const auto strict = can::read_candump(in, "fuzz.log", can::CandumpMode::Strict);
        if (strict.size() != records.size()) property_failed("candump strict and lenient disagree", report.summary());
    } catch (const can::CanError&) {
    }
    // What was read is written and read back to the same frame, interface and (microsecond) time.
    for (const auto& r : records) {
        const std::string line = can::format_candump_line(r.frame, r.iface);
        std::string error;
        const auto back = can::parse_candump_line(line, error);
        if (!back) property_failed("candump line written from a read frame does not parse", line + ": " + error);
        const can::CanFrame &a = r.frame, &b = back->frame;
        if (a.id != b.id || a.extended != b.extended || a.fd != b.fd || a.brs != b.brs || a.esi != b.esi || a.rtr != b.rtr ||
            a.error != b.error || a.len != b.len || std::memcmp(a.data.data(), b.data.data(), a.len) != 0) {
            property_failed("candump round trip changed the frame", line);
        }
        if (r.iface != back->iface) property_failed("candump round trip changed the interface name", line);
        if (a.timestamp.count() / 1000 != b.timestamp.count() / 1000) property_failed("candump round trip changed the time", line);
    }
}

void run_csv(const std::uint8_t* data, std::size_t size) {
    std::istringstream in(as_text(data, size));
    Run run;
    try {
        run = read_run_csv(in, "fuzz.csv");
    } catch (const EmadiagError&) {
        return;
    }
    // A run that was read is written and read back with the same samples.
    std::stringstream copy;
    write_run_csv(copy, run);
    Run back;
    try {
        back = read_run_csv(copy, "copy.csv");
    } catch (const EmadiagError& e) {
        property_failed("a run CSV written from a read run does not read back", e.what());
    }
    if (back.samples.size() != run.samples.size() || back.extra_columns.size() != run.extra_columns.size())
        property_failed("run CSV round trip changed the run", std::to_string(run.samples.size()) + " samples");
}

void frame_stream(const std::uint8_t* data, std::size_t size) {
    const std::vector<can::CanFrame> frames = frame_stream_frames(data, size);
    // 1. The session decoder: every frame, then the run (or the error naming what is missing).
    can_tool::SessionDecoder decoder;
    for (const auto& f : frames) {
        decoder.feed(f);
        if (const can::Message* m = can::ema_database().find_message(f.id, f.extended)) {
            std::vector<can::DecodedSignal> out;
            (void)m->decode(f.data.data(), f.len, out);
        }
    }
    const can_tool::SessionStats st = decoder.stats();
    if (st.samples_complete > st.samples_expected) property_failed("session stats", "more complete samples than expected");
    accepting_project_errors([&] { (void)decoder.build_run("fuzz"); });

    // 2. The recorder's sequence state machine answered by the same frames.
    static const std::string log_path = "/tmp/emadiag-fuzz-recorder-" + std::to_string(::getpid()) + ".log";
    ScriptedBus bus(frames);
    can_tool::RecorderOptions options;
    options.log_path = log_path;
    options.answer_timeout = std::chrono::milliseconds(20);
    options.silence_timeout = std::chrono::milliseconds(20);
    options.sequence_timeout = std::chrono::milliseconds(200);
    options.trailing_grace = std::chrono::milliseconds(0);
    std::atomic<bool> interrupt{false};
    accepting_project_errors([&] {
        can_tool::Recorder recorder(bus, options);
        (void)recorder.record(interrupt);
    });
}

void model_json(const std::uint8_t* data, std::size_t size) {
    std::string error;
    const auto j = io::parse_bounded_json(std::string_view(reinterpret_cast<const char*>(data), size), error);
    if (!j) return;
    accepting_project_errors([&] { (void)NetworkModel::from_json(*j, "fuzz.json"); });
    accepting_project_errors([&] {
        sim::EmaParams params = sim::EmaParams::datasheet();
        discovery::apply_model(*j, params);
    });
    accepting_project_errors([&] { (void)sim::EmaParams::from_json(*j, "fuzz.json"); });
}

void limits_json(const std::uint8_t* data, std::size_t size) {
    std::string error;
    const auto j = io::parse_bounded_json(std::string_view(reinterpret_cast<const char*>(data), size), error);
    if (!j) return;
    accepting_project_errors([&] {
        const HealthLimits limits = HealthLimits::from_json(*j, "fuzz.json");
        // What was accepted is written and read back to the same limits.
        const HealthLimits back = HealthLimits::from_json(limits.to_json(), "copy.json");
        if (back.limits.size() != limits.limits.size()) property_failed("limits round trip", j->dump());
    });
}

void dataset(const std::uint8_t* data, std::size_t size) {
    std::istringstream in(as_text(data, size));
    accepting_project_errors([&] { (void)read_dataset(in, "fuzz.dataset"); });
}

const std::vector<Target>& targets() {
    static const std::vector<Target> t = {{"dbc", dbc},
                                          {"candump", candump},
                                          {"run_csv", run_csv},
                                          {"frame_stream", frame_stream},
                                          {"model_json", model_json},
                                          {"limits_json", limits_json},
                                          {"dataset", dataset}};
    return t;
}

}  // namespace emadiag::fuzz
