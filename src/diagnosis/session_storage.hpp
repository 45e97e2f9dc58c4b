#pragma once
// The stored form of a test session's parts (maintenance_db), shared by the technician's test run
// and the simulated maintenance history, so both write runs, estimates and findings the same way.
#include "core/run.hpp"
#include "diagnosis/verdict.hpp"
#include "estimation/run_estimator.hpp"

#include "emadiag/db/session_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

/// A run's constants, case, sequence, metadata (as a JSON object), samples and estimates, under
/// `tail` at `started_utc`; source from the run's `source` key, the actuator serial from
/// `ema_serial_number`, valid from its `valid` key (true when absent). The caller adds the raw
/// record (raw_log, raw_log_format) and may refine the source and status note.
[[nodiscard]] db::StoredRun to_stored_run(const Run& run, const std::string& tail, const std::string& started_utc,
                                          const std::optional<RunEstimates>& estimates);

/// Sets the session's verdict, its reason and one finding per line of the assessment.
void set_assessment(db::StoredTestSession& session, const Assessment& assessment);

/// The record of who did the work, where and when in the aircraft's life (14 CFR 43.9, EASA AMC
/// M.A.305(e)), as the technician gives it from the aircraft's technical log.
struct SessionRecordInfo {
    std::string position;  ///< empty: not given
    std::optional<std::int64_t> cycles;
    std::optional<double> hours_h;
    std::string operator_id, technician_name, technician_certificate;
    std::string positions_file;  ///< --positions (empty: $EMADIAG_POSITIONS or the built-in list)
};

/// Checks the record fields before anything moves (an unknown position, negative cycles or hours,
/// a certificate without a name) and sets them, the position's ATA reference and the position
/// list's hash on `session`. Throws EmadiagError naming the field.
void set_record_info(db::StoredTestSession& session, const SessionRecordInfo& info);

/// Adds the model files the estimates used, each with its SHA-256 (role "model"), once each.
void add_model_artifacts(db::StoredTestSession& session, const std::vector<std::string>& model_files);

/// "installation change at LH-ELEV of N123EM: SN-1 -> SN-3 (session 12, 2026-03-05T08:00:00Z, 1200 cycles)".
[[nodiscard]] std::string describe_installation(const db::StoredInstallation& i);

}  // namespace emadiag
