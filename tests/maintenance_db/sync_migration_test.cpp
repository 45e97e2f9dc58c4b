// Schema version 4 -> 5 (schema/005_sync.sql): the station identity and the sync record are added to
// a file with sessions, which stay as they were; every file gets its own station UUID.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/test_session_store.hpp"

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
    const TempFile file;
    std::string sha_before;
    {
        Database db(file.path);
        (void)store_session(db, session("2026-01-01T08:00:00Z"));
        sha_before = store_session(db, session("2026-02-01T08:00:00Z")).content_sha256;
        // Back to the file as schema version 4 left it: without 005's tables.
        db.exec("DROP TABLE synced_sessions; DROP TABLE synced_discovery_findings; DROP TABLE station_identity; PRAGMA user_version = 4");
    }
    Database db(file.path);
    EXPECT_EQ(db.schema_version(), 5);
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
