#pragma once
// Parts of the record (test_session_store.cpp) the migration code in database.cpp calls. Not installed.
#include "emadiag/db/database.hpp"

namespace emadiag::db::detail {

/// Schema version 3: computes the hash chain of every session stored before it (per tail, in
/// session_id order) and fills the summary tables series_stats and position_status from them.
/// Called inside the migration's transaction, before the append-only triggers exist.
void seal_sessions_before_v3(Database& db);

/// Maps a failed SQLite call to a DbError of the right kind, naming the database and the cause.
[[noreturn]] void throw_sqlite_error(Database& db, int rc, const std::string& what);

}  // namespace emadiag::db::detail
