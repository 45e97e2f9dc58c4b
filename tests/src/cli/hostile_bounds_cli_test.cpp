// Bounds and clear refusals through the command line (issue 21 items 11 to 15): train's options and
// datasets, numbers that used to wrap or clamp, history-sim's plan checked before anything is
// stored, bounded reads (positions file, run file for import), and messages that say what is wrong
// (NUL bytes, UTF-16, a directory as --db, an over-long --term, a database on read-only media).
// Each test reproduces the report's command; a crash shows as an exit code other than 1.
#include "support/cli_runner.hpp"

#include "estimation/dataset.hpp"
#include "estimation/health_estimate.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::AnyOf;
using ::testing::HasSubstr;
using ::testing::Not;
using emadiag::test::run_cli;

namespace {

/// Memory limit (KiB) put on commands that read unbounded input in the old code, so a regression
/// fails the test with bad_alloc instead of exhausting the machine.
constexpr int kChildMemoryKiB = 1'500'000;

#if defined(__SANITIZE_ADDRESS__)
#define EMADIAG_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define EMADIAG_TEST_ASAN 1
#endif
#endif

/// "ulimit -v KIB; ": the child's memory cap. Under AddressSanitizer (the sanitizer build) none: ASan
/// reserves terabytes of address space for its shadow and aborts under any cap; that build still
/// checks the refusal and its message, the release build checks it under the cap.
std::string memory_cap(int kib) {
#ifdef EMADIAG_TEST_ASAN
    (void)kib;
    return "";
#else
    return "ulimit -v " + std::to_string(kib) + "; ";
#endif
}
/// Exit codes of a clear refusal: emadiag's error (1), or CLI11's ValidationError (105) for an
/// option refused by its check. An abort (SIGABRT) gives neither.
constexpr int kErrorExit = 1;
constexpr int kOptionRefusedExit = 105;

/// `command` through the shell (for a memory limit or an environment variable set before emadiag).
emadiag::test::CliResult run_sh(const std::string& command) {
    emadiag::test::CliResult r;
    FILE* pipe = popen((command + " 2>&1").c_str(), "r");
    if (!pipe) return r;
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
    const int status = pclose(pipe);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

class HostileBoundsCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag-bounds-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ec);
        fs::remove_all(dir_, ec);
    }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }

    /// A dataset file of `runs` runs of `samples` samples (sound unless `edit` spoils it).
    std::string dataset(const std::string& name, int runs, std::size_t samples,
                        const std::function<void(emadiag::Dataset&)>& edit = {}) const {
        emadiag::Dataset d;
        d.spec.load_case = emadiag::sim::LoadCase::A;
        d.spec.count = runs;
        const auto params = emadiag::sim::EmaParams::datasheet();
        d.constants = emadiag::RunConstants{params.k_t_nm_per_a, params.j_kgm2, params.tau, emadiag::sim::kSamplePeriodS};
        for (int r = 0; r < runs; ++r) {
            emadiag::DatasetRun run;
            const double fdj = 0.07 + 0.002 * r;
            run.labels = emadiag::HealthLabels{fdj, 0.12, 0.85, emadiag::sim::eta_a_from_eta_o(0.85, params.tau)};
            for (std::size_t k = 0; k < samples; ++k) {
                const double t = static_cast<double>(k + 1) * emadiag::sim::kSamplePeriodS;
                run.samples.push_back({t, fdj * 10 + std::sin(100 * t), 10 * std::cos(50 * t), 0.1 * t, 2.0, 0.0});
            }
            d.runs.push_back(std::move(run));
        }
        if (edit) edit(d);
        emadiag::write_dataset(p(name), d);
        return p(name);
    }
    fs::path dir_;
};

// ---- item 11: train

