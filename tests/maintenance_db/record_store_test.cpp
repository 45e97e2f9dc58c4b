// The maintenance record of a fleet: SHA-256, positions and installation changes, corrections, the
// per-tail hash chain and its check, discovery findings, the summary tables against a direct
// computation, migrations from every earlier version, and the faults (a locked database, a full
// disk, a corrupt file, kill -9 during a write).
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"
#include "support/db_test_files.hpp"
#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <random>
#include <thread>

namespace emadiag::db {
namespace {

using ::testing::HasSubstr;
using ::testing::SizeIs;
using ::testing::ThrowsMessage;
using test::RawConnection;
using test::read_text_file;
using test::TempDbFile;

constexpr int kNewestSchemaVersion = 7;

StoredTestSession session_at(const std::string& tail, const std::string& position, const std::string& serial, const std::string& utc,
                             double fdj_nm, std::optional<std::int64_t> cycles = std::nullopt) {
    StoredTestSession s;
    s.tail_number = tail;
    s.position = position;
    s.position_ata = position.find("ELEV") != std::string::npos ? "27-30" : "27-10";
    s.actuator_serial = serial;
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.cycles = cycles;
    s.hours_h = cycles ? std::optional<double>(*cycles * 1.5) : std::nullopt;
    s.operator_id = "EMA-AIR";
    s.technician_name = "A. Mechanic";
    s.technician_certificate = "B1-12345";
    s.work_performed = "ground test run DYN, BRK";
    s.source = "test-run";
    s.tool_version = "0.1.0";
    s.verdict = "SERVICEABLE";
    s.limits_json = R"({"FDJ_Nm":{"max":0.12}})";
    s.artifacts.push_back({"model", "models/case_A_dyn.json", sha256_hex("model bytes")});
    s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj_nm, 0.001, 0.12, "max", "WITHIN", ""});
    s.findings.push_back({"FDJ_Nm", "physics:brk", fdj_nm + 0.0005, 0.002, 0.12, "max", "WITHIN", ""});
    s.findings.push_back({"FDJ_Nm", "network:dyn", fdj_nm + 0.01, 0.003, 0.12, "max", "WITHIN", "not a measurement"});
    return s;
}

TEST(Sha256, MatchesTheFips180Examples) {
    EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
              "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    Sha256 million;
    const std::string chunk(1000, 'a');
    for (int i = 0; i < 1000; ++i) million.update(chunk);
    EXPECT_EQ(million.hex(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    // Split anywhere, the same digest.
    const std::string text = "The quick brown fox jumps over the lazy dog, then over the 64-byte block boundary and on.";
    for (std::size_t cut = 0; cut <= text.size(); cut += 7) {
        EXPECT_EQ(Sha256().update(text.substr(0, cut)).update(text.substr(cut)).hex(), sha256_hex(text)) << "cut at " << cut;
    }
}

TEST(Sha256, MatchesAnIndependentImplementationAtEveryLengthUpTo300Bytes) {
    // Every padding case and 0 to 4 whole blocks, on whichever compression function this CPU uses
    // (the SHA extensions or the portable one). Expected: Python's hashlib over the same 301 inputs,
    // bytes (7 i + 3) mod 256, the 301 hex digests concatenated and hashed once more.
    std::string digests;
    for (std::size_t n = 0; n <= 300; ++n) {
        std::string bytes(n, '\0');
        for (std::size_t i = 0; i < n; ++i) bytes[i] = static_cast<char>((i * 7 + 3) & 0xff);
        digests += sha256_hex(bytes);
    }
    EXPECT_EQ(sha256_hex(digests), "9ab015b3431ba48c0f99e81c5bb7d903f6bfea343d7d7b190120d07cc51e653b");
}

TEST(Record, StoresEveryFieldOfTheRecordAndReadsItBack) {
    Database db(":memory:");
    const auto receipt = store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08, 1200));
    const StoredTestSession s = load_test_session(db, receipt.session_id);
    EXPECT_EQ(s.position, std::optional<std::string>("LH-ELEV"));
    EXPECT_EQ(s.position_ata, "27-30");
    EXPECT_EQ(s.cycles, std::optional<std::int64_t>(1200));
    EXPECT_EQ(s.hours_h, std::optional<double>(1800.0));
    EXPECT_EQ(s.technician_name, "A. Mechanic");
    EXPECT_EQ(s.technician_certificate, "B1-12345");
    EXPECT_EQ(s.operator_id, "EMA-AIR");
    EXPECT_EQ(s.work_performed, "ground test run DYN, BRK");
    EXPECT_EQ(s.limits_sha256, sha256_hex(R"({"FDJ_Nm":{"max":0.12}})"));
    ASSERT_THAT(s.artifacts, SizeIs(1));
    EXPECT_EQ(s.artifacts[0].sha256, sha256_hex("model bytes"));
    EXPECT_EQ(s.prev_sha256, "");
    EXPECT_EQ(s.content_sha256, receipt.content_sha256);
    EXPECT_EQ(session_content_sha256(s, s.prev_sha256), s.content_sha256) << "the loaded session hashes to the stored value";
    const auto second = store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-02-05T08:00:00Z", 0.081, 1260));
    EXPECT_EQ(load_test_session(db, second.session_id).prev_sha256, receipt.content_sha256) << "chained to the previous session";
    ASSERT_THAT(list_positions(db), SizeIs(1));
}

