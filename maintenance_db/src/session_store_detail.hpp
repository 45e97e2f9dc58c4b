#pragma once
// The parts of the session store that its files share (session_checks.cpp, session_listing.cpp,
// session_hash.cpp, session_summaries.cpp, session_store.cpp). Not installed.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <unordered_map>
#include <utility>

namespace emadiag::db::detail {

inline constexpr std::string_view kNoLimit = "none";

inline constexpr const char* kSessionColumns =
    "s.session_id, s.tail_number, s.actuator_serial, s.phase, s.started_utc, s.tool_version, s.verdict, s.verdict_note, s.limits_json, "
    "s.position, p.ata_reference, p.description, s.cycles, s.hours_h, s.operator_id, s.technician_name, s.technician_certificate, "
    "s.work_performed, s.source, s.limits_sha256, s.amends_session_id, s.correction_reason, s.prev_sha256, s.content_sha256 "
    "FROM test_sessions s LEFT JOIN positions p ON p.position = s.position";

// ---- session_checks.cpp ----
void invalid(const std::string& message);
[[nodiscard]] bool is_iso_date_time(const std::string& text);
/// Throws DbError naming the field (and run / finding index) unless the session can be stored.
void check_session(const StoredTestSession& s);

// ---- session_listing.cpp ----
[[nodiscard]] StoredTestSession read_session_row(const Statement& st);

/// The layout of the findings table: clustered by tail (schema version 6 on) or keyed by session
/// alone (versions 2 to 5: only the sealing of the version-3 migration reads it so).
enum class FindingsLayout { ByTail, BySession };
[[nodiscard]] std::vector<StoredFinding> load_findings(Database& db, std::int64_t session_id, FindingsLayout layout = FindingsLayout::ByTail);
[[nodiscard]] StoredTestSession load_session(Database& db, std::int64_t session_id, FindingsLayout layout);

// ---- session_hash.cpp ----

/// The content hash of `s` with its limits hash given (the store computes it without copying `s`).
[[nodiscard]] std::string content_sha256(const StoredTestSession& s, const std::string& limits_sha256, const std::string& prev_sha256);

// ---- session_summaries.cpp ----

/// What one transaction of stores (one session, or a batch) has read and changed of the small
/// per-tail tables, kept in memory and written once before COMMIT (flush): the summary rows
/// (series_stats, position_status), the chain heads, the tails and positions known to exist. Each
/// row is read from the database the first time the transaction touches it and then updated here
/// by the same rules, in the same order, as one statement per session would: the result is the same
/// as storing the sessions one by one. Dropped unflushed when the transaction rolls back.
struct Batch {
    struct Head {
        std::int64_t session_id = 0, added = 0;
        std::string sha;
    };
    /// (tail, position, serial) -> parameter -> its series_stats row (none: not stored yet). Two
    /// levels: a session's parameters share the first key, looked up once per session.
    std::map<std::tuple<std::string, std::string, std::string>, std::map<std::string, std::optional<SeriesStats>>> series;
    std::map<std::pair<std::string, std::string>, std::optional<PositionStatus>> positions;
    std::unordered_map<std::string, Head> heads;
    std::unordered_map<std::string, std::string> head_before;  ///< tail -> its stored head ("" none)
    std::unordered_map<std::string, bool> tails_known;
    std::unordered_map<std::string, std::string> position_ata;  ///< position -> its ATA reference, checked or registered
    /// The last limits text hashed and its SHA-256 (a fleet's sessions share their limits).
    std::string limits_json, limits_sha256;
    /// The id the next stored session gets (0: not read yet in this transaction).
    std::int64_t next_session_id = 0;
    /// Check each tail's chain head before appending to it (off only while the migration seals).
    bool check_heads = true;
    /// The insert statements, fetched from the connection's cache once per transaction.
    Statement *insert_aircraft = nullptr, *insert_session = nullptr, *insert_finding = nullptr, *insert_artifact = nullptr;
};

[[nodiscard]] std::optional<PositionStatus>& position_row(Database& db, Batch& b, const std::string& tail, const std::string& position);

/// Adds (sign +1) or removes (sign -1, for a session a correction amends) a session's measurements
/// in series_stats, and its place in position_status (docs/record-format.md, "Summary tables").
void add_to_summaries(Database& db, Batch& b, const StoredTestSession& s, std::int64_t session_id, int sign);
/// Writes what the batch changed, inside its transaction.
void flush(Database& db, Batch& b);

// ---- session_store.cpp ----
void bind_optional(Statement& st, int index, const std::optional<double>& v);
void bind_optional(Statement& st, int index, const std::optional<std::int64_t>& v);

}  // namespace emadiag::db::detail
