// Issue 21 items 5, 6 and 9 with the real binary: recover refuses a manifest that names a file
// outside its spool directory (and stores the good ones); history-sim is whole or absent when a
// session fails, on SIGINT, SIGTERM and kill -9; verify, report and import see changes made outside
// the tool (an edited installation, a deleted last session with a rewritten chain head, a damaged
// cell, bytes appended to the file).
#include "support/cli_runner.hpp"
#include "support/db_test_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

namespace {

namespace fs = std::filesystem;
using emadiag::test::RawConnection;
using emadiag::test::run_cli;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

class HostileRecordCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::path(EMADIAG_BINARY_DIR) / ("hostile_record_cli_" + std::to_string(::getpid()) + "_" +
                                               ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        db_ = (dir_ / "m.db").string();
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::int64_t sessions(const std::string& tail) {
        if (!fs::exists(db_)) return 0;
        RawConnection raw(db_);
        return raw.query_int("SELECT count(*) FROM test_sessions WHERE tail_number = '" + tail + "'");
    }
    fs::path dir_;
    std::string db_;
};

std::string slurp(const fs::path& p) { return emadiag::test::read_text_file(p.string()); }

// ---- item 6: recover ----

std::string manifest(const std::string& utc, const std::string& log_path) {
    return R"({"format":"emadiag-session-spool-1","tail_number":"N123EM","phase":"pre-flight","started_utc":")" + utc +
           R"(","tool_version":"test","limits_json":"{}","sequences":["dyn"],"logs":[{"sequence":"dyn","attempt":1,"log_path":")" + log_path +
           R"("}],"state":"recording","record_json":"{}"})";
}

TEST_F(HostileRecordCli, RecoverTakesOnlyFilesInsideTheSpoolAndStoresTheGoodManifestsPastTheBadOnes) {
    const std::string secret = "PRIVATE-KEY-0123456789-never-in-the-database";
    const fs::path priv = dir_ / "private.txt";
    std::ofstream(priv) << secret << "\n";
    const fs::path spool = dir_ / "m.db.spool";
    fs::create_directories(spool);
    // The good one: a log cut before the EMA answered (two frames), inside the spool.
    std::ofstream(spool / "good_dyn.log") << "(1795525640.771675) can0 011#0100000000000000\n(1795525640.791645) can0 010#0100000000000000\n";
    fs::create_symlink(priv, spool / "link_dyn.log");
    fs::create_hard_link(priv, spool / "hard_dyn.log");
    ASSERT_EQ(::mkfifo((spool / "fifo_dyn.log").c_str(), 0600), 0);
    const std::vector<std::pair<std::string, std::string>> bad = {
        {"a_absolute.json", priv.string()},      {"b_dotdot.json", "../private.txt"},  {"c_symlink.json", "link_dyn.log"},
        {"d_hardlink.json", "hard_dyn.log"},     {"e_fifo.json", "fifo_dyn.log"},      {"f_subdir.json", "sub/x.log"}};
    int minute = 10;
    for (const auto& [name, log] : bad) std::ofstream(spool / name) << manifest("2026-11-24T10:" + std::to_string(minute++) + ":00Z", log);
    std::ofstream(spool / "g_not_json.json") << "{ not json";
    std::ofstream(spool / "z_good.json") << manifest("2026-11-24T11:00:00Z", "good_dyn.log");

    const auto r = run_cli("recover --db " + db_);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("1 spooled session(s) stored"));
    EXPECT_THAT(r.output, HasSubstr("7 refused (left in place)"));
    EXPECT_THAT(r.output, HasSubstr("a_absolute.json: log_path \"" + priv.string() + "\" is an absolute path"));
    EXPECT_THAT(r.output, HasSubstr("b_dotdot.json: log_path \"../private.txt\" is not a plain file name"));
    EXPECT_THAT(r.output, HasSubstr("c_symlink.json: log_path \"link_dyn.log\" is a symbolic link"));
    EXPECT_THAT(r.output, HasSubstr("d_hardlink.json: log_path \"hard_dyn.log\" has 2 hard links"));
    EXPECT_THAT(r.output, HasSubstr("e_fifo.json: log_path \"fifo_dyn.log\" is not a regular file"));
    EXPECT_THAT(r.output, HasSubstr("f_subdir.json: log_path \"sub/x.log\" is not a plain file name"));
    EXPECT_THAT(r.output, HasSubstr("g_not_json.json"));
    for (const auto& [name, log] : bad) EXPECT_TRUE(fs::exists(spool / name)) << name << " is left in place";
    EXPECT_FALSE(fs::exists(spool / "z_good.json")) << "the good manifest is stored and removed";
    EXPECT_EQ(sessions("N123EM"), 1);
    EXPECT_THAT(slurp(db_), Not(HasSubstr(secret))) << "the private file's bytes are not in the database";
}

