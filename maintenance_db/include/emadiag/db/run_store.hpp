#pragma once
// Runs, their raw logs, samples and estimates, stored under the aircraft's tail number. A run is
// stored with its test session (session_store.hpp), in the session's one transaction: either all
// there or not there at all.
#include "emadiag/db/database.hpp"
#include "emadiag/record/run_sample.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::db {

/// A stored sample is the run's sample (emadiag/record/run_sample.hpp): one shape, no copying field by field.
using StoredSample = RunSample;

struct StoredEstimate {
    std::string estimator;  ///< "physics", "network"
    std::string parameter;  ///< FDJ_Nm, FSJ_Nm, eta_O, eta_A
    std::optional<double> value;
    double std_error = 0;
    bool identifiable = true;
    std::string method;
    std::string note;
};

struct StoredRun {
    std::int64_t run_id = 0;  ///< set by the store / load_run
    std::string tail_number;
    std::string actuator_serial;
    std::string started_utc;  ///< ISO 8601
    std::string source;
    std::string load_case;
    std::string sequence;
    double k_t_nm_per_a = 0, j_kgm2 = 0, tau = 0, sample_period_s = 0;
    bool valid = true;
    std::string status_note;
    std::string meta_json = "{}";
    std::vector<StoredSample> samples;
    std::string raw_log_format;  ///< "candump" or "csv"
    std::string raw_log;         ///< the bytes as received, kept before anything is computed
    std::vector<StoredEstimate> estimates;
    /// The test session the run belongs to; set by load_run / list_runs, empty for a run stored on its
    /// own (stored before schema version 2 brought sessions). Ignored on input, like run_id: store_test_session
    /// writes the new session's id.
    std::optional<std::int64_t> session_id;
};

/// Checks a tail number: 1 to 16 characters of A-Z, 0-9 and '-'. Throws DbError naming it.
void check_tail_number(const std::string& tail_number);

/// Loads one run with everything stored for it. Throws DbError when there is no such run.
[[nodiscard]] StoredRun load_run(Database& db, std::int64_t run_id);

/// The runs of one aircraft (on their own or in a test session), oldest first, without samples, raw
/// logs or estimates.
[[nodiscard]] std::vector<StoredRun> list_runs(Database& db, const std::string& tail_number);

}  // namespace emadiag::db