TEST(Record, RecordsAnInstallationChangeWhenAPositionShowsANewSerial) {
    Database db(":memory:");
    const auto first = store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08, 100));
    ASSERT_TRUE(first.installation);
    EXPECT_EQ(first.installation->from_serial, "");
    EXPECT_EQ(first.installation->to_serial, "SN-1");
    EXPECT_FALSE(store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-02-05T08:00:00Z", 0.08, 150)).installation);
    EXPECT_TRUE(store_session(db, session_at("F-WEMA", "RH-ELEV", "SN-2", "2026-02-05T09:00:00Z", 0.08, 150)).installation);
    const auto swap = store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-3", "2026-03-05T08:00:00Z", 0.07, 200));
    ASSERT_TRUE(swap.installation);
    EXPECT_EQ(swap.installation->from_serial, "SN-1");
    EXPECT_EQ(swap.installation->to_serial, "SN-3");
    EXPECT_EQ(swap.installation->cycles, std::optional<std::int64_t>(200));
    // SN-1 moves to another aircraft: its history follows the serial.
    const auto moved = store_session(db, session_at("F-WEMB", "LH-ELEV", "SN-1", "2026-04-05T08:00:00Z", 0.083, 5000));
    ASSERT_TRUE(moved.installation);
    EXPECT_THAT(list_installations(db, "F-WEMA"), SizeIs(3));
    EXPECT_THAT(list_installations_of_serial(db, "SN-1"), SizeIs(3));
    EXPECT_THAT(list_sessions_of_serial(db, "SN-1"), SizeIs(3));
    const auto status = list_position_status(db);
    ASSERT_THAT(status, SizeIs(3));
    EXPECT_EQ(status[0].position, "LH-ELEV");
    EXPECT_EQ(status[0].actuator_serial, "SN-3");
}

TEST(Record, RefusesAnInvalidPositionOrAnotherAtaReferenceAndWritesNothing) {
    Database db(":memory:");
    auto bad = session_at("F-WEMA", "lh elev", "SN-1", "2026-01-05T08:00:00Z", 0.08);
    EXPECT_THAT([&] { (void)store_session(db, bad); }, ThrowsMessage<DbError>(HasSubstr("position 'lh elev' is not valid")));
    bad = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08);
    bad.position_ata = "32-10";
    EXPECT_THAT([&] { (void)store_session(db, bad); }, ThrowsMessage<DbError>(HasSubstr("ATA reference '32-10' is not valid")));
    (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08));
    bad.position_ata = "27-31";
    EXPECT_THAT([&] { (void)store_session(db, bad); },
                ThrowsMessage<DbError>(HasSubstr("position LH-ELEV is recorded in :memory: with ATA reference 27-30, not 27-31")));
    EXPECT_THAT(list_test_sessions(db, "F-WEMA"), SizeIs(1));
}

