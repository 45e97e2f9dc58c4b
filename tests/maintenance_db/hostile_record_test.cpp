// Issue 21 items 5, 9 and 10 against the library: changes made outside the tool to rows a report
// shows (installations, discovery findings), a deleted last session with a rewritten chain head
// (found by the anchor file), a store that would append to a broken chain, bytes appended to the
// file, a batch of sessions that is whole or absent, and several processes creating one new file.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"

#include "older_version_file.hpp"
#include "support/db_test_files.hpp"
#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

namespace {

using namespace emadiag::db;
using emadiag::test::RawConnection;
using emadiag::test::TempDbFile;
using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

StoredTestSession session_at(const std::string& tail, const std::string& serial, const std::string& utc, double fdj_nm) {
    StoredTestSession s;
    s.tail_number = tail;
    s.position = "LH-ELEV";
    s.position_ata = "27-30";
    s.actuator_serial = serial;
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.cycles = 1000;
    s.hours_h = 1500;
    s.source = "test-run";
    s.tool_version = "hostile-record-test";
    s.verdict = "SERVICEABLE";
    s.limits_json = R"({"FDJ_Nm":{"max":0.12}})";
    s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj_nm, 0.001, 0.12, "max", "WITHIN", ""});
    return s;
}

StoredDiscoveryFinding discovery(const std::string& tail, const std::string& summary) {
    StoredDiscoveryFinding f;
    f.tail_number = tail;
    f.position = "LH-ELEV";
    f.position_ata = "27-30";
    f.actuator_serial = "SN-1";
    f.found_utc = "2026-05-01T10:00:00Z";
    f.summary = summary;
    f.model_json = R"({"effects":{"viscous":2.1e-05}})";
    return f;
}

/// Three sessions of F-WEMA (SN-1, SN-1, SN-2: two installations) and two discovery findings.
void fill(const std::string& path) {
    Database db(path);
    (void)store_session(db, session_at("F-WEMA", "SN-1", "2026-01-05T08:00:00Z", 0.080));
    (void)store_session(db, session_at("F-WEMA", "SN-1", "2026-02-05T08:00:00Z", 0.081));
    (void)store_session(db, session_at("F-WEMA", "SN-2", "2026-03-05T08:00:00Z", 0.079));
    (void)store_discovery_finding(db, discovery("F-WEMA", "viscous friction 2.1e-05 N m s/rad"));
    (void)store_discovery_finding(db, discovery("F-WEMA", "backlash 0.02 rad"));
}

std::string problems_of(Database& db, const std::string& tail) {
    std::string all;
    for (const auto& p : verify_tail(db, tail).problems) all += p + "\n";
    return all;
}

std::string file_bytes(const std::string& path) { return emadiag::test::read_text_file(path); }

TEST(HostileRecord, AnInstallationEditedOutsideTheToolFailsVerify) {
    const TempDbFile file;
    fill(file.path());
    {
        Database db(file.path());
        const ChainCheck c = verify_tail(db, "F-WEMA");
        EXPECT_TRUE(c.ok()) << problems_of(db, "F-WEMA");
        EXPECT_EQ(c.installations_checked, 2);
        EXPECT_EQ(c.discovery_findings_checked, 2);
        EXPECT_EQ(c.anchor_lines_checked, 5) << "one anchor line per store";
    }
    {
        RawConnection raw(file.path());
        raw.exec("DROP TRIGGER installations_no_update; UPDATE installations SET to_serial = 'FAKE-1' WHERE to_serial = 'SN-2'");
    }
    Database db(file.path());
    EXPECT_THAT(problems_of(db, "F-WEMA"), AllOf(HasSubstr("installation 2 reads LH-ELEV SN-1 -> FAKE-1"), HasSubstr("SN-1 -> SN-2"),
                                                 HasSubstr("changed outside the tool")));
}

