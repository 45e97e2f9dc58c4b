#pragma once
// Test support: a run stored on its own, outside any test session, as the tool stored runs before it
// had sessions (schema version 1). The runs table keeps such rows (session_id NULL) and load_run and
// list_runs read them back; the tool itself no longer writes one (a run outside a session is outside
// the tail's hash chain), so the tests write it with the store's own parts: the same checks
// (check_run) and the same insert (insert_run) as a session's runs, in one transaction.
#include "../../maintenance_db/src/run_store_detail.hpp"

#include <cstdint>
#include <optional>

namespace emadiag::test {

inline std::int64_t store_lone_run(db::Database& db, const db::StoredRun& run) {
    db::detail::check_run(run, "");
    db::Transaction tx(db);
    const std::int64_t id = db::detail::insert_run(db, run, std::nullopt);
    tx.commit();
    return id;
}

}  // namespace emadiag::test
