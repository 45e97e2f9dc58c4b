// Database::Access::ReadOnly (issue 21 item 15): the commands that only read (report, trend,
// fleet, verify, export) open the file with SQLITE_OPEN_READONLY, so a database on read-only media
// can be read; such an open never creates a file, refuses a directory by name, and cannot write.
// The whole path as an unprivileged user on a 0444 file: tests/src/cli/hostile_bounds_cli_test.cpp.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "older_version_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>

namespace fs = std::filesystem;
using emadiag::db::Database;
using emadiag::db::DbError;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {

class HostileReadOnlyDb : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag-rodb-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    fs::path dir_;
};

Database read_only(const std::string& path) {
    return Database(path, Database::kDefaultBusyTimeoutMs, true, Database::Access::ReadOnly);
}

TEST_F(HostileReadOnlyDb, AMissingFileIsNotCreated) {
    EXPECT_THAT([&] { (void)read_only(p("none.db")); }, ThrowsMessage<DbError>(HasSubstr("none.db does not exist")));
    EXPECT_FALSE(fs::exists(p("none.db")));
}

TEST_F(HostileReadOnlyDb, ADirectoryIsNamedAsSuch) {
    EXPECT_THAT([&] { (void)read_only(dir_.string()); },
                ThrowsMessage<DbError>(HasSubstr(dir_.string() + " is a directory, not a database file")));
}

TEST_F(HostileReadOnlyDb, ItReadsAndCannotWrite) {
    { Database made(p("r.db")); }
    const auto size = fs::file_size(p("r.db"));
    Database db = read_only(p("r.db"));
    EXPECT_GT(db.schema_version(), 0);
    EXPECT_THROW(db.exec("CREATE TABLE intruder (x INTEGER)"), DbError);
    EXPECT_EQ(fs::file_size(p("r.db")), size);
}

TEST_F(HostileReadOnlyDb, AnOlderFileIsMigratedWhereItCanBeWrittenAndNamedWhereItCannot) {
    int newest = 0;
    {
        Database made(p("new.db"));
        newest = made.schema_version();
    }
    emadiag::test::write_older_version_copy(p("new.db"), p("old.db"), 5);
    {
        Database db = read_only(p("old.db"));  // writable: migrated as before, then read
        EXPECT_EQ(db.schema_version(), newest);
    }
    emadiag::test::write_older_version_copy(p("new.db"), p("old2.db"), 5);
    fs::permissions(p("old2.db"), fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
    fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec);
    // root may write any file: the read-only case runs as nobody, in a child process.
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(4);
        try {
            (void)read_only(p("old2.db"));
            ::_exit(1);
        } catch (const DbError& e) {
            ::_exit(std::string(e.what()).find("has schema version 5, not this emadiag's") != std::string::npos ? 0 : 2);
        } catch (...) {
            ::_exit(3);
        }
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << "1: opened, 2: other message, 3: other exception, 4: setuid failed";
}

}  // namespace
