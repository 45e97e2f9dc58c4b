// Schema version 5 -> 6 (schema/006_clustered_by_tail.sql): test_sessions and findings rebuilt as
// tables keyed by tail first. Every session, finding and id is kept, the hash chain still verifies,
// the store gives ids above every one used, and a migration that would lose a row changes nothing.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"
#include "older_version_file.hpp"
#include "support/db_test_files.hpp"
#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag::db {
namespace {

using ::testing::HasSubstr;
using ::testing::SizeIs;
using ::testing::ThrowsMessage;
using test::RawConnection;
using test::TempDbFile;

constexpr int kClusteredVersion = 6;
constexpr int kNewestVersion = 7;  // a migrated file goes on to the newest version

StoredTestSession session_at(const std::string& tail, const std::string& position, const std::string& serial, const std::string& utc,
                             double fdj_nm) {
    StoredTestSession s;
    s.tail_number = tail;
    s.position = position;
    s.position_ata = "27-30";
    s.actuator_serial = serial;
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.verdict = "SERVICEABLE";
    s.technician_name = "A. Mechanic";
    s.limits_json = R"({"FDJ_Nm":{"max":0.12}})";
    s.artifacts.push_back({"model", "models/case_A_dyn.json", sha256_hex("model bytes")});
    s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj_nm, 0.001, 0.12, "max", "WITHIN", ""});
    s.findings.push_back({"FSJ_Nm", "physics:brk", 0.12, 0.002, 0.2, "max", "WITHIN", ""});
    s.findings.push_back({"eta_O", "network:dyn", std::nullopt, std::nullopt, std::nullopt, "none", "NOT_IDENTIFIABLE", "no load"});
    return s;
}

const std::vector<std::string> kTails = {"F-WAAA", "F-WBBB", "F-WCCC"};

/// A newest-version file whose tails' sessions interleave as a fleet's do (time order, all tails),
/// with a run, a correction, an installation change and a session stored out of time order.
void fill(const std::string& path) {
    Database db(path);
    for (int day = 1; day <= 6; ++day) {
        std::vector<StoredTestSession> batch;
        for (const auto& tail : kTails) {
            const std::string utc = "2026-03-0" + std::to_string(day) + "T08:00:00Z";
            batch.push_back(session_at(tail, "LH-ELEV", day < 4 ? tail + "-SN-1" : tail + "-SN-2", utc, 0.08 + 0.001 * day));
        }
        (void)store_sessions(db, batch);
    }
    StoredTestSession with_run = session_at("F-WBBB", "LH-ELEV", "F-WBBB-SN-2", "2026-03-07T08:00:00Z", 0.09);
    with_run.runs.push_back(test::example_stored_run("dyn", "F-WBBB"));
    (void)store_session(db, with_run);
    StoredTestSession correction = session_at("F-WAAA", "LH-ELEV", "F-WAAA-SN-2", "2026-03-07T09:00:00Z", 0.085);
    correction.amends_session_id = 13;  // F-WAAA's session of day 5
    correction.correction_reason = "FDJ re-read from the log";
    (void)store_session(db, correction);
    // Stored last, dated before the others of its tail.
    (void)store_session(db, session_at("F-WCCC", "LH-ELEV", "F-WCCC-SN-1", "2026-02-01T08:00:00Z", 0.079));
}

std::vector<std::vector<StoredTestSession>> every_tail(Database& db) {
    std::vector<std::vector<StoredTestSession>> all;
    for (const auto& tail : kTails) all.push_back(list_test_sessions(db, tail));
    return all;
}