TEST(HostileRecord, APositionsAtaReferenceOrDescriptionEditedOutsideTheToolFailsVerifyThroughTheAnchor) {
    for (const std::string edit : {"ata_reference = '27-10'", "description = 'right aileron'"}) {
        const TempDbFile file;
        fill(file.path());
        {
            RawConnection raw(file.path());
            raw.exec("UPDATE positions SET " + edit + " WHERE position = 'LH-ELEV'");
        }
        Database db(file.path());
        EXPECT_THAT(problems_of(db, "F-WEMA"),
                    HasSubstr("records position LH-ELEV with another ATA reference or description than the positions table holds now"))
            << edit;
    }
}

TEST(HostileRecord, ADeletedInstallationFailsVerify) {
    const TempDbFile file;
    fill(file.path());
    {
        RawConnection raw(file.path());
        raw.exec("DROP TRIGGER installations_no_delete; DELETE FROM installations WHERE to_serial = 'SN-2'");
    }
    Database db(file.path());
    EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("session 3 shows an installation change (LH-ELEV SN-1 -> SN-2"));
}

TEST(HostileRecord, ADiscoveryFindingsSummaryOrStatusEditedOutsideTheToolFailsVerify) {
    for (const std::string edit : {"summary = 'nothing found'", "status = 'closed'"}) {
        const TempDbFile file;
        fill(file.path());
        {
            RawConnection raw(file.path());
            raw.exec("DROP TRIGGER discovery_findings_no_update; UPDATE discovery_findings SET " + edit + " WHERE finding_id = 1");
        }
        Database db(file.path());
        EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("discovery finding 1 (2026-05-01T10:00:00Z): its content differs from its stored hash"))
            << edit;
        // Nothing is appended to the broken chain of discovery findings.
        EXPECT_THAT([&] { (void)store_discovery_finding(db, discovery("F-WEMA", "more")); },
                    ThrowsMessage<DbError>(AllOf(HasSubstr("tail F-WEMA: the chain of its discovery findings is broken"), HasSubstr("discovery finding 1"))));
    }
}

TEST(HostileRecord, ADiscoveryFindingReHashedOrRemovedOutsideTheToolFailsVerify) {
    const TempDbFile file;
    fill(file.path());
    {
        // The summary edited and its own hash recomputed as the format says: the chain shows it.
        Database db(file.path());
        auto f = list_discovery_findings(db, "F-WEMA").front();
        f.summary = "nothing found";
        Sha256 h;
        h.update("emadiag-discovery-v1\n");
        for (const auto& [name, value] : std::initializer_list<std::pair<const char*, std::string>>{
                 {"tail_number", f.tail_number}, {"position", *f.position}, {"actuator_serial", f.actuator_serial},
                 {"found_utc", f.found_utc}, {"summary", f.summary}, {"model_json", f.model_json}, {"status", f.status},
                 {"amends_finding_id", "-"}, {"tool_version", f.tool_version}})
            h.update(std::string(name) + ":" + std::to_string(value.size()) + ":").update(value).update("\n");
        RawConnection raw(file.path());
        raw.exec("DROP TRIGGER discovery_findings_no_update; UPDATE discovery_findings SET summary = 'nothing found', content_sha256 = '" +
                 h.hex() + "' WHERE finding_id = 1");
    }
    {
        Database db(file.path());
        EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("discovery findings were removed, added or re-hashed outside the tool"));
    }
    const TempDbFile second("_removed");
    fill(second.path());
    {
        RawConnection raw(second.path());
        raw.exec("DROP TRIGGER discovery_findings_no_delete; DELETE FROM discovery_findings WHERE finding_id = 2; "
                 "UPDATE chain_heads SET discovery_findings = 1, discovery_head_sha256 = '' WHERE tail_number = 'F-WEMA'");
    }
    Database db(second.path());
    const std::string problems = problems_of(db, "F-WEMA");
    EXPECT_THAT(problems, HasSubstr("records 2 discovery findings, the database holds 1: discovery findings were removed outside the tool"));
}

