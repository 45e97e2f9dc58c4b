// Schema version 4 -> 5 (schema/005_sync.sql): the station identity and the sync record are added to
// a file with sessions, which stay as they were; every file gets its own station UUID. (A version-4
// file then takes version 6 too: schema/006, tests in cluster_migration_test.cpp.)
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "older_version_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <unistd.h>

namespace emadiag::db {
namespace {

struct TempFile {
    std::string path = (std::filesystem::temp_directory_path() / ("emadiag_sync_mig_" + std::to_string(::getpid()) + "_" +
                                                                 ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db"))
                           .string();
    TempFile() { std::filesystem::remove(path); }
    ~TempFile() { std::filesystem::remove(path); }
};

StoredTestSession session(const std::string& utc) {
    StoredTestSession s;
    s.tail_number = "N5EM";
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.verdict = "SERVICEABLE";
    s.position = "LH-ELEV";
    s.position_ata = "27-30";
    s.actuator_serial = "SN-1";
    s.findings.push_back({"FDJ_Nm", "physics", 0.08, 0.002, 0.2, "max", "WITHIN", ""});
    return s;
}

std::string uuid_of(Database& db) {
    Statement st(db, "SELECT station_uuid FROM station_identity");
    EXPECT_TRUE(st.step());
    return st.column_text(0);
}

TEST(SyncMigration, AVersion4FileGetsAStationIdentityAndKeepsEverySession) {
    const TempFile newest;
    const std::string v4_path = newest.path + ".v4";
    std::filesystem::remove(v4_path);
    struct Remove {
        std::string path;
        ~Remove() { std::filesystem::remove(path); }
    } const remove_v4{v4_path};
    std::string sha_before;
    {
        Database db(newest.path);
        (void)store_session(db, session("2026-01-01T08:00:00Z"));
        sha_before = store_session(db, session("2026-02-01T08:00:00Z")).content_sha256;
    }
    // The file as schema version 4 left it (schema/001 .. 004, without 005's tables), with those sessions.
    test::write_older_version_copy(newest.path, v4_path, 4);
    {
        test::RawConnection raw(v4_path);
        ASSERT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'station_identity'"), 0);
    }
    Database db(v4_path);
    EXPECT_EQ(db.schema_version(), 7);
    const std::string uuid = uuid_of(db);
    EXPECT_TRUE(std::regex_match(uuid, std::regex("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}"))) << uuid;
    const auto sessions = list_test_sessions(db, "N5EM");
    ASSERT_EQ(sessions.size(), 2U);
    EXPECT_EQ(sessions[1].content_sha256, sha_before);
    EXPECT_TRUE(verify_tail(db, "N5EM").ok());
    Statement none(db, "SELECT count(*) FROM synced_sessions");
    ASSERT_TRUE(none.step());
    EXPECT_EQ(none.column_int(0), 0) << "nothing is synced yet";
    // The sync record is append-only, and a session can be recorded once per server.
    db.exec("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES ('s', 1, 7, '2026-03-01T00:00:00Z')");
    EXPECT_THROW(db.exec("UPDATE synced_sessions SET fleet_session_id = 8"), DbError);
    EXPECT_THROW(db.exec("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES ('s', 1, 9, 'x')"), DbError);
    EXPECT_THROW(db.exec("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES ('s', 99, 9, 'x')"), DbError)
        << "only sessions of this file";
}

TEST(SyncMigration, EveryNewFileIsItsOwnStation) {
    const TempFile a;
    const std::string b = a.path + ".b";
    std::filesystem::remove(b);
    std::string ua, ub;
    {
        Database da(a.path);
        Database db(b);
        ua = uuid_of(da);
        ub = uuid_of(db);
    }
    std::filesystem::remove(b);
    EXPECT_NE(ua, ub);
    Database again(a.path);
    EXPECT_EQ(uuid_of(again), ua) << "the identity is made once";
}

}  // namespace
}  // namespace emadiag::db
