// Input that tries to get in, through the command line (issue 12 part 4): device files, FIFOs,
// symbolic links and directories as output paths of every command that writes a file; NaN, inf,
// negative and enormous numbers in options, CSV cells and JSON; SQL, markup, Unicode and very long
// tail numbers. Each must end with a clear error and a non-zero exit (or be handled safely), never
// hang, crash, write through a link or replace a device.
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using ::testing::AnyOf;
using ::testing::HasSubstr;
using emadiag::test::run_cli;

namespace {

class HostileCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag-hostile-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    /// A FIFO nobody reads: a writer that opened it would block (the test would hang, then time out).
    std::string fifo() const {
        const std::string f = p("fifo");
        EXPECT_EQ(::mkfifo(f.c_str(), 0600), 0);
        return f;
    }
    /// A symlink to a file with known content.
    std::string link_to_victim() const {
        std::ofstream(p("victim.txt")) << "precious\n";
        fs::create_symlink(p("victim.txt"), p("link"));
        return p("link");
    }
    std::string victim() const {
        std::ifstream in(p("victim.txt"));
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    fs::path dir_;
};

bool is_char_device(const char* path) {
    struct stat st {};
    return ::lstat(path, &st) == 0 && S_ISCHR(st.st_mode);
}

TEST_F(HostileCli, SimulateRefusesDevicesFifosLinksAndDirectoriesAsOutput) {
    for (const char* dev : {"/dev/null", "/dev/zero"}) {
        const auto r = run_cli(std::string("simulate --sequence dyn --out ") + dev);
        EXPECT_NE(r.exit_code, 0) << r.output;
        EXPECT_THAT(r.output, HasSubstr("is a device file; refusing to write it"));
        EXPECT_TRUE(is_char_device(dev)) << dev << " was replaced";
        EXPECT_FALSE(fs::exists(std::string(dev) + ".part"));
    }
    auto r = run_cli("simulate --out " + fifo());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a FIFO; refusing to write it"));
    r = run_cli("simulate --out " + link_to_victim());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a symbolic link"));
    EXPECT_EQ(victim(), "precious\n");
    r = run_cli("simulate --out " + dir_.string());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a directory"));
    // A link planted at the old fixed temporary name is never opened: the temporary is a new file with
    // a unique name (O_EXCL), renamed into place (issue 21 item 4).
    fs::create_symlink(p("victim.txt"), p("run.csv.part"));
    r = run_cli("simulate --out " + p("run.csv"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(p("run.csv"))));
    EXPECT_TRUE(fs::is_symlink(p("run.csv.part")));
    EXPECT_EQ(victim(), "precious\n");
}

TEST_F(HostileCli, DotDotIsAnOrdinaryPathComponent) {
    fs::create_directories(dir_ / "sub");
    const auto r = run_cli("simulate --out " + p("sub/../run.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::is_regular_file(dir_ / "run.csv"));
}

TEST_F(HostileCli, HistorySimRefusesDevicesFifosAndLinksAsDatabase) {
    const std::string base = "history-sim --tail N123EM --sessions 1 --noise none --db ";
    for (const char* dev : {"/dev/null", "/dev/zero"}) {
        const auto r = run_cli(base + dev);
        EXPECT_NE(r.exit_code, 0);
        EXPECT_THAT(r.output, HasSubstr("maintenance database " + std::string(dev) + " is a device file"));
        EXPECT_TRUE(is_char_device(dev));
        EXPECT_FALSE(fs::exists(std::string(dev) + "-journal"));
    }
    auto r = run_cli(base + fifo());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a FIFO"));
    r = run_cli(base + link_to_victim());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a symbolic link"));
    EXPECT_EQ(victim(), "precious\n");
}

TEST_F(HostileCli, LongRunningWritersCheckTheOutputBeforeWorking) {
    // dataset, train and paper-tables refuse at once rather than after minutes of work.
    for (const std::string& args : {std::string("dataset --count 1000 --out /dev/null"), std::string("paper-tables --out /dev/zero")}) {
        const auto r = run_cli(args);
        EXPECT_NE(r.exit_code, 0) << args;
        EXPECT_THAT(r.output, HasSubstr("is a device file; refusing to write it")) << args;
    }
}

TEST_F(HostileCli, NonFiniteNegativeAndEnormousNumbersInOptionsAreRefused) {
    for (const std::string v : {"nan", "inf", "-inf", "-1", "1e308", "1e999", "0x1p2000"}) {
        auto r = run_cli("simulate --fdj " + v);
        EXPECT_NE(r.exit_code, 0) << "--fdj " << v << ": " << r.output;
        EXPECT_THAT(r.output, AnyOf(HasSubstr("fdj_nm"), HasSubstr("--fdj"))) << v;
        r = run_cli("history-sim --db " + p("h.db") + " --tail N1 --days-between " + v);
        EXPECT_NE(r.exit_code, 0) << "--days-between " << v << ": " << r.output;
        r = run_cli("history-sim --db " + p("h.db") + " --tail N1 --sessions 2 --noise none --fdj-rate-per-100d " + v);
        // -1 and 1e308 per 100 days drive FDJ out of the simulator's range by the second session.
        EXPECT_NE(r.exit_code, 0) << "--fdj-rate-per-100d " << v << ": " << r.output;
        EXPECT_NE(r.exit_code, -1) << "crashed on " << v;
    }
    for (const std::string v : {"-5", "0", "99999999999999999999", "nan", "2.5"}) {
        const auto r = run_cli("history-sim --db " + p("h.db") + " --tail N1 --sessions " + v);
        EXPECT_NE(r.exit_code, 0) << "--sessions " << v;
        EXPECT_NE(r.exit_code, -1) << "crashed on --sessions " << v;
    }
}

TEST_F(HostileCli, NonFiniteAndEnormousNumbersInARunCsv) {
    const auto csv = p("run.csv");
    auto r = run_cli("simulate --case B --sequence dyn --out " + csv);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::ifstream in(csv);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string first = "\n0.00050000000000000001,";  // the first sample row's time
    const auto row = text.find(first);
    ASSERT_NE(row, std::string::npos);
    for (const std::string bad : {"nan", "inf", "-inf", "1e999"}) {
        std::string t = text;
        t.replace(row + 1, first.size() - 2, bad);
        std::ofstream(p("bad.csv")) << t;
        r = run_cli("estimate " + p("bad.csv"));
        EXPECT_NE(r.exit_code, 0) << bad;
        EXPECT_THAT(r.output, HasSubstr("is not a finite number")) << bad;
    }
    // Enormous but finite: no crash, a result or a clear error, never NaN printed as a figure.
    std::string t = text;
    t.replace(row + 1, first.size() - 2, "1e300");
    std::ofstream(p("huge.csv")) << t;
    r = run_cli("estimate --estimator physics " + p("huge.csv"));
    EXPECT_NE(r.exit_code, -1) << r.output;
}

TEST_F(HostileCli, HostileTailNumbersAreRefusedBeforeAnythingIsWritten) {
    const std::vector<std::string> tails = {"\"'; DROP TABLE test_sessions; --\"", "'<script>alert(1)</script>'", "N123\xC3\x89M",
                                            "../../etc/passwd", std::string(100000, 'N'), "''"};
    for (const auto& tail : tails) {
        const auto r = run_cli("history-sim --db " + p("t.db") + " --sessions 1 --noise none --tail " + tail);
        EXPECT_NE(r.exit_code, 0) << tail.substr(0, 40);
        EXPECT_THAT(r.output, HasSubstr("is not valid: use 1 to 16 characters of A-Z, 0-9 and '-'")) << tail.substr(0, 40);
        EXPECT_LT(r.output.size(), 1000u) << "the error echoes the whole tail number";
        EXPECT_FALSE(fs::exists(p("t.db"))) << "a database was created for a refused tail number";
    }
}

}  // namespace