TEST(HostileRecord, TheLastSessionDeletedWithARewrittenChainHeadIsFoundByTheAnchor) {
    const TempDbFile file;
    fill(file.path());
    {
        RawConnection raw(file.path());
        raw.exec("PRAGMA foreign_keys = OFF; DROP TRIGGER test_sessions_no_delete; DROP TRIGGER findings_no_delete; "
                 "DROP TRIGGER installations_no_delete; DELETE FROM findings WHERE session_id = 3; DELETE FROM installations WHERE session_id = 3; "
                 "DELETE FROM test_sessions WHERE session_id = 3; "
                 "UPDATE chain_heads SET session_id = 2, sessions = 2, content_sha256 = (SELECT content_sha256 FROM test_sessions WHERE session_id = 2)");
    }
    {
        Database db(file.path());
        db.set_anchor_path("");  // the database alone: consistent, the deletion does not show
        EXPECT_TRUE(verify_tail(db, "F-WEMA").ok()) << "without the anchor the database is self-consistent";
    }
    Database db(file.path());
    EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("records 3 sessions ending at "));
    EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("the database holds 2: sessions were removed outside the tool"));
    // A store checks the database's own chain, not the anchor (a database restored from a backup is
    // older than its anchor too, and goes on): what was removed still shows after more are stored.
    (void)store_session(db, session_at("F-WEMA", "SN-2", "2026-04-05T08:00:00Z", 0.08));
    EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("records session 3 of the chain as "));
    EXPECT_THAT(problems_of(db, "F-WEMA"), HasSubstr("the chain was rewritten outside the tool"));
}

TEST(HostileRecord, AStoreNeverAppendsToABrokenChainAndNamesTheFirstBadSession) {
    const TempDbFile file;
    fill(file.path());
    {
        // Damage inside a cell of session 2 (what a flipped byte quick_check cannot see does).
        RawConnection raw(file.path());
        raw.exec("DROP TRIGGER findings_no_update; UPDATE findings SET value = 0.05 WHERE session_id = 2");
    }
    Database db(file.path());
    try {
        (void)store_session(db, session_at("F-WEMA", "SN-2", "2026-04-05T08:00:00Z", 0.08));
        FAIL() << "stored on a broken chain";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::BrokenChain);
        EXPECT_THAT(e.what(), AllOf(HasSubstr("tail F-WEMA"), HasSubstr("session 2 (2026-02-05T08:00:00Z)"), HasSubstr("nothing was stored")));
    }
    EXPECT_EQ(list_test_sessions(db, "F-WEMA").size(), 3u);
    // The bulk store checks the head session of each tail: damage there is refused too.
    {
        RawConnection raw(file.path());
        raw.exec("UPDATE findings SET value = 0.05 WHERE session_id = 3");
    }
    EXPECT_THAT([&] { (void)store_sessions(db, {session_at("F-WEMA", "SN-2", "2026-04-05T08:00:00Z", 0.08)}); },
                ThrowsMessage<DbError>(AllOf(HasSubstr("tail F-WEMA: its hash chain is broken"), HasSubstr("session 3"))));
    // Another tail is not held up.
    EXPECT_GT(store_session(db, session_at("F-WEMB", "SN-9", "2026-04-05T08:00:00Z", 0.08)).session_id, 0);
}

TEST(HostileRecord, BytesAppendedToTheFileAreRefusedAtOpenAndTheFileIsLeftUntouched) {
    const TempDbFile file;
    fill(file.path());
    {
        std::ofstream out(file.path(), std::ios::binary | std::ios::app);
        std::mt19937_64 rng(21);  // seed 21: the issue's number
        for (int i = 0; i < 5000; ++i) out.put(static_cast<char>(rng() & 0xff));
    }
    const std::string before = file_bytes(file.path());
    try {
        Database db(file.path());
        FAIL() << "opened a file with 5000 bytes after its last page";
    } catch (const DbError& e) {
        EXPECT_EQ(e.kind(), DbErrorKind::Corrupt);
        EXPECT_THAT(e.what(), AllOf(HasSubstr("5000 bytes after the last page were not written by SQLite"), HasSubstr("left untouched")));
    }
    EXPECT_EQ(file_bytes(file.path()), before) << "the file is not modified";
}

