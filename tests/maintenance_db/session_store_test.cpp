// Test sessions in the maintenance database against :memory: and temporary files: round trips,
// one transaction for a whole session (a bad field anywhere writes nothing), the schema's CHECKs,
// and the upgrade of a version-1 file in place.
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "support/db_test_files.hpp"
#include "support/lone_run.hpp"
#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace emadiag::db {
namespace {

using ::testing::Each;
using ::testing::HasSubstr;
using ::testing::Pair;
using ::testing::SizeIs;
using ::testing::ThrowsMessage;

constexpr int kNewestSchemaVersion = 7;  // schema/007_chain_coverage.sql
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

StoredRun example_run(const std::string& sequence, const std::string& tail = "F-WEMA") { return test::example_stored_run(sequence, tail); }

/// A post-flight session with two runs and four findings, some without value, error or limit.
/// The findings are deliberately not in the order (parameter, estimator) they load back in.
StoredTestSession example_session(const std::string& started_utc = "2026-11-22T20:00:00Z", const std::string& tail = "F-WEMA") {
    StoredTestSession s;
    s.tail_number = tail;
    s.actuator_serial = "SN-0042";
    s.phase = "post-flight";
    s.started_utc = started_utc;
    s.tool_version = "emadiag 0.1.0";
    s.verdict = "INCONCLUSIVE";
    s.verdict_note = "eta_O not identifiable under constant load";
    s.limits_json = R"({"FDJ_Nm":{"max":0.12},"FSJ_Nm":{"max":0.2}})";
    s.runs = {example_run("dyn", tail), example_run("static", tail)};
    s.runs[1].started_utc = "2026-11-22T20:01:30Z";
    s.runs[1].valid = false;
    s.runs[1].status_note = "frame loss 0.3 % above the limit";
    s.findings.push_back({"FSJ_Nm", "physics", 0.151, 0.002, 0.2, "max", "WITHIN", ""});
    s.findings.push_back({"FDJ_Nm", "physics", 0.081, 0.0004, 0.12, "max", "WITHIN", "margin 0.039 N m"});
    s.findings.push_back({"eta_O", "physics", std::nullopt, std::nullopt, std::nullopt, "none", "NOT_IDENTIFIABLE",
                          "constant load"});
    s.findings.push_back({"FDJ_Nm", "network", 0.118, std::nullopt, 0.12, "max", "STRADDLES", "no uncertainty from the network"});
    return s;
}

std::string describe(const std::optional<double>& v) {
    if (!v) return "NULL";
    std::ostringstream out;
    out << std::setprecision(17) << *v;
    return out.str();
}

std::string describe(const StoredFinding& f) {
    return f.parameter + "/" + f.estimator + " value=" + describe(f.value) + " std_error=" + describe(f.std_error) +
           " limit=" + f.limit_kind + ":" + describe(f.limit_value) + " status=" + f.status + " note='" + f.note + "'";
}

/// Compares findings field by field, exactly (doubles round-trip through SQLite unchanged), and
/// prints both sides of every difference.
::testing::AssertionResult same_findings(const std::vector<StoredFinding>& expected, const std::vector<StoredFinding>& actual) {
    if (expected.size() != actual.size()) {
        return ::testing::AssertionFailure() << "expected " << expected.size() << " findings, got " << actual.size();
    }
    auto result = ::testing::AssertionSuccess();
    bool same = true;
    for (std::size_t i = 0; i < expected.size(); ++i) {
        if (describe(expected[i]) != describe(actual[i])) {
            if (same) result = ::testing::AssertionFailure();
            same = false;
            result << "\nfinding " << i << ": expected " << describe(expected[i]) << "\n           got      " << describe(actual[i]);
        }
    }
    return result;
}

std::vector<StoredFinding> sorted_as_loaded(std::vector<StoredFinding> findings) {
    std::sort(findings.begin(), findings.end(),
              [](const auto& a, const auto& b) { return std::tie(a.parameter, a.estimator) < std::tie(b.parameter, b.estimator); });
    return findings;
}

/// Rows in every table of the database (sqlite_sequence included), by table name.
std::map<std::string, std::int64_t> row_counts(Database& db) {
    std::vector<std::string> tables;
    Statement names(db, "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%' ORDER BY name");
    while (names.step()) tables.push_back(names.column_text(0));
    // station_identity holds the station's UUID from the moment the file is made (005_sync.sql): not session data.
    std::erase(tables, std::string("station_identity"));
    std::map<std::string, std::int64_t> counts;
    for (const auto& t : tables) {
        Statement count(db, "SELECT count(*) FROM \"" + t + "\"");
        count.step();
        counts[t] = count.column_int(0);
    }
    return counts;
}

using test::RawConnection;
using test::read_text_file;
using test::TempDbFile;

TEST(TestSessionStore, StoreThenLoadGivesBackEverything) {
    Database db(":memory:");
    EXPECT_EQ(db.schema_version(), kNewestSchemaVersion);
    const StoredTestSession in = example_session();
    const auto id = store_test_session(db, in);
    EXPECT_GT(id, 0);

    const StoredTestSession out = load_test_session(db, id);
    EXPECT_EQ(out.session_id, id);
    EXPECT_EQ(out.tail_number, in.tail_number);
    EXPECT_EQ(out.actuator_serial, in.actuator_serial);
    EXPECT_EQ(out.phase, in.phase);
    EXPECT_EQ(out.started_utc, in.started_utc);
    EXPECT_EQ(out.tool_version, in.tool_version);
    EXPECT_EQ(out.verdict, in.verdict);
    EXPECT_EQ(out.verdict_note, in.verdict_note);
    EXPECT_EQ(out.limits_json, in.limits_json);

    ASSERT_THAT(out.runs, SizeIs(2));
    for (std::size_t i = 0; i < 2; ++i) {
        SCOPED_TRACE("run " + std::to_string(i));
        const StoredRun& r = out.runs[i];
        EXPECT_EQ(r.session_id, std::optional<std::int64_t>(id));
        EXPECT_EQ(r.sequence, in.runs[i].sequence) << "runs come back in the order they were stored";
        EXPECT_EQ(r.started_utc, in.runs[i].started_utc);
        EXPECT_EQ(r.valid, in.runs[i].valid);
        EXPECT_EQ(r.status_note, in.runs[i].status_note);
        ASSERT_THAT(r.samples, SizeIs(in.runs[i].samples.size())) << "a loaded session's runs are full";
        EXPECT_EQ(r.samples[7].speed_rad_s, in.runs[i].samples[7].speed_rad_s);
        EXPECT_EQ(r.raw_log, in.runs[i].raw_log) << "raw logs are kept byte for byte";
        ASSERT_THAT(r.estimates, SizeIs(2));
        EXPECT_FALSE(r.estimates[1].value.has_value());
    }
    EXPECT_NE(out.runs[0].run_id, out.runs[1].run_id);
    EXPECT_EQ(load_run(db, out.runs[1].run_id).session_id, std::optional<std::int64_t>(id));

    EXPECT_TRUE(same_findings(sorted_as_loaded(in.findings), out.findings));
    const auto counts = row_counts(db);
    EXPECT_EQ(counts.at("test_sessions"), 1);
    EXPECT_EQ(counts.at("runs"), 2);
    EXPECT_EQ(counts.at("samples"), 20);
    EXPECT_EQ(counts.at("raw_logs"), 2);
    EXPECT_EQ(counts.at("findings"), 4);
}

TEST(TestSessionStore, ListsSessionsOldestFirstWithFindingsAndRunsWithoutSamples) {
    Database db(":memory:");
    const auto later = store_test_session(db, example_session("2026-11-23T08:00:00Z"));
    const auto other_aircraft = store_test_session(db, example_session("2026-11-22T21:00:00Z", "F-WEMB"));
    const auto earlier = store_test_session(db, example_session("2026-11-22T20:00:00Z"));
    StoredTestSession no_test = example_session("2026-11-23T08:00:00Z");  // same time as `later`: stored after it
    no_test.phase = "pre-flight";
    no_test.verdict = "NO_TEST";
    no_test.runs.clear();
    no_test.findings.clear();
    const auto same_time = store_test_session(db, no_test);

    const auto listed = list_test_sessions(db, "F-WEMA");
    ASSERT_THAT(listed, SizeIs(3));
    EXPECT_EQ(listed[0].session_id, earlier);
    EXPECT_EQ(listed[1].session_id, later);
    EXPECT_EQ(listed[2].session_id, same_time) << "equal times list in the order stored";
    for (const auto& s : {listed[0], listed[1]}) {
        ASSERT_THAT(s.runs, SizeIs(2));
        for (const auto& r : s.runs) {
            EXPECT_EQ(r.session_id, std::optional<std::int64_t>(s.session_id));
            EXPECT_TRUE(r.samples.empty()) << "listed runs come without samples";
            EXPECT_TRUE(r.raw_log.empty()) << "listed runs come without raw logs";
            EXPECT_THAT(r.estimates, SizeIs(2)) << "listed runs keep their estimates";
        }
        EXPECT_TRUE(same_findings(sorted_as_loaded(example_session().findings), s.findings));
    }
    EXPECT_EQ(listed[2].verdict, "NO_TEST");
    EXPECT_TRUE(listed[2].runs.empty());
    EXPECT_TRUE(listed[2].findings.empty());

    const auto b = list_test_sessions(db, "F-WEMB");
    ASSERT_THAT(b, SizeIs(1));
    EXPECT_EQ(b[0].session_id, other_aircraft);
    EXPECT_TRUE(list_test_sessions(db, "F-NONE").empty());
}

TEST(TestSessionStore, RunsStoredOnTheirOwnHaveNoSession) {
    Database db(":memory:");
    StoredRun alone = example_run("dyn");
    alone.session_id = 12345;  // ignored on input, like run_id
    const auto alone_id = test::store_lone_run(db, alone);
    const auto session_id = store_test_session(db, example_session());

    EXPECT_EQ(load_run(db, alone_id).session_id, std::nullopt);
    const auto runs = list_runs(db, "F-WEMA");
    ASSERT_THAT(runs, SizeIs(3)) << "list_runs lists a session's runs too";
    EXPECT_EQ(std::count_if(runs.begin(), runs.end(), [&](const StoredRun& r) { return r.session_id == session_id; }), 2);
    EXPECT_EQ(std::count_if(runs.begin(), runs.end(), [](const StoredRun& r) { return !r.session_id; }), 1);
}

TEST(TestSessionStore, MisuseIsAClearError) {
    Database db(":memory:");
    EXPECT_THAT([&] { (void)load_test_session(db, 99); }, ThrowsMessage<DbError>(HasSubstr("no test session with id 99")));
    EXPECT_THAT([&] { (void)list_test_sessions(db, "f wema"); }, ThrowsMessage<DbError>(HasSubstr("tail number 'f wema' is not valid")));
    EXPECT_THAT([&] { (void)load_test_session(db, 99); }, ThrowsMessage<DbError>(HasSubstr("[maintenance_db] ")));
}

TEST(TestSessionStore, SchemaChecksAreTheSecondLineOfDefence) {
    // Straight SQL, past the checks in store_test_session: the schema still refuses bad values.
    Database db(":memory:");
    db.exec("INSERT INTO aircraft VALUES ('F-WEMA')");
    const std::string session_sql =
        "INSERT INTO test_sessions(session_id, tail_number, phase, started_utc, verdict, prev_sha256, content_sha256) VALUES (1, ";
    const std::string hashes = ", '', '" + std::string(64, 'a') + "')";
    EXPECT_THAT([&] { db.exec(session_sql + "'F-WEMA', 'pre-flight', '2026-11-22T20:00:00Z', 'NO_TEST', NULL, NULL)"); },
                ThrowsMessage<DbError>(HasSubstr("append-only record: a test session is stored with its hash chain")));
    EXPECT_THAT([&] { db.exec(session_sql + "'F-WEMA', 'mid-flight', '2026-11-22T20:00:00Z', 'NO_TEST'" + hashes); },
                ThrowsMessage<DbError>(HasSubstr("CHECK constraint failed")));
    EXPECT_THAT([&] { db.exec(session_sql + "'F-WEMA', 'pre-flight', '2026-11-22T20:00:00Z', 'OK'" + hashes); },
                ThrowsMessage<DbError>(HasSubstr("CHECK constraint failed")));
    EXPECT_THAT([&] { db.exec(session_sql + "'F-WNONE', 'pre-flight', '2026-11-22T20:00:00Z', 'NO_TEST'" + hashes); },
                ThrowsMessage<DbError>(HasSubstr("FOREIGN KEY constraint failed")));
    db.exec(session_sql + "'F-WEMA', 'pre-flight', '2026-11-22T20:00:00Z', 'NO_TEST'" + hashes);
    const std::string finding_sql = "INSERT INTO findings(tail_number, session_id, parameter, estimator, limit_value, limit_kind, status) VALUES ('F-WEMA', ";
    EXPECT_THAT([&] { db.exec(finding_sql + "1, 'FDJ_Nm', 'physics', 0.1, 'below', 'WITHIN')"); },
                ThrowsMessage<DbError>(HasSubstr("CHECK constraint failed")));
    EXPECT_THAT([&] { db.exec(finding_sql + "1, 'FDJ_Nm', 'physics', NULL, 'max', 'WITHIN')"); },
                ThrowsMessage<DbError>(HasSubstr("CHECK constraint failed")));
    EXPECT_THAT([&] { db.exec(finding_sql + "2, 'FDJ_Nm', 'physics', 0.1, 'max', 'WITHIN')"); },
                ThrowsMessage<DbError>(HasSubstr("FOREIGN KEY constraint failed")));
    db.exec(finding_sql + "1, 'FDJ_Nm', 'physics', 0.1, 'max', 'WITHIN')");
    EXPECT_THAT([&] { db.exec(finding_sql + "1, 'FDJ_Nm', 'physics', 0.1, 'max', 'BEYOND')"); },
                ThrowsMessage<DbError>(HasSubstr("UNIQUE constraint failed: findings")));
    for (const char* table : {"test_sessions", "findings"}) {
        EXPECT_THAT([&] { db.exec(std::string("DELETE FROM ") + table); },
                    ThrowsMessage<DbError>(HasSubstr(std::string("append-only record: ") + table + " rows are never deleted")));
    }
    EXPECT_THAT([&] { db.exec("UPDATE findings SET status = 'WITHIN'"); },
                ThrowsMessage<DbError>(HasSubstr("append-only record: findings rows are never updated")));
    EXPECT_THAT([&] { db.exec("UPDATE test_sessions SET verdict = 'SERVICEABLE'"); },
                ThrowsMessage<DbError>(HasSubstr("append-only record: test_sessions rows are never updated")));
    EXPECT_EQ(row_counts(db).at("findings"), 1) << "nothing was deleted";
}

struct BadSession {
    std::string name;
    std::function<void(StoredTestSession&)> spoil;
    std::string message;
};

void PrintTo(const BadSession& bad, std::ostream* out) { *out << bad.name; }

class InvalidSession : public ::testing::TestWithParam<BadSession> {};

TEST_P(InvalidSession, WritesNothingAndNamesTheField) {
    Database db(":memory:");
    StoredTestSession session = example_session();
    GetParam().spoil(session);
    EXPECT_THAT([&] { (void)store_test_session(db, session); }, ThrowsMessage<DbError>(HasSubstr(GetParam().message)));
    EXPECT_THAT([&] { (void)store_test_session(db, session); }, ThrowsMessage<DbError>(HasSubstr("[maintenance_db] ")));
    EXPECT_THAT(row_counts(db), Each(Pair(::testing::_, 0))) << "nothing of the session is written";
    (void)store_test_session(db, example_session());  // the connection is usable afterwards: no transaction left open
}

INSTANTIATE_TEST_SUITE_P(
    TestSessionStore, InvalidSession,
    ::testing::Values(
        BadSession{"BadPhase", [](auto& s) { s.phase = "mid-flight"; },
                   "test session: phase is 'mid-flight': use 'pre-flight', 'post-flight', 'in-flight' or 'load-rig'"},
        BadSession{"BadVerdict", [](auto& s) { s.verdict = "OK"; },
                   "test session: verdict is 'OK': use 'SERVICEABLE', 'UNSERVICEABLE', 'INCONCLUSIVE' or 'NO_TEST'"},
        BadSession{"BadTail",
                   [](auto& s) {
                       s.tail_number = "f wema";
                       for (auto& r : s.runs) r.tail_number = "f wema";
                   },
                   "test session: tail number 'f wema' is not valid"},
        BadSession{"BadStartedUtc", [](auto& s) { s.started_utc = "22/11/2026 20:00"; },
                   "test session: started_utc '22/11/2026 20:00' is not an ISO 8601 UTC time"},
        BadSession{"RunTailMismatch", [](auto& s) { s.runs[1].tail_number = "F-WEMB"; },
                   "test session run 1: tail_number 'F-WEMB' differs from the session's 'F-WEMA'"},
        BadSession{"RunSampleNotFinite", [](auto& s) { s.runs[1].samples[3].current_a = kNaN; },
                   "test session run 1: run field current_a of sample 3 is not a finite number"},
        BadSession{"RunWithoutRawLog", [](auto& s) { s.runs[1].raw_log.clear(); },
                   "test session run 1: run for F-WEMA has no raw log"},
        BadSession{"RunEstimateStdErrorNaN", [](auto& s) { s.runs[0].estimates[0].std_error = kNaN; },
                   "test session run 0: run field std_error of estimate physics/FDJ_Nm is not a finite number"},
        BadSession{"FindingStdErrorNaN", [](auto& s) { s.findings[2].std_error = kNaN; },
                   "test session finding 2 (eta_O/physics): std_error is not a finite number"},
        BadSession{"FindingStdErrorNegative", [](auto& s) { s.findings[0].std_error = -0.002; },
                   "test session finding 0 (FSJ_Nm/physics): std_error -0.002000 is negative"},
        BadSession{"FindingValueInfinite", [](auto& s) { s.findings[1].value = kInf; },
                   "test session finding 1 (FDJ_Nm/physics): value is not a finite number (inf)"},
        BadSession{"FindingLimitNaN", [](auto& s) { s.findings[1].limit_value = kNaN; },
                   "test session finding 1 (FDJ_Nm/physics): limit_value is not a finite number"},
        BadSession{"FindingBadLimitKind", [](auto& s) { s.findings[3].limit_kind = "below"; },
                   "test session finding 3 (FDJ_Nm/network): limit_kind is 'below': use 'max', 'min' or 'none'"},
        BadSession{"FindingLimitKindWithoutValue", [](auto& s) { s.findings[3].limit_value.reset(); },
                   "test session finding 3 (FDJ_Nm/network): limit_kind 'max' without a limit_value"},
        BadSession{"FindingLimitValueWithoutKind", [](auto& s) { s.findings[3].limit_kind = "none"; },
                   "test session finding 3 (FDJ_Nm/network): limit_kind 'none' with limit_value 0.120000"},
        BadSession{"FindingEmptyStatus", [](auto& s) { s.findings[2].status.clear(); },
                   "test session finding 2 (eta_O/physics): status is empty"},
        BadSession{"DuplicateFinding",
                   [](auto& s) {
                       s.findings.push_back(s.findings[1]);
                       s.findings.back().status = "BEYOND";
                   },
                   "test session finding 4 (FDJ_Nm/physics): duplicate of finding 1"},
        // Passes the checks and fails on the estimates' primary key after run 0 is written: the
        // transaction takes the session and run 0 back with it.
        BadSession{"DuplicateEstimateInRun", [](auto& s) { s.runs[1].estimates.push_back(s.runs[1].estimates[0]); },
                   "UNIQUE constraint failed: estimates.run_id, estimates.estimator, estimates.parameter"}),
    [](const auto& test_param) { return test_param.param.name; });

TEST(Database, UpgradesAVersion1FileInPlaceKeepingItsRuns) {
    const TempDbFile file;
    {
        // The file as emadiag with schema version 1 left it: 001_initial.sql, then user_version 1.
        RawConnection v1(file.path());
        v1.exec(read_text_file(EMADIAG_SOURCE_DIR "/maintenance_db/schema/001_initial.sql"));
        v1.exec("PRAGMA user_version = 1");
        v1.exec("INSERT INTO aircraft VALUES ('F-WOLD');"
                "INSERT INTO runs(tail_number, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, tau, "
                "sample_period_s) VALUES ('F-WOLD', '2025-06-01T09:00:00Z', 'record socketcan:can0', 'A', 'dyn', 0.2, "
                "1.65e-4, 800, 5e-4);"
                "INSERT INTO samples VALUES (1, 0, 5e-4, 0.1, -3.0, 0.01, 5.0, -0.1);"
                "INSERT INTO raw_logs VALUES (1, 'candump', X'00FF0A');"
                "INSERT INTO estimates VALUES (1, 'physics', 'FDJ_Nm', 0.08, 0.001, 1, 'physics-wrls', '')");
        ASSERT_EQ(v1.query_int("PRAGMA user_version"), 1);
    }
    {
        Database db(file.path());
        EXPECT_EQ(db.schema_version(), kNewestSchemaVersion);
        const auto runs = list_runs(db, "F-WOLD");
        ASSERT_THAT(runs, SizeIs(1));
        EXPECT_EQ(runs[0].session_id, std::nullopt) << "runs from before version 2 belong to no session";
        const StoredRun old = load_run(db, runs[0].run_id);
        EXPECT_EQ(old.sequence, "dyn");
        ASSERT_THAT(old.samples, SizeIs(1));
        EXPECT_EQ(old.samples[0].hinge_moment_nm, 5.0);
        EXPECT_EQ(old.raw_log, std::string("\0\xff\n", 3));
        ASSERT_THAT(old.estimates, SizeIs(1));
        EXPECT_EQ(old.estimates[0].value, std::optional<double>(0.08));
        (void)store_test_session(db, example_session("2026-11-22T20:00:00Z", "F-WOLD"));
    }
    {
        Database db(file.path());
        EXPECT_EQ(db.schema_version(), kNewestSchemaVersion);
        EXPECT_THAT(list_runs(db, "F-WOLD"), SizeIs(3));
        const auto sessions = list_test_sessions(db, "F-WOLD");
        ASSERT_THAT(sessions, SizeIs(1));
        EXPECT_THAT(sessions[0].runs, SizeIs(2));
        EXPECT_THAT(sessions[0].findings, SizeIs(4));
    }
}

TEST(Database, RefusesADatabaseOneVersionNewerThanTheCode) {
    const TempDbFile file;
    {
        Database db(file.path());
        (void)store_test_session(db, example_session());
        db.exec("PRAGMA user_version = " + std::to_string(kNewestSchemaVersion + 1));
    }
    EXPECT_THAT([&] { Database db(file.path()); },
                ThrowsMessage<DbError>(HasSubstr("has schema version " + std::to_string(kNewestSchemaVersion + 1) +
                                             ", newer than this emadiag understands (" + std::to_string(kNewestSchemaVersion) + ")")));
    RawConnection raw(file.path());
    EXPECT_EQ(raw.query_int("PRAGMA user_version"), kNewestSchemaVersion + 1) << "never downgraded";
    EXPECT_EQ(raw.query_int("SELECT count(*) FROM test_sessions"), 1);
}

}  // namespace
}  // namespace emadiag::db
