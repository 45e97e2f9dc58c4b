#pragma once
// The stored form of a test session's parts (maintenance_db), shared by the technician's test run
// and the simulated maintenance history, so both write runs, estimates and findings the same way.
#include "core/run.hpp"
#include "diagnosis/verdict.hpp"
#include "estimation/run_estimator.hpp"

#include "emadiag/db/test_session_store.hpp"

#include <optional>
#include <string>

namespace emadiag {

/// A run's constants, case, sequence, metadata (as a JSON object), samples and estimates, under
/// `tail` at `started_utc`; source from the run's `source` key, the actuator serial from
/// `ema_serial_number`, valid from its `valid` key (true when absent). The caller adds the raw
/// record (raw_log, raw_log_format) and may refine the source and status note.
[[nodiscard]] db::StoredRun to_stored_run(const Run& run, const std::string& tail, const std::string& started_utc,
                                          const std::optional<RunEstimates>& estimates);

/// Sets the session's verdict, its reason and one finding per line of the assessment.
void set_assessment(db::StoredTestSession& session, const Assessment& assessment);

}  // namespace emadiag
