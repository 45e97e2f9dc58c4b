#pragma once
// A station file as an older emadiag left it: built from the migration texts themselves
// (schema/001 .. schema/NNN, applied by a bare connection), holding the rows of a file of the newest
// version (copied table by table in session order). The migration from it is the one a real file of
// that version takes.
#include "support/db_test_files.hpp"

#include <string>

namespace emadiag::test {

/// The migration texts in order (schema/00N_*.sql).
inline const char* const kSchemaFiles[] = {"001_initial.sql", "002_test_sessions.sql", "003_fleet_record.sql", "004_append_only.sql",
                                           "005_sync.sql", "006_clustered_by_tail.sql"};

/// Writes at `path` a file of schema `version` (4, 5 or 6) holding what `newest` holds.
inline void write_older_version_copy(const std::string& newest, const std::string& path, int version) {
    RawConnection old(path);
    old.exec("PRAGMA foreign_keys = OFF");
    for (int v = 1; v <= version; ++v) old.exec(read_text_file(std::string(EMADIAG_SOURCE_DIR "/maintenance_db/schema/") + kSchemaFiles[v - 1]));
    old.exec("PRAGMA user_version = " + std::to_string(version));
    old.exec("ATTACH DATABASE '" + newest + "' AS n");
    const std::string session_columns =
        "session_id, tail_number, position, actuator_serial, phase, started_utc, cycles, hours_h, operator_id, technician_name, "
        "technician_certificate, work_performed, source, tool_version, verdict, verdict_note, limits_json, limits_sha256, amends_session_id, "
        "correction_reason, prev_sha256, content_sha256";
    const std::string finding_columns = std::string(version >= 6 ? "tail_number, " : "") +
                                        "session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note";
    old.exec("BEGIN");
    for (const char* table : {"aircraft", "positions", "runs", "samples", "raw_logs", "estimates"})
        old.exec(std::string("INSERT INTO main.") + table + " SELECT * FROM n." + table);
    // In the order they were stored, as the older code wrote them (rowid order = session_id).
    old.exec("INSERT INTO main.test_sessions(" + session_columns + ") SELECT " + session_columns + " FROM n.test_sessions ORDER BY session_id");
    old.exec("INSERT INTO main.findings(" + finding_columns + ") SELECT " + finding_columns + " FROM n.findings ORDER BY session_id, parameter, estimator");
    for (const char* table : {"session_artifacts", "installations", "discovery_findings", "series_stats", "position_status"})
        old.exec(std::string("INSERT INTO main.") + table + " SELECT * FROM n." + table);
    // The session chain's heads (version 7 adds the discovery findings' head to each row, and a row
    // for a tail that has discovery findings only).
    old.exec("INSERT INTO main.chain_heads(tail_number, session_id, sessions, content_sha256) "
             "SELECT tail_number, session_id, sessions, content_sha256 FROM n.chain_heads WHERE sessions > 0");
    if (version >= 5) {
        old.exec("DELETE FROM main.station_identity; INSERT INTO main.station_identity SELECT * FROM n.station_identity");
        for (const char* table : {"synced_sessions", "synced_discovery_findings"})
            old.exec(std::string("INSERT INTO main.") + table + " SELECT * FROM n." + table);
    }
    old.exec("COMMIT");
    old.exec("DETACH DATABASE n");
}

}  // namespace emadiag::test