TEST(Record, ACorrectionIsANewEntryThatAmendsOneSessionOnce) {
    Database db(":memory:");
    const auto wrong = store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.5, 100));
    auto fix = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08, 100);
    fix.amends_session_id = wrong.session_id;
    EXPECT_THAT([&] { (void)store_session(db, fix); }, ThrowsMessage<DbError>(HasSubstr("needs a reason")));
    fix.correction_reason = "cycles typed from the wrong technical log page";
    const auto corrected = store_session(db, fix);
    EXPECT_THAT([&] { (void)store_session(db, fix); }, ThrowsMessage<DbError>(HasSubstr("is already amended by session 2")));
    auto other = session_at("F-WEMB", "LH-ELEV", "SN-9", "2026-01-05T08:00:00Z", 0.08);
    other.amends_session_id = corrected.session_id;
    other.correction_reason = "x";
    EXPECT_THAT([&] { (void)store_session(db, other); }, ThrowsMessage<DbError>(HasSubstr("of tail F-WEMA, not of F-WEMB")));
    EXPECT_EQ(load_test_session(db, wrong.session_id).findings[2].value, std::optional<double>(0.5)) << "the amended entry stays";
    // The summary counts the correction instead of the entry it amends.
    const auto stats = list_series_stats(db, std::string("F-WEMA"));
    ASSERT_THAT(stats, SizeIs(1));
    EXPECT_EQ(stats[0].n, 1);
    EXPECT_NEAR(stats[0].s_wy / stats[0].s_w, 0.0801, 1e-4);
}

TEST(Record, SummaryTablesMatchADirectComputation) {
    // Property: after random sessions (random order of times, some without cycles), series_stats
    // holds the weighted sums a direct computation over the stored sessions gives.
    const std::uint64_t seed = 20261124;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Database db(":memory:");
    for (int i = 0; i < 40; ++i) {
        const int day = static_cast<int>(u(rng) * 300);
        char utc[32];
        std::snprintf(utc, sizeof utc, "2026-%02d-%02dT%02d:00:00Z", 1 + day / 28, 1 + day % 28, static_cast<int>(u(rng) * 23));
        const std::optional<std::int64_t> cycles = u(rng) < 0.8 ? std::optional<std::int64_t>(day * 4) : std::nullopt;
        (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", utc, 0.08 + 0.01 * u(rng), cycles));
    }
    const auto stats = list_series_stats(db, std::string("F-WEMA"));
    ASSERT_THAT(stats, SizeIs(1)) << "seed " << seed;
    const SeriesStats& s = stats[0];
    double w = 0, wt = 0, wtt = 0, wy = 0, wty = 0, wyy = 0, cw = 0, cwt = 0, cy = 0;
    std::int64_t n_cycles = 0;
    const auto sessions = list_test_sessions(db, "F-WEMA");
    for (const auto& x : sessions) {
        const auto m = session_measurements(x.findings);
        ASSERT_THAT(m, SizeIs(1));
        const double wi = 1 / (m[0].std_error * m[0].std_error);
        const int year = std::stoi(x.started_utc.substr(0, 4));
        ASSERT_EQ(year, 2026);
        std::tm tm{};
        strptime(x.started_utc.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm);
        const double days = static_cast<double>(timegm(&tm)) / 86400.0;
        const double t = days - s.first_days;
        w += wi; wt += wi * t; wtt += wi * t * t; wy += wi * m[0].value; wty += wi * t * m[0].value; wyy += wi * m[0].value * m[0].value;
        if (x.cycles) {
            ++n_cycles;
            const double tc = static_cast<double>(*x.cycles) - *s.first_cycles;
            cw += wi; cwt += wi * tc; cy += wi * tc * m[0].value;
        }
    }
    EXPECT_EQ(s.n, 40);
    EXPECT_EQ(s.n_cycles, n_cycles);
    const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b)); };
    EXPECT_TRUE(near(s.s_w, w) && near(s.s_wt, wt) && near(s.s_wtt, wtt) && near(s.s_wy, wy) && near(s.s_wty, wty) && near(s.s_wyy, wyy))
        << "seed " << seed << ": s_wt " << s.s_wt << " vs " << wt << ", s_wtt " << s.s_wtt << " vs " << wtt;
    EXPECT_TRUE(near(s.c_w, cw) && near(s.c_wt, cwt) && near(s.c_wty, cy)) << "seed " << seed;
    EXPECT_EQ(s.last_session_id, sessions.back().session_id) << "the newest session by time";
}

