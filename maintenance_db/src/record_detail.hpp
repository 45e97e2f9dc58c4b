#pragma once
// Parts of the record (session_store.cpp) the migration code in database.cpp calls. Not installed.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_store.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag::db::detail {

/// Schema version 3: computes the hash chain of every session stored before it (per tail, in
/// session_id order) and fills the summary tables series_stats and position_status from them.
/// Called inside the migration's transaction, before the append-only triggers exist.
void seal_sessions_before_v3(Database& db);

/// The columns of series_stats in the order SeriesStats lists them.
inline constexpr const char* kSeriesStatsColumns =
    "tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, s_wy, s_wty, s_wyy, n_cycles, "
    "first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, last_session_id, last_value, last_std_error, limit_kind, limit_value";

/// The summary row of one series, if stored (a statement cached on the connection).
[[nodiscard]] std::optional<SeriesStats> find_series_stats(Database& db, const std::string& tail_number, const std::string& position,
                                                           const std::string& actuator_serial, const std::string& parameter);

/// The position_status row of a tail and position, if stored (a statement cached on the connection).
[[nodiscard]] std::optional<PositionStatus> find_position_status(Database& db, const std::string& tail_number, const std::string& position);

/// Schema version 7: chains each tail's discovery findings stored before it (finding_id order) and
/// records the head and count in chain_heads (docs/record-format.md, "Discovery findings").
void seal_discovery_findings_before_v7(Database& db);

/// After a committed store: appends one line per tail (its session count and head, its discovery
/// findings' count and head) to db.anchor_path(), fsynced. Nothing when the path is empty. Throws
/// DbError naming the file when it cannot be written (the store itself is committed).
void append_anchor(Database& db, const std::vector<std::string>& tails);

/// Maps a failed SQLite call to a DbError of the right kind, naming the database and the cause.
[[noreturn]] void throw_sqlite_error(Database& db, int rc, const std::string& what);

}  // namespace emadiag::db::detail