TEST_F(HostileBoundsCli, TrainTimestepsZeroOneAndMinusOneAreRefusedNotAborted) {
    const std::string d = dataset("d.bin", 12, 20);
    for (const char* n : {"0", "1", "-1"}) {
        const auto r = run_cli("train --dataset " + d + " --out " + p("m.json") + " --timesteps " + n);
        EXPECT_THAT(r.exit_code, AnyOf(kErrorExit, kOptionRefusedExit)) << r.output;  // SIGABRT before
        EXPECT_THAT(r.output, AllOf(HasSubstr("--timesteps"), HasSubstr("outside [2, 10000] (kMinTimesteps, kMaxTimesteps)")));
        EXPECT_FALSE(fs::exists(p("m.json")));
    }
}

TEST_F(HostileBoundsCli, TrainOnTwoSamplesPerRunIsAClearRefusal) {
    const auto r = run_cli("train --dataset " + dataset("two.bin", 12, 2) + " --out " + p("m.json") + " --timesteps 2");
    EXPECT_EQ(r.exit_code, 1) << r.output;  // SIGABRT before
    EXPECT_THAT(r.output, HasSubstr("two.bin: header samples_per_run 2 is below the limit kMinDatasetSamplesPerRun = 3"));
}

TEST_F(HostileBoundsCli, TrainRefusesBadLabelsSamplesAndOptionsAndWritesNoModel) {
    const std::string sound = dataset("d.bin", 12, 20);
    const std::string out = " --out " + p("m.json");
    struct Case {
        std::string args, message;
    };
    const Case cases[] = {
        {"--dataset " + dataset("inf.bin", 12, 20, [](auto& d) { d.runs[4].samples[7].speed_rad_s = INFINITY; }),
         "inf.bin: run 4: sample 7: speed_rad_s = inf is not finite"},
        {"--dataset " + dataset("nan.bin", 12, 20, [](auto& d) { d.runs[3].labels.fdj_nm = NAN; }),
         "nan.bin: run 3: label FDJ_Nm = nan is outside the datasheet's range"},
        {"--dataset " + dataset("fdj.bin", 12, 20, [](auto& d) { d.runs[0].labels.fdj_nm = 100; }),
         "fdj.bin: run 0: label FDJ_Nm = 100 is outside the datasheet's range"},
        {"--dataset " + sound + " --outputs FDJ_Nm,FDJ_Nm", "outputs: FDJ_Nm is listed twice"},
        {"--dataset " + sound + " --goal nan", "NaN and infinity are not accepted"},
        {"--dataset " + sound + " --max-epochs -3", "-3 is outside [1, 1000000] (kMinEpochs, kMaxEpochs)"},
        {"--dataset " + sound + " --neurons -1", "-1 is outside [1, 1000] (kMinHiddenNeurons, kMaxHiddenNeurons)"},
    };
    for (const auto& c : cases) {
        const auto r = run_cli("train " + c.args + out);
        EXPECT_THAT(r.exit_code, AnyOf(kErrorExit, kOptionRefusedExit)) << c.args << '\n' << r.output;
        EXPECT_THAT(r.output, HasSubstr(c.message)) << c.args;
        EXPECT_THAT(r.output, Not(HasSubstr("bad_alloc")));
        EXPECT_FALSE(fs::exists(p("m.json"))) << c.args;
    }
}

// ---- item 14: numbers that wrapped, clamped or were empty

TEST_F(HostileBoundsCli, SeedsNeitherWrapNorClampNorDefaultWhenEmpty) {
    struct Case {
        std::string value, message;
    };
    const Case cases[] = {
        {"-1", "'-1' is not a whole number >= 0 (decimal digits, no sign): it is negative"},
        {"18446744073709551616", "outside the range of the option's type [0, 18446744073709551615]"},
        {"''", "'' is not a whole number >= 0 (decimal digits, no sign): it is empty"},
        {"0x10", "unexpected character at position 2"},
        {"+5", "no '+' sign"},
    };
    for (const auto& c : cases) {
        const auto r = run_cli("simulate --seed " + c.value);
        EXPECT_NE(r.exit_code, 0) << c.value << '\n' << r.output;
        EXPECT_THAT(r.output, AllOf(HasSubstr("--seed"), HasSubstr(c.message))) << c.value;
    }
    EXPECT_EQ(run_cli("simulate --seed 18446744073709551615").exit_code, 0);  // the largest seed is a seed
}