TEST(Record, VerifyFindsEveryChangeMadeOutsideTheTool) {
    const TempDbFile file;
    {
        Database db(file.path());
        auto with_run = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08, 100);
        with_run.runs.push_back(test::example_stored_run("dyn", "F-WEMA"));
        (void)store_session(db, with_run);
        (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-02-05T08:00:00Z", 0.081, 150));
        (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-03-05T08:00:00Z", 0.082, 200));
        const auto check = verify_tail(db, "F-WEMA");
        EXPECT_TRUE(check.ok()) << ::testing::PrintToString(check.problems);
        EXPECT_EQ(check.sessions_checked, 3);
    }
    struct Tamper {
        std::string sql, expected;
    };
    for (const Tamper& t : std::vector<Tamper>{
             {"UPDATE findings SET value = 0.07 WHERE session_id = 2 AND estimator = 'physics:dyn'", "session 2 (2026-02-05T08:00:00Z): its content differs"},
             {"UPDATE samples SET current_a = 1.5 WHERE sample_index = 3", "session 1 (2026-01-05T08:00:00Z): its content differs"},
             {"UPDATE raw_logs SET content = X'00'", "session 1 (2026-01-05T08:00:00Z): its content differs"},
             {"UPDATE test_sessions SET technician_certificate = 'B1-99999' WHERE session_id = 3", "session 3 (2026-03-05T08:00:00Z): its content differs"},
             {"DELETE FROM findings WHERE session_id = 2; DELETE FROM test_sessions WHERE session_id = 2", "session 3 (2026-03-05T08:00:00Z): its link"},
             {"DELETE FROM findings WHERE session_id = 3; DELETE FROM test_sessions WHERE session_id = 3", "the chain head records 3 sessions"},
         }) {
        const TempDbFile copy("_tampered");
        std::filesystem::copy_file(file.path(), copy.path());
        {
            RawConnection raw(copy.path());  // someone outside the tool, dropping the triggers first
            raw.exec("PRAGMA foreign_keys = OFF");
            for (const char* table : {"test_sessions", "findings", "samples", "raw_logs"}) {
                raw.exec(std::string("DROP TRIGGER ") + table + "_no_update; DROP TRIGGER " + table + "_no_delete");
            }
            raw.exec(t.sql);
        }
        Database db(copy.path());
        const auto check = verify_tail(db, "F-WEMA");
        EXPECT_FALSE(check.ok()) << t.sql;
        EXPECT_THAT(::testing::PrintToString(check.problems), HasSubstr(t.expected)) << t.sql;
    }
}

TEST(Record, DiscoveryFindingsAreStoredOpenedAndClosed) {
    Database db(":memory:");
    StoredDiscoveryFinding f;
    f.tail_number = "F-WEMA";
    f.position = "LH-ELEV";
    f.position_ata = "27-30";
    f.actuator_serial = "SN-1";
    f.found_utc = "2026-05-01T10:00:00Z";
    f.summary = "viscous friction 2.1e-05 N m s/rad; RMS error 0.031 -> 0.004 N m";
    f.model_json = R"({"effects":{"viscous":2.1e-05}})";
    const auto id = store_discovery_finding(db, f);
    EXPECT_THAT(list_discovery_findings(db, "F-WEMA", true), SizeIs(1));
    StoredDiscoveryFinding close = f;
    close.status = "closed";
    close.summary = "gearbox relubricated; residual back within noise";
    close.amends_finding_id = id;
    (void)store_discovery_finding(db, close);
    EXPECT_THAT(list_discovery_findings(db, "F-WEMA", true), SizeIs(0));
    EXPECT_THAT(list_discovery_findings(db, "F-WEMA"), SizeIs(2));
    EXPECT_THAT([&] { (void)store_discovery_finding(db, close); }, ThrowsMessage<DbError>(HasSubstr("is already amended by finding 2")));
    f.summary.clear();
    EXPECT_THAT([&] { (void)store_discovery_finding(db, f); }, ThrowsMessage<DbError>(HasSubstr("discovery finding: summary is empty")));
    f.summary = "x";
    f.tail_number = "bad tail";
    EXPECT_THAT([&] { (void)store_discovery_finding(db, f); }, ThrowsMessage<DbError>(HasSubstr("tail number 'bad tail' is not valid")));
}

// ---- migrations: every earlier version to the newest, nothing lost ----

TEST(Migration, FromVersion2KeepsEverySessionAndSealsItIntoTheChain) {
    const TempDbFile file;
    {
        RawConnection v2(file.path());
        v2.exec(read_text_file(EMADIAG_SOURCE_DIR "/maintenance_db/schema/001_initial.sql"));
        v2.exec(read_text_file(EMADIAG_SOURCE_DIR "/maintenance_db/schema/002_test_sessions.sql"));
        v2.exec("PRAGMA user_version = 2");
        v2.exec("INSERT INTO aircraft VALUES ('F-WOLD');"
                "INSERT INTO test_sessions(tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, limits_json) "
                "VALUES ('F-WOLD', 'SN-7', 'pre-flight', '2025-06-01T09:00:00Z', '0.1.0', 'SERVICEABLE', 'ok', '{\"FDJ_Nm\":{\"max\":0.12}}'),"
                "       ('F-WOLD', 'SN-7', 'post-flight', '2025-07-01T09:00:00Z', '0.1.0', 'INCONCLUSIVE', '', '{}');"
                "INSERT INTO runs(tail_number, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, tau, sample_period_s, session_id) "
                "VALUES ('F-WOLD', '2025-06-01T09:00:00Z', 'test-run socketcan:can0', 'A', 'dyn', 0.2, 1.65e-4, 800, 5e-4, 1);"
                "INSERT INTO samples VALUES (1, 0, 5e-4, 0.1, -3.0, 0.01, 5.0, -0.1);"
                "INSERT INTO raw_logs VALUES (1, 'candump', X'00FF0A');"
                "INSERT INTO estimates VALUES (1, 'physics', 'FDJ_Nm', 0.08, 0.001, 1, 'physics-wrls', '');"
                "INSERT INTO findings VALUES (1, 'FDJ_Nm', 'physics:dyn', 0.08, 0.001, 0.12, 'max', 'WITHIN', ''),"
                "                            (2, 'FDJ_Nm', 'physics:dyn', 0.09, 0.001, 0.12, 'max', 'WITHIN', '')");
    }
    Database db(file.path());
    EXPECT_EQ(db.schema_version(), kNewestSchemaVersion);
    const auto sessions = list_test_sessions(db, "F-WOLD");
    ASSERT_THAT(sessions, SizeIs(2));
    EXPECT_EQ(sessions[0].session_id, 1);
    EXPECT_EQ(sessions[0].verdict_note, "ok");
    EXPECT_EQ(sessions[0].position, std::nullopt) << "no position before version 3";
    EXPECT_EQ(sessions[1].phase, "post-flight");
    EXPECT_EQ(sessions[0].findings[0].value, std::optional<double>(0.08));
    const StoredTestSession full = load_test_session(db, 1);
    ASSERT_THAT(full.runs, SizeIs(1));
    EXPECT_EQ(full.runs[0].raw_log, std::string("\0\xff\n", 3));
    EXPECT_THAT(full.runs[0].samples, SizeIs(1));
    const auto check = verify_tail(db, "F-WOLD");
    EXPECT_TRUE(check.ok()) << ::testing::PrintToString(check.problems);
    EXPECT_EQ(check.sessions_checked, 2);
    EXPECT_EQ(sessions[1].prev_sha256, sessions[0].content_sha256);
    const auto stats = list_series_stats(db, std::string("F-WOLD"));
    ASSERT_THAT(stats, SizeIs(1));
    EXPECT_EQ(stats[0].n, 2);
    EXPECT_EQ(stats[0].position, "");
    // And the record goes on from there.
    const auto next = store_session(db, session_at("F-WOLD", "LH-ELEV", "SN-7", "2025-08-01T09:00:00Z", 0.1, 300));
    EXPECT_EQ(load_test_session(db, next.session_id).prev_sha256, sessions[1].content_sha256);
    EXPECT_THAT([&] { db.exec("DELETE FROM test_sessions WHERE session_id = 1"); }, ThrowsMessage<DbError>(HasSubstr("append-only record")));
}

TEST(Migration, FromVersion1KeepsItsRunsAndFromNothingBuildsTheNewest) {
    const TempDbFile file;
    {
        RawConnection v1(file.path());
        v1.exec(read_text_file(EMADIAG_SOURCE_DIR "/maintenance_db/schema/001_initial.sql"));
        v1.exec("PRAGMA user_version = 1");
        v1.exec("INSERT INTO aircraft VALUES ('F-WOLD');"
                "INSERT INTO runs(tail_number, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, tau, sample_period_s) "
                "VALUES ('F-WOLD', '2025-06-01T09:00:00Z', 'record socketcan:can0', 'A', 'dyn', 0.2, 1.65e-4, 800, 5e-4);"
                "INSERT INTO samples VALUES (1, 0, 5e-4, 0.1, -3.0, 0.01, 5.0, -0.1);"
                "INSERT INTO raw_logs VALUES (1, 'candump', X'00FF0A');"
                "INSERT INTO estimates VALUES (1, 'physics', 'FDJ_Nm', 0.08, 0.001, 1, 'physics-wrls', '')");
    }
    {
        Database db(file.path());
        EXPECT_EQ(db.schema_version(), kNewestSchemaVersion);
        const StoredRun old = load_run(db, 1);
        EXPECT_EQ(old.raw_log, std::string("\0\xff\n", 3));
        EXPECT_EQ(old.estimates[0].value, std::optional<double>(0.08));
        EXPECT_TRUE(verify_tail(db, "F-WOLD").ok());
    }
    Database fresh(":memory:");
    EXPECT_EQ(fresh.schema_version(), kNewestSchemaVersion);
}

// ---- faults ----

TEST(Faults, ALockedDatabaseWaitsTheBusyTimeoutThenSaysSoAndWritesNothing) {
    const TempDbFile file;
    { Database create(file.path()); }
    RawConnection other(file.path());
    other.exec("BEGIN IMMEDIATE");  // another writer holds the lock
    constexpr int kBusyTimeoutMs = 300;
    Database db(file.path(), kBusyTimeoutMs);
    const auto t0 = std::chrono::steady_clock::now();
    try {
        (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08));
        FAIL() << "stored into a locked database";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::Busy);
        EXPECT_THAT(e.what(), HasSubstr("database " + file.path() + ": locked by another writer (waited the busy timeout of 300 ms)"));
        EXPECT_THAT(e.what(), HasSubstr("nothing was written"));
    }
    EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(kBusyTimeoutMs));
    other.exec("ROLLBACK");
    EXPECT_THAT(list_test_sessions(db, "F-WEMA"), SizeIs(0));
    (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08));  // free again
    EXPECT_THAT(list_test_sessions(db, "F-WEMA"), SizeIs(1));
}

