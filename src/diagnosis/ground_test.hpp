#pragma once
// The technician's test run (`emadiag test-run`): on the ramp, against the EMA on a CAN bus, one
// command runs the ground routine and ends in a verdict stored under the aircraft's tail number.
//   1. The tail number is checked and the database opened (migrated) before anything moves.
//   2. For each sequence of the phase (DYN, the paper's pre/post-flight routine, then BRK, which
//      makes FSJ observable): the recorder identifies the EMA, enters ground test and confirms the
//      EMA reports GROUND_TEST, runs the sequence with the 50 Hz heartbeat and logs every frame
//      of both directions to a candump file (kept before anything is computed from it).
//   3. Each valid run is checked and estimated by both methods (physics, network).
//   4. The verdict (diagnosis/verdict.hpp) is formed against the limits.
//   5. Session, runs (samples, raw logs, estimates) and findings go into SQLite in one transaction.
// A run lost to something passing (dropped or corrupted frames, the EMA's heartbeat watchdog, a
// silent EMA) is run once more on its own, and the technician is told; both attempts are stored.
// An aborted or invalid run ends the session as NO_TEST; its logs are stored all the same.
// The session is spooled beside the database (diagnosis/session_spool.hpp) until it is stored.
#include "can_tool/recorder.hpp"
#include "diagnosis/augmented_model_use.hpp"
#include "diagnosis/session_spool.hpp"
#include "diagnosis/health_limits.hpp"
#include "diagnosis/session_storage.hpp"
#include "diagnosis/verdict.hpp"

#include "emadiag/db/session_store.hpp"

#include "emadiag/can/can_bus.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace emadiag {

/// The ground routine: the datasheet defines one (DYN then BRK, case A on the ground). The phase
/// is recorded with the session so trends can keep cold (pre-flight) and warm (post-flight)
/// transmissions apart.
inline constexpr const char* kPhasePreFlight = "pre-flight";
inline constexpr const char* kPhasePostFlight = "post-flight";

struct TestRunOptions {
    std::string tail_number;
    std::string phase = kPhasePreFlight;
    std::vector<can::icd::TestSequence> sequences{can::icd::TestSequence::Dyn, can::icd::TestSequence::Brk};
    std::filesystem::path out_dir;   ///< raw logs and run CSVs: <tail>_<utc>_<phase>_<sequence>.{log,csv}
    std::string db_path;             ///< the maintenance database (created if missing)
    HealthLimits limits = HealthLimits::datasheet_envelope();
    /// An augmented model from `emadiag discover` (empty: none). It is read and checked before anything
    /// moves; each valid run is estimated with its effects and terms removed (augmented_model_use.hpp).
    std::string augmented_model_path;
    std::uint16_t first_session_id = 1;  ///< START_SEQUENCE session ids: this, this + 1, ...
    std::chrono::milliseconds answer_timeout{500};
    std::string tool_version;
    /// Run a sequence once more when a transient loss invalidated it.
    bool retry_transient = true;
    /// Position, cycles, hours, operator, technician and certificate for the record (checked first:
    /// an unknown position is an error before anything moves).
    SessionRecordInfo record;
    /// Progress lines for the technician (libraries never print; the CLI passes them to stdout).
    std::function<void(const std::string&)> on_progress;
};

struct TestRunRecord {
    sim::Sequence sequence = sim::Sequence::Dyn;  ///< the run's sequence (text only where it is shown or spooled)
    int attempt = 1;
    can_tool::RecordOutcome outcome;
    std::string log_path, csv_path;
    std::optional<RunEstimates> estimates;
    std::string estimate_error;  ///< why a valid run could not be estimated
};

struct TestRunResult {
    std::int64_t db_session_id = 0;
    std::optional<AugmentedModelUse> augmented_model;  ///< the model the estimates used (--model)
    std::string started_utc;
    std::string actuator_serial;
    std::vector<TestRunRecord> runs;
    Assessment assessment;
    bool interrupted = false;
    std::vector<RecoveredSession> recovered;  ///< earlier spooled sessions stored first
    std::string content_sha256;  ///< the stored session's link in the tail's hash chain
    std::optional<db::StoredInstallation> installation;  ///< when the position showed a new serial
};

/// Runs the session. Throws EmadiagError (after keeping the logs written so far on disk) when the
/// EMA does not answer, refuses ground test or does not confirm it; DbError for a bad tail number
/// or an unusable database, before the surface moves.
[[nodiscard]] TestRunResult run_test(can::CanBus& bus, const TestRunOptions& options, const std::atomic<bool>& interrupt);

/// The parts of a session's storage shared by the live test run and the spool recovery.
namespace session_parts {
/// Estimates a valid run (both methods), on the run corrected by `model` when given; an estimation
/// error goes to `estimate_error`.
void estimate(TestRunRecord& record, const AugmentedModelUse* model = nullptr);
/// The verdict from the last attempt of each sequence.
[[nodiscard]] Assessment assess_records(const std::vector<TestRunRecord>& runs, const HealthLimits& limits);
/// The stored session: every attempt's run with its raw log read back from `log_path`; the
/// manifest's augmented model (if any) is listed first among the artifacts, with the SHA-256 of its text.
[[nodiscard]] db::StoredTestSession to_stored_session(const SessionManifest& header, const std::vector<TestRunRecord>& runs,
                                                      const Assessment& assessment);
}  // namespace session_parts

/// "dyn" or "brk"; throws EmadiagError on another name.
[[nodiscard]] can::icd::TestSequence parse_test_sequence(const std::string& name);

}  // namespace emadiag
