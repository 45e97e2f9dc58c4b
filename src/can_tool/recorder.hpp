#pragma once
// The tool-side sequencer (emadiag record): identifies the EMA, enters ground test, runs one
// sequence with a 50 Hz heartbeat, logs every frame of both directions to a candump log, and
// decodes the session into a Run.
#include "can_tool/session_decoder.hpp"
#include "core/run.hpp"

#include "emadiag/can/can_bus.hpp"
#include "emadiag/can/candump_log.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

namespace emadiag::can_tool {

struct RecorderOptions {
    can::icd::TestSequence sequence = can::icd::TestSequence::Dyn;
    std::uint16_t session_id = 1;
    std::string log_path;                                  ///< RUN.log
    std::chrono::milliseconds answer_timeout{500};         ///< no EMA answer within this is an error
    std::chrono::milliseconds silence_timeout{500};        ///< no EMA frame at all during a sequence
    std::chrono::milliseconds sequence_timeout{60000};     ///< whole sequence, simulation included
    std::chrono::milliseconds trailing_grace{50};          ///< keep listening after DONE
    bool send_heartbeat = true;                            ///< false only to test the EMA's watchdog
};

struct RecordOutcome {
    Run run;              ///< decoded session (meta status / valid / counts)
    SessionStats stats;
    std::string status;   ///< "complete", "aborted", "incomplete"
    bool valid = false;
    std::string invalid_reason;
    std::size_t log_lines = 0;
};

class Recorder {
public:
    Recorder(can::CanBus& bus, RecorderOptions options);
    /// Runs the session. `interrupt` (Ctrl-C) sends ABORT, keeps the partial log and marks the
    /// run aborted. Throws EmadiagError for no answer (naming the bus and the awaited message) and
    /// for a refusal (naming the reason); the log written so far is kept in both cases.
    RecordOutcome record(const std::atomic<bool>& interrupt);

private:
    using Clock = std::chrono::steady_clock;
    void transmit(const can::CanFrame& f);
    /// Receives (and logs) until `done()` or the deadline; sends heartbeats when due. Returns done().
    bool pump(Clock::time_point deadline, const std::function<bool()>& done, const std::atomic<bool>* interrupt = nullptr);
    std::string no_answer(const std::string& awaited, const std::string& after) const;
    void log(const can::CanFrame& f);

    can::CanBus& bus_;
    RecorderOptions options_;
    can::CandumpWriter writer_;
    SessionDecoder decoder_;
    Clock::time_point next_heartbeat_;
    std::uint8_t heartbeat_counter_ = 0;
    std::uint64_t ema_frames_ = 0;
    Clock::time_point last_ema_frame_;
    std::optional<can::CommandAck> last_ack_;
};

}  // namespace emadiag::can_tool