TEST_F(HostileBoundsCli, NanInfinityAndHexAreRefusedByEveryNumericOption) {
    std::ofstream(p("db.sqlite")) << "";
    const std::string cmds[] = {
        "fleet --db " + p("db.sqlite") + " --horizon-cycles nan",
        "report --db " + p("db.sqlite") + " --tail N1 --horizon-days inf",
        "simulate --fdj nan",
        "history-sim --db " + p("h.db") + " --tail N1 --days-between nan",
        "dataset --count 5 --out " + p("d.bin") + " --threads -1",
    };
    for (const auto& c : cmds) {
        const auto r = run_cli(c);
        EXPECT_NE(r.exit_code, 0) << c << '\n' << r.output;
        EXPECT_THAT(r.output, AnyOf(HasSubstr("NaN and infinity are not accepted"), HasSubstr("it is negative"))) << c;
    }
    EXPECT_FALSE(fs::exists(p("h.db")));
}

TEST_F(HostileBoundsCli, HistorySimPlanIsCheckedBeforeAnythingIsStored) {
    const std::string db = p("h.db");
    auto r = run_cli("history-sim --db " + db + " --tail N1 --sessions 3 --cycles 9223372036854775807");
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("outside [0, 100000000] (kMaxFlightCycles)"));
    EXPECT_FALSE(fs::exists(db));
    // Within the bound at session 1, beyond it at session 3: nothing is stored, not session 1 and 2.
    r = run_cli("history-sim --db " + db + " --tail N1 --sessions 3 --days-between 30 --cycles 99950000 --cycles-per-day 1000");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("session 3 of 3 (day 60): cycles 99950000 + 60000 flown exceed the limit kMaxFlightCycles"));
    EXPECT_FALSE(fs::exists(db));
    // A friction that drifts below zero by session 3: refused up front as well.
    r = run_cli("history-sim --db " + db + " --tail N1 --sessions 3 --fdj-rate-per-100d -0.2");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("nothing was stored"));
    EXPECT_FALSE(fs::exists(db));
}

// ---- item 15: messages

TEST_F(HostileBoundsCli, DatasetCountMessagesNameTheBound) {
    auto r = run_cli("dataset --count 0 --out " + p("d.bin"));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("0 is outside [1, 16000] (kMaxDatasetCount)"));
    EXPECT_LT(r.output.size(), 300u) << r.output;  // was a 309-digit number
    r = run_cli("dataset --count 2147483647 --out " + p("d.bin"));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("2147483647 is outside [1, 16000] (kMaxDatasetCount)"));
    EXPECT_THAT(r.output, Not(HasSubstr("only 0 of 0")));
}

TEST_F(HostileBoundsCli, AVeryLongTermGivesAShortError) {
    const std::string term = "torque: " + std::string(30000, '(') + "w" + std::string(30000, ')');
    const auto r = run_cli("simulate --term '" + term + "'");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("is longer than the limit kMaxTermChars = 256 characters"));
    EXPECT_LT(r.output.size(), 400u);  // was 60 KB
}

