// Issue 21 items 4, 7 and 8 with the real binary: outputs that would destroy a record (the database,
// an input, a device, a FIFO, a link, a planted link at a temporary name, a full disk), forged lines
// and live formulas (control characters in names, stored fields and file names; spreadsheet
// formulas in CSV), and passwords in URIs. Each test reproduces what the old code got wrong.
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using emadiag::test::CliResult;

namespace {

/// `emadiag ARGS` run by bash (ARGS may use $'\n' quoting) in `cwd` (when given) under `timeout` (a
/// FIFO that blocked would end with 124), with `env` ("NAME=value ..." or empty); stdout and stderr merged.
CliResult run_in(const std::string& args, const std::string& cwd = "", const std::string& env = "") {
    const std::string script = (fs::temp_directory_path() / ("emadiag-hostile-out-cmd-" + std::to_string(::getpid()) + ".sh")).string();
    std::ofstream(script, std::ios::binary) << (cwd.empty() ? "" : "cd '" + cwd + "' || exit 99\n") << "exec env " << env << " timeout 60 "
                                            << EMADIAG_CLI << " " << args << " 2>&1\n";
    return emadiag::test::run_shell("bash " + script);
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool is_char_device(const std::string& path) {
    struct stat st {};
    return ::lstat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

/// Lines of `text` that begin with `prefix` (a forged line would).
int lines_starting_with(const std::string& text, const std::string& prefix) {
    int n = 0;
    std::size_t at = 0;
    while (at < text.size()) {
        if (text.compare(at, prefix.size(), prefix) == 0) ++n;
        const auto nl = text.find('\n', at);
        if (nl == std::string::npos) break;
        at = nl + 1;
    }
    return n;
}

constexpr const char* kTail = "N100";

class HostileOutput : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("emadiag-hostile-out-" + std::to_string(::getpid()) + "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    /// A maintenance database with two sessions of N100 LH-ELEV.
    std::string make_db() const {
        const auto r = run_in("history-sim --db " + p("hh.db") + " --tail " + kTail + " --position LH-ELEV --sessions 2 --noise none");
        EXPECT_EQ(r.exit_code, 0) << r.output;
        return p("hh.db");
    }
    std::string make_run(const std::string& name = "in.csv") const {
        const auto r = run_in("simulate --out " + p(name));
        EXPECT_EQ(r.exit_code, 0) << r.output;
        return p(name);
    }
    /// SQL run by the sqlite3 shell (scripts/setup.sh installs it): changes made outside the tool.
    static void sql(const std::string& db, const std::string& statements) {
        const std::string cmd = "sqlite3 '" + db + "' \"" + statements + "\" 2>&1";
        ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    }
    std::set<std::string> names(const std::string& sub = "") const {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(sub.empty() ? dir_ : dir_ / sub)) out.insert(e.path().filename().string());
        return out;
    }
    fs::path dir_;
};

// ---- item 4: outputs that destroy records ----------------------------------------------------------

TEST_F(HostileOutput, ReportTrendFleetAndExportRefuseTheirDatabaseAsOutput) {
    const std::string db = make_db();
    const std::string before = slurp(db);
    for (const std::string& cmd : std::vector<std::string>{"report --tail N100", "trend --tail N100", "fleet", "export --tail N100"}) {
        for (const std::string& out : std::vector<std::string>{db, db + "-journal", db + "-wal", p("./hh.db")}) {
            const auto r = run_in(cmd + " --db " + db + " --out " + out);
            EXPECT_NE(r.exit_code, 0) << cmd << " --out " << out << ": " << r.output;
            EXPECT_THAT(r.output, HasSubstr("the maintenance database")) << cmd;
        }
    }
    EXPECT_EQ(slurp(db), before) << "the database was changed";
    EXPECT_FALSE(fs::exists(db + "-wal"));
    const auto r = run_in(std::string("verify --db ") + db + " --tail " + kTail);
    EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST_F(HostileOutput, ReportTrendFleetAndExportRefuseDevicesFifosAndLinks) {
    const std::string db = make_db();
    std::ofstream(p("victim.txt")) << "precious\n";
    fs::create_symlink(p("victim.txt"), p("link"));
    ASSERT_EQ(::mkfifo(p("fifo").c_str(), 0600), 0);
    for (const std::string& cmd : std::vector<std::string>{"report --tail N100", "trend --tail N100", "fleet", "export --tail N100"}) {
        auto r = run_in(cmd + " --db " + db + " --out /dev/full");
        EXPECT_NE(r.exit_code, 0) << cmd;
        EXPECT_THAT(r.output, HasSubstr("/dev/full is a device file")) << cmd;
        EXPECT_TRUE(is_char_device("/dev/full")) << cmd << " replaced /dev/full";
        r = run_in(cmd + " --db " + db + " --out " + p("fifo"));
        EXPECT_NE(r.exit_code, 124) << cmd << " blocked on the FIFO";
        EXPECT_THAT(r.output, HasSubstr("is a FIFO")) << cmd;
        r = run_in(cmd + " --db " + db + " --out " + p("link"));
        EXPECT_NE(r.exit_code, 0) << cmd;
        EXPECT_THAT(r.output, HasSubstr("is a symbolic link")) << cmd;
        EXPECT_EQ(slurp(p("victim.txt")), "precious\n") << cmd << " wrote through the link";
        EXPECT_TRUE(fs::is_symlink(p("link")));
    }
    // hh.db.anchor: the chain heads every store appends to (docs/record-format.md), not an output.
    EXPECT_EQ(names(), (std::set<std::string>{"hh.db", "hh.db.anchor", "victim.txt", "link", "fifo"}));
}

TEST_F(HostileOutput, APlantedLinkAtTheOldTemporaryNameIsNotFollowed) {
    const std::string db = make_db();
    std::ofstream(p("victim.txt")) << "precious\n";
    fs::create_symlink(p("victim.txt"), p("rep.txt.tmp"));
    const auto r = run_in("report --db " + db + " --tail N100 --out " + p("rep.txt"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(slurp(p("victim.txt")), "precious\n");
    EXPECT_THAT(slurp(p("rep.txt")), HasSubstr("emadiag report: tail N100"));
    EXPECT_EQ(names(), (std::set<std::string>{"hh.db", "hh.db.anchor", "victim.txt", "rep.txt.tmp", "rep.txt"})) << "a temporary file was left";
}

TEST_F(HostileOutput, DiscoverRefusesItsInputAsOutputAndNeverBlocksOnAFifo) {
    const std::string run = make_run();
    const std::string before = slurp(run);
    for (const std::string opt : {"--out-model", "--out-params", "--plot"}) {
        const auto r = run_in("discover " + run + " " + opt + " " + p("./in.csv"));
        EXPECT_NE(r.exit_code, 0) << opt;
        EXPECT_THAT(r.output, HasSubstr(opt + " " + p("./in.csv") + " is an input of this command")) << opt;
    }
    EXPECT_EQ(slurp(run), before) << "discover wrote over its input";
    std::ofstream(p("victim.txt")) << "precious\n";
    fs::create_symlink(p("victim.txt"), p("plot.svg"));
    auto r = run_in("discover " + run + " --plot " + p("plot.svg"));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a symbolic link"));
    EXPECT_EQ(slurp(p("victim.txt")), "precious\n");
    ASSERT_EQ(::mkfifo(p("fifo").c_str(), 0600), 0);
    r = run_in("discover " + run + " --plot " + p("fifo"));
    EXPECT_NE(r.exit_code, 124) << "discover --plot FIFO blocked";
    EXPECT_THAT(r.output, HasSubstr("--plot " + p("fifo") + " is a FIFO"));
    r = run_in("discover " + run + " --out-model " + p("m.json") + " --out-params " + p("m.json"));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is also the --out-model output"));
}

TEST_F(HostileOutput, TrainRefusesItsDatasetAsOutput) {
    auto r = run_in("dataset --count 12 --out " + p("ds.bin"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string before = slurp(p("ds.bin"));
    r = run_in("train --dataset " + p("ds.bin") + " --out " + p("ds.bin") + " --max-epochs 2 --neurons 3 --timesteps 50");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is an input of this command"));
    EXPECT_EQ(slurp(p("ds.bin")), before);
}

/// A directory where every write fails with ENOSPC: a full 256 kB tmpfs when the test runs as root
/// and may mount (CI), else the output helper's fault hook (EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES).
/// Which one ran is printed and recorded; neither is skipped.
class FullDisk {
public:
    explicit FullDisk(const fs::path& dir) : dir_(dir) {
        fs::create_directories(dir_);
        if (::geteuid() == 0 && ::mount("tmpfs", dir_.c_str(), "tmpfs", 0, "size=256k") == 0) {
            mounted_ = true;
            std::ofstream fill(dir_ / "filler", std::ios::binary);
            const std::string block(4096, 'x');
            while (fill.write(block.data(), static_cast<std::streamsize>(block.size())) && fill.flush()) {
            }
        } else {
            env_ = "EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES=0";
        }
        std::cout << "full disk: " << (mounted_ ? "a full tmpfs" : "the fault hook (not root, or mount refused)") << '\n';
        ::testing::Test::RecordProperty("full_disk", mounted_ ? "tmpfs" : "fault hook");
    }
    ~FullDisk() {
        if (mounted_) ::umount(dir_.c_str());
    }
    [[nodiscard]] const std::string& env() const { return env_; }
    [[nodiscard]] std::set<std::string> names() const {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(dir_))
            if (e.path().filename() != "filler") out.insert(e.path().filename().string());
        return out;
    }
    [[nodiscard]] std::string p(const std::string& name) const { return (dir_ / name).string(); }

private:
    fs::path dir_;
    bool mounted_ = false;
    std::string env_;
};

TEST_F(HostileOutput, AFullDiskLeavesNoPartialOrEmptyOutput) {
    const std::string run = make_run();
    ASSERT_EQ(run_in("dataset --count 12 --out " + p("ds.bin")).exit_code, 0);
    const std::string db = make_db();
    const FullDisk full(dir_ / "full");
    std::ofstream(full.p("old.txt")) << "";  // may be empty on a full tmpfs: then it must stay empty, not vanish
    const std::vector<std::string> commands = {
        "simulate --out " + full.p("run.csv"),
        "dataset --count 12 --out " + full.p("ds.bin"),
        "train --dataset " + p("ds.bin") + " --out " + full.p("model.json") + " --max-epochs 2 --neurons 3 --timesteps 50",
        "discover " + run + " --max-effects 1 --out-model " + full.p("am.json"),
        "discover " + run + " --max-effects 1 --out-params " + full.p("params.json"),
        "discover " + run + " --max-effects 1 --plot " + full.p("plot.svg"),
        "report --db " + db + " --tail N100 --out " + full.p("old.txt"),
        "fleet --db " + db + " --format csv --out " + full.p("fleet.csv"),
        "export --db " + db + " --tail N100 --out " + full.p("export.json"),
    };
    for (const auto& cmd : commands) {
        const auto r = run_in(cmd, "", full.env());
        EXPECT_NE(r.exit_code, 0) << cmd << ": " << r.output;
        EXPECT_THAT(r.output, HasSubstr("No space left on device")) << cmd;
        EXPECT_THAT(r.output, HasSubstr(dir_.string() + "/full/")) << cmd << ": the error names the path";
        EXPECT_EQ(full.names(), std::set<std::string>{"old.txt"}) << cmd << " left a partial, empty or temporary file";
    }
    EXPECT_EQ(slurp(full.p("old.txt")), "");
}

TEST_F(HostileOutput, AWriteThatFailsHalfWayLeavesNoPartFile) {
    // The fault hook after 100 kB: simulate's run CSV (about 150 kB) is cut in the middle.
    std::ofstream(p("run.csv")) << "old run\n";
    const auto r = run_in("simulate --out " + p("run.csv"), "", "EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES=100000");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, AllOf(HasSubstr("run CSV " + p("run.csv")), HasSubstr("No space left on device")));
    EXPECT_EQ(slurp(p("run.csv")), "old run\n");
    EXPECT_EQ(names(), std::set<std::string>{"run.csv"});
}

// ---- item 7: forged lines and live formulas ------------------------------------------------------

TEST_F(HostileOutput, ControlCharactersAndHugeNamesAreRefusedAtTheEdge) {
    const std::string run = make_run();
    const std::string base = "import " + run + " --tail N100 --position LH-ELEV --utc 2026-01-01T00:00:00Z --db " + p("t.db") + " ";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"--technician $'Bob\\nVERDICT: SERVICEABLE'", "--technician: character 4 is the control character U+000A"},
        {"--technician Bob --certificate $'C1\\nVERDICT: SERVICEABLE'", "--certificate: character 3 is the control character U+000A"},
        {"--operator $'OP\\x1b[2J'", "--operator: character 3 is the control character U+001B"},
        {"--serial $'SN\\r\\nVERDICT: SERVICEABLE'", "--serial: character 3 is the control character U+000D"},
        {"--serial " + std::string(100000, 'N'), "--serial: 100000 bytes is longer than the limit of 128 characters"},
    };
    for (const auto& [opt, message] : cases) {
        const auto r = run_in(base + opt);
        EXPECT_NE(r.exit_code, 0) << opt.substr(0, 60);
        EXPECT_THAT(r.output, HasSubstr(message)) << opt.substr(0, 60);
        EXPECT_LT(r.output.size(), 600u) << "the error echoes the value";
        EXPECT_FALSE(fs::exists(p("t.db"))) << "stored despite " << opt.substr(0, 60);
    }
    const auto r = run_in("history-sim --db " + p("t.db") + " --tail N100 --sessions 1 --noise none --serial $'SN\\nVERDICT: SERVICEABLE'");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("--serial: character 3 is the control character U+000A"));
    EXPECT_FALSE(fs::exists(p("t.db")));
}

TEST_F(HostileOutput, StoredControlCharactersAreEscapedInReportAndFleet) {
    // Fields changed outside the tool (or stored by an older version): a report shows them escaped.
    const std::string db = make_db();
    sql(db, "UPDATE position_status SET actuator_serial = 'SN1' || char(10) || 'VERDICT: SERVICEABLE' || char(27) || '[2J';"
            "DROP TRIGGER test_sessions_no_update;"
            "UPDATE test_sessions SET technician_name = 'Bob' || char(10) || 'VERDICT: SERVICEABLE' || char(27) || ']0;x' || char(7),"
            " technician_certificate = 'C' || char(13) || 'VERDICT: SERVICEABLE';");
    for (const std::string& cmd : std::vector<std::string>{"report --tail N100", "fleet", "report --tail N100 --format csv", "fleet --format csv"}) {
        const auto r = run_in(cmd + " --db " + db);
        // The sessions were changed outside the tool: report says so and exits 5 (verify's code);
        // fleet lists what is there. Either way every stored string is printed escaped.
        ASSERT_EQ(r.exit_code, cmd.rfind("report", 0) == 0 ? 5 : 0) << cmd << ": " << r.output;
        EXPECT_EQ(lines_starting_with(r.output, "VERDICT"), 0) << cmd << " printed a forged line:\n" << r.output;
        EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << cmd << " echoed an escape sequence";
        EXPECT_EQ(r.output.find('\r'), std::string::npos) << cmd;
        EXPECT_EQ(r.output.find('\a'), std::string::npos) << cmd;
    }
    EXPECT_THAT(run_in("report --tail N100 --db " + db).output, HasSubstr("Bob\\x0aVERDICT: SERVICEABLE\\x1b]0;x\\x07 (C\\x0dVERDICT"));
    EXPECT_THAT(run_in("fleet --db " + db).output, HasSubstr("SN1\\x0aVERDICT: SERVICEABLE\\x1b[2J"));
}

TEST_F(HostileOutput, EscapeSequencesInFileNamesAndRunMetadataAreNotEchoedRaw) {
    const std::string run = make_run();
    // A file name with an escape sequence, in estimate's report and in an error message.
    const std::string evil = p("run\x1b[31m.csv");
    fs::copy_file(run, evil);
    auto r = run_in("estimate $'" + p("run\\x1b[31m.csv") + "'");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output;
    EXPECT_THAT(r.output, HasSubstr("run\\x1b[31m.csv"));
    r = run_in("estimate $'" + p("missing\\x1b]0;owned\\x07.csv") + "'");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output;
    // Run metadata and a CSV header cell with escape sequences.
    std::string text = slurp(run);
    text.insert(0, "# operator_note=\x1b[2J\x1b[Hall good\n");
    const auto header = text.find("t_s,current_A");
    ASSERT_NE(header, std::string::npos);
    text.insert(header, "bogus\x1b[5m,");
    std::ofstream(p("meta.csv"), std::ios::binary) << text;
    r = run_in("estimate " + p("meta.csv"));
    EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output;
}

TEST_F(HostileOutput, FormulasAreNeutralisedInFleetReportAndExportCsv) {
    const std::string db = make_db();
    const auto imp = run_in("import " + make_run() + " --tail N100 --position LH-ELEV --utc 2026-03-01T00:00:00Z --db " + db +
                            " --serial '=HYPERLINK(\"http://evil.example/x\",\"open\")' --technician '@SUM(A1)' --operator '+1+cmd'");
    ASSERT_EQ(imp.exit_code, 0) << imp.output;
    sql(db, "UPDATE position_status SET actuator_serial = '=HYPERLINK(1)';");
    const auto fleet = run_in("fleet --format csv --db " + db);
    ASSERT_EQ(fleet.exit_code, 0) << fleet.output;
    EXPECT_THAT(fleet.output, HasSubstr(",'=HYPERLINK(1),"));
    EXPECT_THAT(fleet.output, Not(HasSubstr(",=HYPERLINK"))) << fleet.output;
    EXPECT_THAT(fleet.output, Not(HasSubstr(",\"=HYPERLINK"))) << fleet.output;
    const auto exp = run_in("export --format csv --db " + db + " --tail N100 --out " + p("exp"));
    ASSERT_EQ(exp.exit_code, 0) << exp.output;
    const std::string sessions = slurp(p("exp/sessions.csv"));
    EXPECT_THAT(sessions, HasSubstr("\"'=HYPERLINK("));
    EXPECT_THAT(sessions, HasSubstr(",'@SUM(A1),"));
    EXPECT_THAT(sessions, HasSubstr(",'+1+cmd,"));
    for (const auto& f : fs::directory_iterator(p("exp"))) {
        const std::string t = slurp(f.path().string());
        EXPECT_THAT(t, Not(HasSubstr(",=HYPERLINK"))) << f.path();
        EXPECT_THAT(t, Not(HasSubstr(",\"=HYPERLINK"))) << f.path();
    }
}

// ---- item 8: passwords in URIs -------------------------------------------------------------------

TEST_F(HostileOutput, AMalformedUriIsNeverPrintedWithItsPassword) {
    const std::string db = make_db();
    const std::string uri = "'postgresql://alice:S3cretPW@[::1:5432/fleet'";
    for (const std::string& cmd : std::vector<std::string>{"report --tail N100 --db " + uri, "trend --tail N100 --db " + uri, "fleet --db " + uri,
                                   "sync --db " + db + " --to " + uri, "fleet-server --to " + uri,
                                   "report --tail N100 --db " + db + " postgresql://bob:Pw2Secret@h/x"}) {
        const auto r = run_in(cmd);
        EXPECT_NE(r.exit_code, 0) << cmd;
        EXPECT_THAT(r.output, Not(HasSubstr("S3cretPW"))) << cmd << ": " << r.output;
        EXPECT_THAT(r.output, Not(HasSubstr("Pw2Secret"))) << cmd << ": " << r.output;
    }
}

TEST_F(HostileOutput, SqliteOnlyCommandsRefuseAUriAndCreateNothing) {
    // The directories a URI would name as a relative path exist: the old code created a SQLite file there.
    fs::create_directories(dir_ / "postgresql:" / "alice:S3cretPW@localhost");
    const std::string run = make_run();
    const std::string uri = "postgresql://alice:S3cretPW@localhost/fleet";
    for (const std::string& cmd : std::vector<std::string>{"import " + run + " --tail N100 --position LH-ELEV --utc 2026-01-01T00:00:00Z --db " + uri,
                                   "verify --tail N100 --db " + uri, "export --tail N100 --db " + uri, "sync --db " + uri + " --to postgresql://h/db",
                                   "history-sim --tail N100 --sessions 1 --noise none --db " + uri, "recover --db " + uri,
                                   "test-run --bus socketcan:vcan-none --tail N100 --db " + uri,
                                   "discover --tail N100 --db " + uri}) {
        const auto r = run_in(cmd, dir_.string());
        EXPECT_NE(r.exit_code, 0) << cmd;
        EXPECT_THAT(r.output, HasSubstr("SQLite file only")) << cmd << ": " << r.output;
        EXPECT_THAT(r.output, Not(HasSubstr("S3cretPW"))) << cmd << ": " << r.output;
        EXPECT_TRUE(fs::is_empty(dir_ / "postgresql:" / "alice:S3cretPW@localhost")) << cmd << " created a file at the URI's path";
    }
}

}  // namespace