TEST(HostileRecord, ABatchIsWholeOrAbsent) {
    const TempDbFile file;
    fill(file.path());
    Database db(file.path());
    {
        SessionBatch batch(db);
        for (int i = 0; i < 5; ++i) (void)batch.add(session_at("F-WEMA", "SN-2", "2026-04-0" + std::to_string(i + 1) + "T08:00:00Z", 0.08));
        // A failure at session 6: the batch is never committed.
        StoredTestSession bad = session_at("F-WEMA", "SN-2", "2026-04-07T08:00:00Z", 0.08);
        bad.phase = "mid-air";
        EXPECT_THROW((void)batch.add(bad), DbError);
    }
    EXPECT_EQ(list_test_sessions(db, "F-WEMA").size(), 3u) << "nothing of the failed batch is stored";
    EXPECT_TRUE(verify_tail(db, "F-WEMA").ok());
    SessionBatch batch(db);
    for (int i = 0; i < 5; ++i) (void)batch.add(session_at("F-WEMA", "SN-2", "2026-04-0" + std::to_string(i + 1) + "T08:00:00Z", 0.08));
    batch.commit();
    EXPECT_EQ(list_test_sessions(db, "F-WEMA").size(), 8u);
    EXPECT_TRUE(verify_tail(db, "F-WEMA").ok()) << problems_of(db, "F-WEMA");
}

TEST(HostileRecord, DiscoveryFindingsOfAVersion6FileAreChainedByTheMigration) {
    const TempDbFile newest("_newest"), file;
    fill(newest.path());
    emadiag::test::write_older_version_copy(newest.path(), file.path(), 6);
    {
        RawConnection v6(file.path());
        ASSERT_EQ(v6.query_int("PRAGMA user_version"), 6);
        ASSERT_EQ(v6.query_int("SELECT count(*) FROM discovery_findings"), 2);
    }
    Database db(file.path());
    EXPECT_EQ(db.schema_version(), 7);
    const ChainCheck c = verify_tail(db, "F-WEMA");
    EXPECT_TRUE(c.ok()) << problems_of(db, "F-WEMA");
    EXPECT_EQ(c.discovery_findings_checked, 2);
    EXPECT_EQ(c.sessions_checked, 3);
    (void)store_discovery_finding(db, discovery("F-WEMA", "third"));
    EXPECT_TRUE(verify_tail(db, "F-WEMA").ok()) << problems_of(db, "F-WEMA");
}

// Several processes create the same new file at once (issue 21 item 10: 4 concurrent imports into a
// new file failed 36 times in 80 with "table aircraft already exists"). Every one must store.
TEST(HostileRecord, SeveralProcessesCreatingOneNewFileAllStore) {
    constexpr int kRounds = 10;
    constexpr int kWriters = 4;
    for (int round = 0; round < kRounds; ++round) {
        const TempDbFile file("_" + std::to_string(round));
        pid_t pids[kWriters];
        for (int w = 0; w < kWriters; ++w) {
            pids[w] = ::fork();
            ASSERT_GE(pids[w], 0);
            if (pids[w] == 0) {
                try {
                    Database db(file.path());
                    (void)store_session(db, session_at("F-WEM" + std::string(1, static_cast<char>('A' + w)), "SN-1", "2026-01-05T08:00:00Z", 0.08));
                } catch (const std::exception& e) {
                    std::cerr << "round " << round << " writer " << w << ": " << e.what() << "\n";
                    ::_exit(1);
                }
                ::_exit(0);
            }
        }
        int failed = 0;
        for (pid_t pid : pids) {
            int status = 0;
            ::waitpid(pid, &status, 0);
            failed += WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
        }
        EXPECT_EQ(failed, 0) << "round " << round << ": writers failed to create or store (stderr above)";
        Database db(file.path());
        EXPECT_EQ(db.schema_version(), 7);
        for (int w = 0; w < kWriters; ++w) {
            const std::string tail = "F-WEM" + std::string(1, static_cast<char>('A' + w));
            EXPECT_EQ(list_test_sessions(db, tail).size(), 1u) << "round " << round << " " << tail;
        }
    }
}

}  // namespace
