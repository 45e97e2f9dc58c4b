#pragma once
// The parts of run_store.cpp that session_store.cpp reuses: checking a run, writing it inside
// the caller's transaction (SQLite has no nested BEGIN) and reading runs back. Not installed.
#include "emadiag/db/database.hpp"
#include "emadiag/db/run_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::db::detail {

/// What is wrong with a tail number, or nothing when it is valid (check_tail_number throws this).
[[nodiscard]] std::optional<std::string> tail_number_problem(const std::string& tail_number);

/// Throws DbError naming the field, its value and the sample index when the run cannot be stored.
/// `context` (e.g. "test session run 1: ") starts every message.
void check_run(const StoredRun& run, const std::string& context);

/// Writes a run checked by check_run with its samples, raw log and estimates under `session_id`
/// (NULL when empty). Must be called inside the caller's open Transaction; returns the run id.
[[nodiscard]] std::int64_t insert_run(Database& db, const StoredRun& run, std::optional<std::int64_t> session_id);

/// The runs of one test session in the order they were stored, with their estimates but without
/// samples or raw logs.
[[nodiscard]] std::vector<StoredRun> session_runs(Database& db, std::int64_t session_id);

/// The runs of the test sessions matching `where` (a condition on test_sessions aliased s, with one
/// bound text `value`), in run_id order, with their estimates but without samples or raw logs.
[[nodiscard]] std::vector<StoredRun> runs_where(Database& db, const std::string& where, const std::string& value);

}  // namespace emadiag::db::detail