TEST(Faults, AFullDiskFailsTheWholeSessionWithAClearError) {
    const TempDbFile file;
    Database db(file.path());
    (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08));
    // No room for one more page: SQLite reports SQLITE_FULL exactly as on a full disk.
    RawConnection probe(file.path());
    const auto pages = probe.query_int("PRAGMA page_count");
    db.exec("PRAGMA max_page_count = " + std::to_string(pages));
    auto big = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-02-05T08:00:00Z", 0.08);
    big.runs.push_back(test::example_stored_run("dyn", "F-WEMA"));
    big.runs[0].raw_log = std::string(200000, 'x');
    try {
        (void)store_session(db, big);
        FAIL() << "stored past a full disk";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::Full);
        EXPECT_THAT(e.what(), HasSubstr("database " + file.path() + ": the disk is full; nothing was written"));
    }
    EXPECT_THAT(list_test_sessions(db, "F-WEMA"), SizeIs(1));
    EXPECT_TRUE(verify_tail(db, "F-WEMA").ok());
}

TEST(Faults, ACorruptDatabaseIsDetectedAtOpenAndNeverWritten) {
    const TempDbFile garbage;
    {
        std::ofstream out(garbage.path(), std::ios::binary);
        out << "this is a spreadsheet, not a maintenance database, but it is long enough to have a header";
    }
    const std::string before = read_text_file(garbage.path());
    try {
        Database db(garbage.path());
        FAIL() << "opened a file that is not SQLite";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::Corrupt);
        EXPECT_THAT(e.what(), HasSubstr("database " + garbage.path() + " is corrupt or not an SQLite database"));
    }
    EXPECT_EQ(read_text_file(garbage.path()), before) << "never written";

    // A real database with a damaged page past the header: PRAGMA quick_check finds it.
    const TempDbFile damaged("_damaged");
    {
        Database db(damaged.path());
        for (int i = 0; i < 30; ++i) {
            auto s = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08 + i * 1e-4);
            s.runs.push_back(test::example_stored_run("dyn", "F-WEMA"));
            (void)store_session(db, s);
        }
    }
    std::string bytes = read_text_file(damaged.path());
    ASSERT_GT(bytes.size(), 8192u);
    for (std::size_t i = 4096 + 8; i < 4096 + 200; ++i) bytes[i] = static_cast<char>(0xA5);  // page 2's header and cells
    { std::ofstream(damaged.path(), std::ios::binary | std::ios::trunc) << bytes; }
    try {
        Database db(damaged.path());
        FAIL() << "opened a damaged database";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::Corrupt) << e.what();
        EXPECT_THAT(e.what(), HasSubstr("it is left untouched"));
    }
    EXPECT_EQ(read_text_file(damaged.path()), bytes) << "never written";
}