void expect_same(const std::vector<std::vector<StoredTestSession>>& a, const std::vector<std::vector<StoredTestSession>>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t t = 0; t < a.size(); ++t) {
        ASSERT_EQ(a[t].size(), b[t].size()) << kTails[t];
        for (std::size_t i = 0; i < a[t].size(); ++i) {
            const auto &x = a[t][i], &y = b[t][i];
            EXPECT_EQ(x.session_id, y.session_id);
            EXPECT_EQ(x.started_utc, y.started_utc);
            EXPECT_EQ(x.content_sha256, y.content_sha256);
            EXPECT_EQ(x.prev_sha256, y.prev_sha256);
            EXPECT_EQ(x.limits_json, y.limits_json);
            EXPECT_EQ(x.amends_session_id, y.amends_session_id);
            EXPECT_EQ(x.runs.size(), y.runs.size());
            EXPECT_EQ(x.artifacts.size(), y.artifacts.size());
            ASSERT_EQ(x.findings.size(), y.findings.size()) << "session " << x.session_id;
            for (std::size_t k = 0; k < x.findings.size(); ++k) {
                EXPECT_EQ(x.findings[k].parameter, y.findings[k].parameter);
                EXPECT_EQ(x.findings[k].estimator, y.findings[k].estimator);
                EXPECT_EQ(x.findings[k].value, y.findings[k].value);
                EXPECT_EQ(x.findings[k].note, y.findings[k].note);
            }
        }
    }
}

TEST(ClusterMigration, AVersion5FileKeepsEverySessionFindingAndIdAndItsChainVerifies) {
    const TempDbFile newest("_newest"), file;
    fill(newest.path());
    std::vector<std::vector<StoredTestSession>> before;
    {
        Database db(newest.path());
        before = every_tail(db);
    }
    test::write_older_version_copy(newest.path(), file.path(), 5);
    std::int64_t sessions = 0, findings = 0;
    {
        RawConnection v5(file.path());
        ASSERT_EQ(v5.query_int("PRAGMA user_version"), 5);
        ASSERT_EQ(v5.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'test_sessions' AND sql LIKE '%AUTOINCREMENT%'"), 1)
            << "the version-5 layout";
        sessions = v5.query_int("SELECT count(*) FROM test_sessions");
        findings = v5.query_int("SELECT count(*) FROM findings");
        ASSERT_EQ(sessions, 21);
        ASSERT_EQ(findings, 63);
    }
    {
        Database db(file.path());
        EXPECT_EQ(db.schema_version(), kNewestVersion);
        expect_same(every_tail(db), before);
        for (const auto& tail : kTails) {
            const auto check = verify_tail(db, tail);
            EXPECT_TRUE(check.ok()) << tail << ": " << ::testing::PrintToString(check.problems);
        }
        const StoredTestSession one = load_test_session(db, 13);
        EXPECT_EQ(one.tail_number, "F-WAAA");
        EXPECT_THAT(one.findings, SizeIs(3));
        EXPECT_THAT(list_sessions_of_serial(db, "F-WBBB-SN-2"), SizeIs(4));
        // The next session continues the ids; its findings carry its tail.
        const auto receipt = store_session(db, session_at("F-WBBB", "LH-ELEV", "F-WBBB-SN-2", "2026-03-08T08:00:00Z", 0.091));
        EXPECT_EQ(receipt.session_id, 22);
        EXPECT_TRUE(verify_tail(db, "F-WBBB").ok());
    }
    RawConnection v6(file.path());
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM test_sessions"), sessions + 1);
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM findings"), findings + 3);
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM findings f JOIN test_sessions s ON s.session_id = f.session_id "
                           "WHERE f.tail_number != s.tail_number"),
              0);
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM sqlite_schema WHERE name IN ('test_sessions', 'findings') AND sql LIKE '%WITHOUT ROWID%'"), 2);
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM sqlite_schema WHERE name IN ('test_sessions_v6', 'findings_v6', 'test_sessions_by_tail', "
                           "'sqlite_autoindex_findings_1')"),
              0)
        << "no second copy and no old index is left";
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM sqlite_schema WHERE type = 'trigger' AND tbl_name IN ('test_sessions', 'findings')"), 4)
        << "the append-only triggers are back";
    EXPECT_EQ(v6.query_int("SELECT count(*) FROM pragma_foreign_key_check"), 0);
}