// ---- item 9: history-sim is one transaction ----

TEST_F(HostileRecordCli, HistorySimThatFailsAtSessionSevenStoresNothing) {
    ASSERT_EQ(run_cli("history-sim --db " + db_ + " --tail N1EM --sessions 2 --noise none").exit_code, 0);
    const std::string before = slurp(db_);
    // FDJ falls 0.015 N m per session from 0.08: session 7's is negative, outside the model's range.
    const auto r = run_cli("history-sim --db " + db_ + " --tail N1EM --sessions 12 --days-between 30 --fdj-rate-per-100d -0.05 --noise none");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("session 7 of 12"), HasSubstr("nothing was stored"), HasSubstr("fdj_nm")));
    EXPECT_THAT(r.output, Not(HasSubstr("  session 3 ")));
    EXPECT_EQ(sessions("N1EM"), 2) << "the earlier history is kept, nothing of the failed one";
    const auto v = run_cli("verify --db " + db_ + " --tail N1EM");
    EXPECT_EQ(v.exit_code, 0) << v.output;
}

/// Starts `emadiag ARGS` with its stdout on a pipe, reads until `line` appears, sends `sig`, waits.
/// Returns the exit status (WIFEXITED ...) and the output.
std::pair<int, std::string> signal_after(const std::string& args, const std::string& line, int sig, std::chrono::milliseconds delay) {
    int out[2];
    if (::pipe(out) != 0) return {-1, "pipe failed"};
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::dup2(out[1], 1);
        ::dup2(out[1], 2);
        ::close(out[0]);
        ::close(out[1]);
        ::execl("/bin/sh", "sh", "-c", ("exec " + std::string(EMADIAG_CLI) + " " + args).c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    ::close(out[1]);
    std::string text;
    char buf[4096];
    bool sent = false;
    ssize_t n;
    while ((n = ::read(out[0], buf, sizeof buf)) > 0) {
        text.append(buf, static_cast<std::size_t>(n));
        if (!sent && text.find(line) != std::string::npos) {
            std::this_thread::sleep_for(delay);  // into the middle of the history: any moment gives the same result
            ::kill(pid, sig);
            sent = true;
        }
    }
    ::close(out[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (!sent) text += "\n(the signal was never sent)";
    return {status, text};
}

TEST_F(HostileRecordCli, HistorySimInterruptedBySigintSigtermOrKillStoresNothing) {
    ASSERT_EQ(run_cli("history-sim --db " + db_ + " --tail N1EM --sessions 2 --noise none").exit_code, 0);
    const std::string args = "history-sim --db " + db_ + " --tail N2EM --sessions 1000 --noise none";
    for (const int sig : {SIGINT, SIGTERM}) {
        const auto [status, text] = signal_after(args, "emadiag history-sim:", sig, std::chrono::milliseconds(800));
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << "signal " << sig << ": " << text;
        EXPECT_THAT(text, AllOf(HasSubstr("interrupted (SIGINT or SIGTERM)"), HasSubstr("nothing was stored"))) << "signal " << sig;
        EXPECT_EQ(sessions("N2EM"), 0) << "signal " << sig;
    }
    const auto [status, text] = signal_after(args, "emadiag history-sim:", SIGKILL, std::chrono::milliseconds(800));
    EXPECT_TRUE(WIFSIGNALED(status)) << text;
    EXPECT_EQ(sessions("N2EM"), 0) << "kill -9: the hot journal is rolled back, no partial history";
    EXPECT_EQ(sessions("N1EM"), 2);
    const auto v = run_cli("verify --db " + db_ + " --tail N1EM");
    EXPECT_EQ(v.exit_code, 0) << v.output;
}

// ---- item 5: changes made outside the tool ----

class HostileRecordChain : public HostileRecordCli {
protected:
    void SetUp() override {
        HostileRecordCli::SetUp();
        for (const std::string args : {"--serial SN-1 --sessions 2 --cycles 100 --cycles-per-day 4",
                                       "--serial SN-2 --sessions 2 --start-utc 2026-06-01T08:00:00Z"}) {
            const auto r = run_cli("history-sim --db " + db_ + " --tail N1EM --position LH-ELEV --noise none " + args);
            ASSERT_EQ(r.exit_code, 0) << r.output;
        }
        csv_ = (dir_ / "flight.csv").string();
        ASSERT_EQ(run_cli("simulate --case B --noise typical --seed 5 --out " + csv_).exit_code, 0);
    }
    std::string import(const std::string& utc, int* exit_code) {
        const auto r = run_cli("import " + csv_ + " --db " + db_ + " --tail N1EM --position LH-ELEV --serial SN-2 --utc " + utc);
        *exit_code = r.exit_code;
        return r.output;
    }
    std::string csv_;
};

TEST_F(HostileRecordChain, AnEditedInstallationFailsVerifyReportSaysSoAndImportRefuses) {
    {
        RawConnection raw(db_);
        raw.exec("DROP TRIGGER installations_no_update; UPDATE installations SET to_serial = 'FAKE-1' WHERE to_serial = 'SN-2'");
    }
    auto r = run_cli("verify --db " + db_ + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 5) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("RECORD CHANGED OUTSIDE THE TOOL"), HasSubstr("SN-1 -> FAKE-1"), HasSubstr("SN-1 -> SN-2")));
    r = run_cli("report --db " + db_ + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 5) << r.output;
    EXPECT_THAT(r.output, HasSubstr("# RECORD CHANGED OR DAMAGED OUTSIDE THE TOOL: the hash chain of N1EM is broken"));
    r = run_cli("report --db " + db_ + " --tail N1EM --format json", false);
    EXPECT_THAT(r.output, HasSubstr("\"record_integrity\""));
    int rc = 0;
    const std::string out = import("2026-08-01T00:00:00Z", &rc);
    EXPECT_EQ(rc, 1) << out;
    EXPECT_THAT(out, AllOf(HasSubstr("tail N1EM: its record was changed outside the tool"), HasSubstr("nothing is appended to a broken chain")));
    EXPECT_EQ(sessions("N1EM"), 4);
}

TEST_F(HostileRecordChain, TheLastSessionDeletedWithARewrittenChainHeadIsFoundThroughTheAnchorAndTheExpectedHead) {
    auto r = run_cli("verify --db " + db_ + " --tail N1EM");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto at = r.output.find("head ");
    ASSERT_NE(at, std::string::npos);
    const std::string head = r.output.substr(at + 5, 64);
    {
        RawConnection raw(db_);
        raw.exec("PRAGMA foreign_keys = OFF; DROP TRIGGER test_sessions_no_delete; DROP TRIGGER findings_no_delete; DROP TRIGGER runs_no_delete; "
                 "DROP TRIGGER samples_no_delete; DROP TRIGGER raw_logs_no_delete; DROP TRIGGER estimates_no_delete; "
                 "DROP TRIGGER session_artifacts_no_delete; "
                 "DELETE FROM samples WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 4); "
                 "DELETE FROM raw_logs WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 4); "
                 "DELETE FROM estimates WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 4); "
                 "DELETE FROM runs WHERE session_id = 4; DELETE FROM findings WHERE session_id = 4; "
                 "DELETE FROM session_artifacts WHERE session_id = 4; DELETE FROM test_sessions WHERE session_id = 4; "
                 "UPDATE chain_heads SET session_id = 3, sessions = 3, content_sha256 = (SELECT content_sha256 FROM test_sessions WHERE session_id = 3)");
    }
    // The database alone is consistent (what verify said before: "3 sessions, hash chain intact").
    r = run_cli("verify --db " + db_ + " --tail N1EM --anchor " + (dir_ / "no-such-anchor").string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("no anchor file"));
    // The anchor every store appended to shows the deletion; so does the head noted at the last export.
    r = run_cli("verify --db " + db_ + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 5) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("records 4 sessions ending at"), HasSubstr("the database holds 3: sessions were removed outside the tool")));
    r = run_cli("verify --db " + db_ + " --tail N1EM --anchor " + (dir_ / "no-such-anchor").string() + " --expect-head " + head);
    EXPECT_EQ(r.exit_code, 5) << r.output;
    EXPECT_THAT(r.output, HasSubstr("the expected head " + head.substr(0, 16) + "... is not in the chain"));
    // An import goes on (a store checks the database's own chain; a restored backup is older than
    // its anchor too); the removal still shows afterwards.
    int rc = 0;
    const std::string out = import("2026-08-01T00:00:00Z", &rc);
    EXPECT_EQ(rc, 0) << out;
    r = run_cli("verify --db " + db_ + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 5) << r.output;
    EXPECT_THAT(r.output, HasSubstr("the chain was rewritten outside the tool"));
}