TEST(Faults, KillDashNineDuringWritesNeverLeavesAPartialSession) {
    const TempDbFile file;
    { Database create(file.path()); }
    constexpr int kRunsPerSession = 3;
    constexpr int kSamplesPerRun = 4000;
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        // The writer: sessions with large runs, as fast as it can, until killed.
        try {
            Database db(file.path(), Database::kDefaultBusyTimeoutMs, false);
            for (int i = 0;; ++i) {
                auto s = session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-05T08:00:00Z", 0.08);
                for (int r = 0; r < kRunsPerSession; ++r) {
                    auto run = test::example_stored_run(r == 0 ? "dyn" : "brk", "F-WEMA");
                    run.samples.resize(kSamplesPerRun, run.samples.back());
                    s.runs.push_back(std::move(run));
                }
                (void)store_session(db, s);
            }
        } catch (...) {
        }
        _exit(1);
    }
    // Kill it at a moment unrelated to its transactions once a few sessions are in.
    for (int waited_ms = 0; waited_ms < 20000; waited_ms += 20) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        RawConnection probe(file.path());
        try {
            if (probe.query_int("SELECT count(*) FROM test_sessions") >= 3) break;
        } catch (const std::exception&) {
        }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(37));
    ASSERT_EQ(kill(child, SIGKILL), 0);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    Database db(file.path());  // rolls back the hot journal, passes quick_check
    {
        Statement ic(db, "PRAGMA integrity_check");
        ASSERT_TRUE(ic.step());
        EXPECT_EQ(ic.column_text(0), "ok");
    }
    const auto sessions = list_test_sessions(db, "F-WEMA");
    EXPECT_GE(sessions.size(), 3u);
    for (const auto& s : sessions) {
        ASSERT_THAT(s.runs, SizeIs(kRunsPerSession)) << "session " << s.session_id;
        ASSERT_THAT(s.findings, SizeIs(3)) << "session " << s.session_id;
    }
    Statement samples(db, "SELECT count(*) FROM samples");
    samples.step();
    EXPECT_EQ(samples.column_int(0), static_cast<std::int64_t>(sessions.size()) * kRunsPerSession * kSamplesPerRun);
    const auto check = verify_tail(db, "F-WEMA");
    EXPECT_TRUE(check.ok()) << ::testing::PrintToString(check.problems);
    (void)store_session(db, session_at("F-WEMA", "LH-ELEV", "SN-1", "2026-01-06T08:00:00Z", 0.08));  // the record goes on
}

}  // namespace
}  // namespace emadiag::db
