#pragma once
// The tool-side sequencer (emadiag record): makes sure no other tool commands the bus,
// identifies the EMA, enters ground test, runs one sequence with the 50 Hz heartbeat (its own
// thread: can_tool/heartbeat_sender.hpp), logs every frame of both directions to a candump log
// (received in batches, written buffered, in time order), and decodes the session into a Run.
#include "can_tool/heartbeat_sender.hpp"
#include "can_tool/session_decoder.hpp"
#include "core/run.hpp"

#include "emadiag/can/can_bus.hpp"
#include "emadiag/can/candump_log.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
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
    /// Listen this long before the first command: a TOOL_Command or TOOL_Heartbeat heard then means
    /// another tool is on the bus, and nothing is sent. Longer than the EMA's 100 ms heartbeat
    /// watchdog: a tool that keeps an EMA in a sequence must send a heartbeat within every 100 ms, so
    /// this window hears it even when that tool's sender runs late. (Three nominal periods, 60 ms,
    /// missed a tool whose heartbeats came 54 ms apart on a loaded user-mode Linux guest in CI.)
    std::chrono::milliseconds listen_before_command{150};
    bool send_heartbeat = true;                            ///< false only to test the EMA's watchdog
    /// A heartbeat that spans several sequences (test-run: it keeps going between them, while runs
    /// are estimated, so no other tool finds the bus free); started here if not yet running, and
    /// left running (stopped only when the recording fails). Null: the recorder runs its own for the
    /// one sequence.
    HeartbeatSender* shared_heartbeat = nullptr;
};

/// What the bus path did: the figures of bench/vcan_session_bench.
struct BusLoopStats {
    std::uint64_t frames_received = 0;   ///< frames and error frames read from the bus
    std::uint64_t receive_calls = 0;     ///< batched receive calls that returned something
    HeartbeatStats heartbeat;
    double wall_s = 0.0;                 ///< the whole record(), identification to leave
    double cpu_s = 0.0;                  ///< process CPU time (user + system) over the same span
};

struct RecordOutcome {
    Run run;              ///< decoded session (meta status / valid / counts)
    SessionStats stats;
    std::string status;   ///< "complete", "aborted", "incomplete"
    bool valid = false;
    std::string invalid_reason;
    std::size_t log_lines = 0;
    BusLoopStats loop;
    /// Set when the run was lost to something passing (frames dropped or corrupted on the bus, the
    /// EMA's heartbeat watchdog, the EMA going silent): running the sequence again may succeed.
    bool transient_loss = false;
};

class Recorder {
public:
    Recorder(can::CanBus& bus, RecorderOptions options);
    /// Runs the session. `interrupt` (Ctrl-C) sends ABORT, keeps the partial log and marks the
    /// run aborted. Throws EmadiagError for no answer (naming the bus and the awaited message), for
    /// a refusal (naming the reason) and for another tool on the bus (naming what was heard); the
    /// log written so far is kept in every case.
    RecordOutcome record(const std::atomic<bool>& interrupt);

private:
    using Clock = std::chrono::steady_clock;
    void transmit(const can::CanFrame& f);
    /// Receives (and logs) until `done()` or the deadline. Returns done().
    bool pump(Clock::time_point deadline, const std::function<bool()>& done, const std::atomic<bool>* interrupt = nullptr);
    std::string no_answer(const std::string& awaited, const std::string& after) const;
    /// Writes the heartbeats sent up to `upto` (all of them when nullopt) to the log, in time order.
    /// `take`: first collect what the heartbeat thread sent since the last call.
    void log_heartbeats(std::optional<std::chrono::nanoseconds> upto, bool take = true);
    void log(const can::CanFrame& f);
    /// Throws (after flushing the log) when the heartbeat thread could not send.
    void check_heartbeat() const;
    [[noreturn]] void fail(const std::string& message);

    can::CanBus& bus_;
    RecorderOptions options_;
    can::CandumpWriter writer_;
    SessionDecoder decoder_;
    std::unique_ptr<HeartbeatSender> own_heartbeat_;
    HeartbeatSender& heartbeat_;
    std::vector<can::CanFrame> heartbeats_pending_;
    std::vector<can::ReceiveResult> batch_;
    BusLoopStats loop_;
    std::uint64_t ema_frames_ = 0;
    Clock::time_point last_ema_frame_;
    std::optional<can::CommandAck> last_ack_;
    std::optional<std::string> other_tool_;  ///< what betrayed another tool on the bus
};

}  // namespace emadiag::can_tool
