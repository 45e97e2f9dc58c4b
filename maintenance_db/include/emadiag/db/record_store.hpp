#pragma once
// The maintenance record of a fleet beyond the sessions themselves: positions, installation
// changes, discovery findings, the summary tables the fleet view reads, and the check of each
// tail's hash chain (docs/record-format.md). Sessions are stored by session_store.hpp.
#include "emadiag/db/database.hpp"
#include "emadiag/db/session_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::db {

inline constexpr std::size_t kMaxPositionLength = 16;

/// What is wrong with a position name (1 to 16 of A-Z, 0-9, '-'), or nothing.
[[nodiscard]] std::optional<std::string> position_problem(const std::string& position);
/// What is wrong with an ATA reference (chapter 27: "27-NN..."), or nothing.
[[nodiscard]] std::optional<std::string> ata_reference_problem(const std::string& ata);

struct StoredPosition {
    std::string position, ata_reference, description;
};
/// The positions the database has seen, sorted by name.
[[nodiscard]] std::vector<StoredPosition> list_positions(Database& db);

/// One session's measurement of a parameter: the inverse-variance mean of its physics findings
/// with a value and a positive standard error, y = sum(w y)/sum(w), se = 1/sqrt(sum(w)), w = 1/se^2;
/// the limit is the parameter's limit in the findings. The summary tables and the trends
/// (prognostics/trend_series) use this same rule.
struct SessionMeasurement {
    std::string parameter;
    double value = 0, std_error = 0;
    std::string limit_kind = "none";
    std::optional<double> limit_value;
};
[[nodiscard]] std::vector<SessionMeasurement> session_measurements(const std::vector<StoredFinding>& findings);

/// Installation changes of a tail, oldest first.
[[nodiscard]] std::vector<StoredInstallation> list_installations(Database& db, const std::string& tail_number);
/// Every installation of one serial on any tail, oldest first (where the actuator has been).
[[nodiscard]] std::vector<StoredInstallation> list_installations_of_serial(Database& db, const std::string& actuator_serial);

/// A finding of `emadiag discover`: an effect the model lacks, traced in a run of this actuator.
struct StoredDiscoveryFinding {
    std::int64_t finding_id = 0;  ///< set by the store / load
    std::string tail_number;
    std::optional<std::string> position;
    std::string position_ata, position_description;  ///< to register a position first used here
    std::string actuator_serial;
    std::string found_utc;   ///< ISO 8601 UTC
    std::string summary;     ///< one line: the effect, its coefficient, the error before and after
    std::string model_json = "{}";  ///< the augmented model
    std::string status = "open";    ///< "open" or "closed"
    std::optional<std::int64_t> amends_finding_id;  ///< e.g. the entry a "closed" finding closes
    std::string tool_version;
    std::string content_sha256;  ///< set by the store
};
/// Stores one discovery finding in one transaction (append-only); returns its id. DbError names the
/// field on invalid input (tail, position, time, empty summary, status, an amended finding of
/// another tail or already amended).
[[nodiscard]] std::int64_t store_discovery_finding(Database& db, const StoredDiscoveryFinding& finding);
/// The discovery findings of a tail, oldest first; with open_only, those not amended by a later entry
/// and with status "open".
[[nodiscard]] std::vector<StoredDiscoveryFinding> list_discovery_findings(Database& db, const std::string& tail_number,
                                                                          bool open_only = false);

/// The summary of one measurement series (tail, position, serial, parameter), kept up to date by
/// every store: the weighted sums of a linear least-squares fit against days and against flight
/// cycles since the series' first session (schema/003_fleet_record.sql, series_stats).
struct SeriesStats {
    std::string tail_number, position, actuator_serial, parameter;
    std::int64_t n = 0;
    double first_days = 0, last_days = 0;
    double s_w = 0, s_wt = 0, s_wtt = 0, s_wy = 0, s_wty = 0, s_wyy = 0;
    std::int64_t n_cycles = 0;
    std::optional<double> first_cycles, last_cycles;
    double c_w = 0, c_wt = 0, c_wtt = 0, c_wy = 0, c_wty = 0, c_wyy = 0;
    std::int64_t last_session_id = 0;
    double last_value = 0, last_std_error = 0;
    std::string limit_kind = "none";
    std::optional<double> limit_value;
};
/// Per tail and position: the serial installed now (that of the newest session) and the last session.
struct PositionStatus {
    std::string tail_number, position, actuator_serial;
    std::int64_t sessions = 0, last_session_id = 0;
    std::string last_utc, last_verdict;
    std::optional<std::int64_t> last_cycles;
};
[[nodiscard]] std::vector<PositionStatus> list_position_status(Database& db);
/// Every series, or those of one tail when tail_number is given.
[[nodiscard]] std::vector<SeriesStats> list_series_stats(Database& db, const std::optional<std::string>& tail_number = std::nullopt);

/// The result of checking a tail's hash chain.
struct ChainCheck {
    std::string tail_number;
    std::int64_t sessions_checked = 0;
    std::string head_sha256;            ///< the last session's content_sha256 (to note in the MRO system)
    std::int64_t discovery_findings_checked = 0;
    std::string discovery_head_sha256;  ///< the head of the tail's discovery findings' chain ("" none)
    std::int64_t installations_checked = 0;
    std::string anchor_path;            ///< the anchor file compared ("" none)
    std::int64_t anchor_lines_checked = 0;
    std::vector<std::string> problems;  ///< empty: every session is as stored by the tool
    std::vector<std::string> notes;     ///< not problems: e.g. no anchor file to compare with
    [[nodiscard]] bool ok() const { return problems.empty(); }
};
/// Recomputes every session's content hash of the tail (with its runs, samples, raw logs, estimates,
/// findings and artifacts) in session_id order and checks each against the stored hash, each link
/// to the previous session and the chain head (which shows a deleted last session); every discovery
/// finding's hash and their chain; the installations, which are derived from the sessions (each is
/// recomputed from them); and the anchor file db.anchor_path() (a deleted last session with a
/// rewritten chain head shows there: docs/record-format.md, "Anchoring the head"). A change made
/// outside the tool shows as a problem naming the session, finding or installation.
/// Reads one consistent snapshot (a read transaction unless the caller has one open).
[[nodiscard]] ChainCheck verify_tail(Database& db, const std::string& tail_number);
/// As above; without the anchor file when compare_anchor is false (what a store checks before it
/// appends: the database's own chain. A database restored from a backup is older than its anchor:
/// verify says so, and stores go on).
[[nodiscard]] ChainCheck verify_tail(Database& db, const std::string& tail_number, bool compare_anchor);

/// The chain link of a discovery finding: SHA-256 over "emadiag-discovery-chain-v1\n", the previous
/// link ("" for the first finding of the tail) and the finding's content_sha256.
[[nodiscard]] std::string discovery_chain_link(const std::string& prev_link, const std::string& content_sha256);

}  // namespace emadiag::db