TEST_F(HostileBoundsCli, ANulByteDoesNotCutTheMessageShort) {
    std::ofstream(p("nul.csv"), std::ios::binary)
        << "# case=B\n# sequence=dyn\nt_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg\n"
        << std::string("0.0005,1") + '\0' + "2,3,4,5,6\n";  // the literal was read one byte past its end
    const auto r = run_cli("estimate " + p("nul.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("'1\\02' is not a finite number"));
}

TEST_F(HostileBoundsCli, EncodingIsNamed) {
    ASSERT_EQ(run_cli("simulate --out " + p("run.csv")).exit_code, 0);
    std::ifstream in(p("run.csv"), std::ios::binary);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::string utf16 = "\xFF\xFE";
    for (const char c : text) utf16 += std::string(1, c) + '\0';
    std::ofstream(p("u16.csv"), std::ios::binary) << utf16;
    auto r = run_cli("estimate " + p("u16.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("starts with a UTF-16 byte order mark: the file looks UTF-16 encoded; save it as UTF-8"));
    std::string no_bom = utf16.substr(2);
    std::ofstream(p("u16le.csv"), std::ios::binary) << no_bom;
    r = run_cli("estimate " + p("u16le.csv"));
    EXPECT_THAT(r.output, HasSubstr("holds NUL bytes: the file looks UTF-16 encoded"));
    // A UTF-8 byte order mark (a spreadsheet's "CSV UTF-8") is skipped: the run is read.
    std::ofstream(p("bom.csv"), std::ios::binary) << "\xEF\xBB\xBF" << text;
    r = run_cli("estimate " + p("bom.csv"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST_F(HostileBoundsCli, ADirectoryAsDatabaseIsNamedAsSuch) {
    const auto r = run_cli("report --db " + dir_.string() + " --tail N1");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr(dir_.string() + " is a directory, not a database file"));
    EXPECT_THAT(r.output, Not(HasSubstr("File does not exist")));
}

TEST_F(HostileBoundsCli, ReportAndVerifyReadADatabaseOnReadOnlyStorage) {
    const std::string db = p("ro.db");
    const auto made = run_cli("history-sim --db " + db + " --tail N1 --sessions 2");
    ASSERT_EQ(made.exit_code, 0) << made.output;
    fs::permissions(db, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
    fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec);
    // root writes any file: the commands run as an unprivileged user (nobody), in a child process.
    for (const std::string& cmd : {"report --tail N1 --db " + db, "verify --tail N1 --db " + db}) {
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(4);
            const auto r = run_cli(cmd);
            std::fprintf(stderr, "%s\n", r.output.c_str());
            ::_exit(r.exit_code == 0 && r.output.find("N1") != std::string::npos ? 0 : 1);
        }
        int status = 0;
        ::waitpid(pid, &status, 0);
        ASSERT_TRUE(WIFEXITED(status));
        EXPECT_EQ(WEXITSTATUS(status), 0) << cmd << " (1: refused or failed, 4: setuid failed)";
    }
}

// ---- items 12 and 13: bounded reads

TEST_F(HostileBoundsCli, ImportRefusesAnOversizedRunFileBeforeReadingIt) {
    { std::ofstream(p("big.csv")) << "# case=B\n"; }
    fs::resize_file(p("big.csv"), std::uintmax_t{300} << 20);  // sparse: 300 MB of which nothing is on disk
    const auto r = run_sh(memory_cap(kChildMemoryKiB / 3) + EMADIAG_CLI " import " + p("big.csv") +
                          " --tail N1 --position LH-ELEV --db " + p("i.db"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("big.csv: the run file has 314572800 bytes, more than the limit kMaxImportFileBytes"));
}

TEST_F(HostileBoundsCli, PositionsFileIsBounded) {
    std::string big = "{\"positions\": [{\"name\": \"LH-ELEV\", \"ata\": \"27-30\", \"description\": \"" + std::string(70'000, 'x') + "\"}]}";
    std::ofstream(p("big.json")) << big;
    const std::string hs = "history-sim --db " + p("h.db") + " --tail N1 --sessions 1 --position LH-ELEV";
    auto r = run_cli(hs + " --positions " + p("big.json"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("big.json: the positions file is larger than the limit kMaxPositionsFileBytes = 65536 bytes"));
    // A long description within the size limit is refused by its own bound, not stored.
    std::ofstream(p("long.json")) << "{\"positions\": [{\"name\": \"LH-ELEV\", \"ata\": \"27-30\", \"description\": \""
                                  << std::string(5'000, 'x') << "\"}]}";
    r = run_cli(hs + " --positions " + p("long.json"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("position 0: description of 5000 characters is longer than the limit kMaxPositionDescriptionChars"));
    // /dev/zero never ends: refused as not a regular file, under a memory limit in case it is read.
    r = run_sh(memory_cap(kChildMemoryKiB) + "EMADIAG_POSITIONS=/dev/zero " EMADIAG_CLI " " + hs);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("/dev/zero: the positions file is not a regular file"));
    EXPECT_FALSE(fs::exists(p("h.db")));
}

}  // namespace