TEST_F(HostileRecordChain, DamageInsideACellIsSaidByReportAndRefusedByImport) {
    {
        RawConnection raw(db_);
        raw.exec("DROP TRIGGER findings_no_update; UPDATE findings SET value = value + 0.01 WHERE session_id = 2");
    }
    auto r = run_cli("report --db " + db_ + " --tail N1EM --format csv");
    EXPECT_EQ(r.exit_code, 5);
    EXPECT_THAT(r.output, HasSubstr("the first: session 2 ("));
    int rc = 0;
    const std::string out = import("2026-08-01T00:00:00Z", &rc);
    EXPECT_EQ(rc, 1) << out;
    EXPECT_THAT(out, AllOf(HasSubstr("tail N1EM"), HasSubstr("session 2 ("), HasSubstr("nothing was stored")));
    EXPECT_EQ(sessions("N1EM"), 4);
}

TEST_F(HostileRecordChain, BytesAppendedToTheFileAreRefusedWithoutModifyingIt) {
    {
        std::ofstream out(db_, std::ios::binary | std::ios::app);
        std::mt19937_64 rng(21);
        for (int i = 0; i < 5000; ++i) out.put(static_cast<char>(rng() & 0xff));
    }
    const std::string before = slurp(db_);
    for (const std::string cmd : {"verify --tail N1EM", "report --tail N1EM"}) {
        const auto r = run_cli(cmd + " --db " + db_);
        EXPECT_NE(r.exit_code, 0) << cmd;
        EXPECT_THAT(r.output, HasSubstr("5000 bytes after the last page were not written by SQLite")) << cmd;
    }
    int rc = 0;
    EXPECT_THAT(import("2026-08-01T00:00:00Z", &rc), HasSubstr("5000 bytes after the last page"));
    EXPECT_NE(rc, 0);
    EXPECT_EQ(slurp(db_), before) << "the file is left untouched";
}

}  // namespace
