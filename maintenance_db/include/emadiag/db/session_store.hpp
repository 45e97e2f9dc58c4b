#pragma once
// Test sessions: one `emadiag test-run` on the ramp, its runs (one per test sequence), the
// per-parameter findings and the verdict, stored under the aircraft's tail number. A session is
// stored in one transaction with all its runs: it is either all there or not there at all.
#include "emadiag/db/database.hpp"
#include "emadiag/db/run_store.hpp"

#include <cstdint>
#include <memory>
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

/// A file or setting a session used, with its SHA-256 (model files, the limits, the position list).
struct StoredArtifact {
    std::string role;    ///< "model", "limits" or "positions"
    std::string name;    ///< the file as given, or "built-in"
    std::string sha256;  ///< 64 lowercase hex digits
};

struct StoredTestSession {
    std::int64_t session_id = 0;  ///< set by store_test_session / load
    std::string tail_number, actuator_serial;
    /// The position of the actuator (e.g. "LH-ELEV"); empty: not given. Registered in table positions
    /// with position_ata and position_description the first time it is used.
    std::optional<std::string> position;
    std::string position_ata;          ///< ATA chapter 27 reference, e.g. "27-30" (needed with a position)
    std::string position_description;  ///< loaded back from table positions
    std::string phase;        ///< "pre-flight", "post-flight" (ground tests), "in-flight" or "load-rig" (imports)
    std::optional<std::int64_t> cycles;  ///< aircraft flight cycles from the technical log
    std::optional<double> hours_h;       ///< aircraft flight hours from the technical log
    std::string operator_id;             ///< the aircraft operator
    std::string technician_name, technician_certificate;  ///< the person who did the work and their certificate number
    std::string work_performed;          ///< what was done, in words
    std::string source;                  ///< the command: "test-run", "import", "history-sim"
    std::vector<StoredArtifact> artifacts;  ///< model files and the like with their hashes (limits: added by the store)
    /// A correction: the earlier session (same tail) this entry amends, and why. Each session is amended at most once.
    std::optional<std::int64_t> amends_session_id;
    std::string correction_reason;
    std::string limits_sha256;   ///< set by the store: SHA-256 of limits_json
    std::string prev_sha256;     ///< set by the store: the tail's previous session's content_sha256 ("" for the first)
    std::string content_sha256;  ///< set by the store: docs/record-format.md
    std::string started_utc;  ///< ISO 8601, "YYYY-MM-DDThh:mm:ss..." (sessions are listed in its order)
    std::string tool_version;
    std::string verdict;  ///< SERVICEABLE, UNSERVICEABLE, INCONCLUSIVE or NO_TEST
    std::string verdict_note;
    std::string limits_json = "{}";
    std::vector<StoredRun> runs;  ///< each stored with this session's id, loaded in the order stored
    std::vector<StoredFinding> findings;  ///< loaded ordered by parameter, then estimator
};

/// An installation change: a position of a tail shows a new actuator serial.
struct StoredInstallation {
    std::int64_t installation_id = 0;
    std::string tail_number, position;
    std::string from_serial;  ///< "" for the first serial seen at the position
    std::string to_serial;
    std::string detected_utc;  ///< the started_utc of the session that showed to_serial
    std::optional<std::int64_t> cycles;
    std::optional<double> hours_h;
    std::int64_t session_id = 0;
};

/// What storing a session did.
struct SessionReceipt {
    std::int64_t session_id = 0;
    std::string content_sha256;
    std::optional<StoredInstallation> installation;  ///< recorded when the position showed a new serial
};

/// Stores the session like store_test_session and says what it did. The tail's whole record is
/// verified first (verify_tail): nothing is appended to a broken chain (DbError, kind BrokenChain,
/// naming the tail and the first problem). After the commit the tail's head is appended to the
/// database's anchor file (Database::anchor_path).
[[nodiscard]] SessionReceipt store_session(Database& db, const StoredTestSession& session);

/// Sessions stored one at a time into ONE transaction, all of them or none (emadiag history-sim: a
/// history is whole or absent, even when a session fails to simulate or the process is killed).
/// Each tail's whole record is verified (verify_tail) before the first session is appended to it:
/// DbError (kind BrokenChain) names the tail and the first problem, and nothing is stored. commit()
/// writes the summaries, commits and appends each tail's head to the anchor file; a batch destroyed
/// without commit() rolls back (never throws).
class SessionBatch {
public:
    explicit SessionBatch(Database& db);
    ~SessionBatch();
    SessionBatch(const SessionBatch&) = delete;
    SessionBatch& operator=(const SessionBatch&) = delete;
    /// Checks and writes one session inside the batch's transaction (begun by the first add).
    SessionReceipt add(const StoredTestSession& session);
    void commit();

private:
    struct State;
    std::unique_ptr<State> state_;
};

/// Stores many sessions in ONE transaction (bulk import, e.g. from another maintenance system):
/// all of them or none. Each is checked first; DbError names the batch index. Each tail's chain
/// head is checked before appending to it (its newest session recomputed), not its whole chain.
[[nodiscard]] std::vector<SessionReceipt> store_sessions(Database& db, const std::vector<StoredTestSession>& sessions);

/// Stores the session, all its runs (samples, raw logs, estimates) and findings in ONE transaction;
/// returns the session id. On any invalid field nothing at all is written; DbError names the field
/// (and run / finding index). Every run's tail_number must equal the session's.
[[nodiscard]] std::int64_t store_test_session(Database& db, const StoredTestSession& session);

/// One session with its runs (full, as load_run gives them) and findings. DbError when absent.
[[nodiscard]] StoredTestSession load_test_session(Database& db, std::int64_t session_id);

/// The sessions of one aircraft, oldest first, with findings and with runs WITHOUT samples/raw logs
/// (their estimates included).
[[nodiscard]] std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number);

/// The sessions of one actuator serial on any tail, oldest first, as list_test_sessions gives them.
[[nodiscard]] std::vector<StoredTestSession> list_sessions_of_serial(Database& db, const std::string& actuator_serial);

/// What a listing loads besides each session's row and findings (a report of a tail with years of
/// sessions needs neither artifacts nor runs: two queries fewer).
struct SessionListParts {
    bool artifacts = true;
    bool runs = true;  ///< without samples or raw logs, with their estimates
    /// limits_json, limits_sha256 and prev_sha256 (the reports show none of them; a record source
    /// may leave them empty when false).
    bool limits_and_links = true;
};
[[nodiscard]] std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number, const SessionListParts& parts);
[[nodiscard]] std::vector<StoredTestSession> list_sessions_of_serial(Database& db, const std::string& actuator_serial,
                                                                     const SessionListParts& parts);

/// The SHA-256 chaining `session` (its stored content, docs/record-format.md) to `prev_sha256`.
/// Findings, estimates and artifacts are taken in their canonical order, so the value does not
/// depend on the order they were given in.
[[nodiscard]] std::string session_content_sha256(const StoredTestSession& session, const std::string& prev_sha256);

}  // namespace emadiag::db
