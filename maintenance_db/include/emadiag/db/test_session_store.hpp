#pragma once
// Test sessions: one `emadiag test-run` on the ramp, its runs (one per test sequence), the
// per-parameter findings and the verdict, stored under the aircraft's tail number. A session is
// stored in one transaction with all its runs: it is either all there or not there at all.
#include "emadiag/db/database.hpp"
#include "emadiag/db/run_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::db {

/// One verdict line: a parameter as one estimator found it, against its limit. value, std_error and
/// limit_value are in the unit the parameter's name gives (FDJ_Nm: N m; eta_O: dimensionless).
struct StoredFinding {
    std::string parameter;  ///< FDJ_Nm, FSJ_Nm, eta_O, eta_A
    std::string estimator;  ///< "physics", "network"
    std::optional<double> value;        ///< empty: not identifiable or not estimated
    std::optional<double> std_error;    ///< empty: no uncertainty; when present finite and >= 0
    std::optional<double> limit_value;  ///< present exactly when limit_kind is "max" or "min"
    std::string limit_kind = "none";    ///< "max", "min" or "none"
    std::string status;                 ///< e.g. WITHIN, BEYOND, STRADDLES, NOT_IDENTIFIABLE
    std::string note;
};

struct StoredTestSession {
    std::int64_t session_id = 0;  ///< set by store_test_session / load
    std::string tail_number, actuator_serial;
    std::string phase;        ///< "pre-flight" or "post-flight"
    std::string started_utc;  ///< ISO 8601, "YYYY-MM-DDThh:mm:ss..." (sessions are listed in its order)
    std::string tool_version;
    std::string verdict;  ///< SERVICEABLE, UNSERVICEABLE, INCONCLUSIVE or NO_TEST
    std::string verdict_note;
    std::string limits_json = "{}";
    std::vector<StoredRun> runs;  ///< each stored with this session's id, loaded in the order stored
    std::vector<StoredFinding> findings;  ///< loaded ordered by parameter, then estimator
};

/// Stores the session, all its runs (samples, raw logs, estimates) and findings in ONE transaction;
/// returns the session id. On any invalid field nothing at all is written; DbError names the field
/// (and run / finding index). Every run's tail_number must equal the session's.
[[nodiscard]] std::int64_t store_test_session(Database& db, const StoredTestSession& session);

/// One session with its runs (full, as load_run gives them) and findings. DbError when absent.
[[nodiscard]] StoredTestSession load_test_session(Database& db, std::int64_t session_id);

/// The sessions of one aircraft, oldest first, with findings and with runs WITHOUT samples/raw logs
/// (their estimates included).
[[nodiscard]] std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number);

}  // namespace emadiag::db