TEST(ClusterMigration, AFileStoredByTheNewestCodeReadsAsItsVersion5CopyDoes) {
    // The same rows in both layouts give the same listings (tail and serial), row for row.
    const TempDbFile newest("_newest"), file;
    fill(newest.path());
    test::write_older_version_copy(newest.path(), file.path(), 5);
    Database a(newest.path()), b(file.path());
    expect_same(every_tail(a), every_tail(b));
    for (const char* serial : {"F-WAAA-SN-1", "F-WCCC-SN-1", "F-WBBB-SN-2"})
        expect_same({list_sessions_of_serial(a, serial)}, {list_sessions_of_serial(b, serial)});
}

TEST(ClusterMigration, AMigrationThatWouldLoseAFindingChangesNothing) {
    const TempDbFile newest("_newest"), file;
    fill(newest.path());
    test::write_older_version_copy(newest.path(), file.path(), 5);
    {
        // A finding whose session is missing (written outside the tool, foreign keys off).
        RawConnection raw(file.path());
        raw.exec("INSERT INTO findings(session_id, parameter, estimator, limit_kind, status) VALUES (99, 'FDJ_Nm', 'physics', 'none', 'WITHIN')");
    }
    EXPECT_THAT([&] { Database db(file.path()); },
                ThrowsMessage<DbError>(HasSubstr("migration to version 6 would keep 21 of 21 test sessions and 63 of 64 findings")));
    RawConnection raw(file.path());
    EXPECT_EQ(raw.query_int("PRAGMA user_version"), 5) << "rolled back";
    EXPECT_EQ(raw.query_int("SELECT count(*) FROM findings"), 64);
    EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'findings' AND sql LIKE '%WITHOUT ROWID%'"), 0);
}

TEST(ClusterMigration, ASessionIdIsNeverGivenTwiceEvenAfterTheLastSessionIsDeletedOutsideTheTool) {
    const TempDbFile file;
    {
        Database db(file.path());
        for (int day = 1; day <= 3; ++day)
            (void)store_session(db, session_at("F-WAAA", "LH-ELEV", "SN-1", "2026-03-0" + std::to_string(day) + "T08:00:00Z", 0.08));
    }
    {
        RawConnection raw(file.path());
        raw.exec("PRAGMA foreign_keys = OFF; DROP TRIGGER test_sessions_no_delete; DROP TRIGGER findings_no_delete;"
                 "DROP TRIGGER session_artifacts_no_delete;"
                 "DELETE FROM findings WHERE session_id = 3; DELETE FROM session_artifacts WHERE session_id = 3;"
                 "DELETE FROM test_sessions WHERE session_id = 3");
    }
    Database db(file.path());
    const auto receipt = store_session(db, session_at("F-WBBB", "LH-ELEV", "SN-2", "2026-03-04T08:00:00Z", 0.08));
    EXPECT_EQ(receipt.session_id, 4) << "id 3 stays the deleted session's (chain_heads still names it)";
    EXPECT_FALSE(verify_tail(db, "F-WAAA").ok());
}

TEST(ClusterMigration, TheSchemaRefusesASecondSessionWithAnIdInUse) {
    Database db(":memory:");
    const auto first = store_session(db, session_at("F-WAAA", "LH-ELEV", "SN-1", "2026-03-01T08:00:00Z", 0.08));
    EXPECT_THAT([&] {
        db.exec("INSERT INTO test_sessions(session_id, tail_number, phase, started_utc, verdict, prev_sha256, content_sha256) VALUES (" +
                std::to_string(first.session_id) + ", 'F-WAAA', 'pre-flight', '2026-03-02T08:00:00Z', 'NO_TEST', '', '" + std::string(64, 'a') +
                "')");
    }, ThrowsMessage<DbError>(HasSubstr("UNIQUE constraint failed: test_sessions.session_id")));
}

}  // namespace
}  // namespace emadiag::db
