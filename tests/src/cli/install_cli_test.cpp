// What an installed tool says about itself (issue 26, docs/install.md): `--version` (release, git
// description, build type, build id, SIMD targets), the tool version every stored session records and
// the export shows, `help COMMAND`, the manual pages and completion scripts generated from the CLI's
// own definitions, and where the shipped models are found (never ./models; --models and
// EMADIAG_MODELS_DIR override and say so).
#include "support/cli_runner.hpp"
#include "support/db_test_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

namespace fs = std::filesystem;
using emadiag::test::run_cli;

std::string read(const fs::path& p) { return emadiag::test::read_text_file(p.string()); }

/// The first line of --version: "emadiag 0.1.0"; the stored version starts with the release.
std::string release() {
    const auto r = run_cli("--version", false);
    std::istringstream in(r.output);
    std::string word, version;
    in >> word >> version;
    return version;
}

class InstallCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag_install_cli_" + std::to_string(getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    /// `cd DIR && [ENV] emadiag ARGS`
    static emadiag::test::CliResult in_dir(const fs::path& dir, const std::string& args, const std::string& env = "") {
        return run_cli("--version >/dev/null; cd '" + dir.string() + "' && " + env + " " + EMADIAG_CLI + " " + args);
    }
    fs::path dir_;
};

TEST_F(InstallCli, VersionNamesReleaseGitBuildTypeBuildIdAndSimdTargets) {
    const auto r = run_cli("--version");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(StartsWith("emadiag " + release() + "\n"), HasSubstr("\ngit:"), HasSubstr("\nbuild type:"),
                                HasSubstr("\nbuild id:"), HasSubstr("\nSIMD compiled:  scalar"), HasSubstr("\nSIMD this CPU:  scalar"),
                                HasSubstr("\nmodels:")));
    EXPECT_THAT(r.output, Not(HasSubstr("linked without --build-id")));
    // A binary in its build tree reads the source tree's models, never ./models.
    EXPECT_THAT(r.output, HasSubstr(std::string(EMADIAG_SOURCE_DIR) + "/models (build tree"));
}

TEST_F(InstallCli, EverySessionRecordsTheFullToolVersionAndTheExportShowsIt) {
    const std::string db = (dir_ / "m.db").string();
    ASSERT_EQ(run_cli("history-sim --db " + db + " --tail N1EM --sessions 3 --days-between 30 --seed 1").exit_code, 0);
    const auto e = run_cli("export --db " + db + " --tail N1EM --format csv --out " + (dir_ / "export").string());
    ASSERT_EQ(e.exit_code, 0) << e.output;
    const std::string sessions = read(dir_ / "export" / "sessions.csv");
    // "0.1.0 (git <describe>, <build type>, build-id <hex>) history-sim" in each of the 3 rows.
    std::size_t rows = 0;
    for (std::size_t at = sessions.find(release() + " (git "); at != std::string::npos; at = sessions.find(release() + " (git ", at + 1)) ++rows;
    EXPECT_EQ(rows, 3u) << sessions;
    EXPECT_THAT(sessions, HasSubstr(", build-id "));
    const auto html = run_cli("report --db " + db + " --tail N1EM --format html");
    EXPECT_THAT(html.output, HasSubstr("emadiag " + release() + " (git "));
}

TEST_F(InstallCli, HelpPrintsACommandsOptionsAndRefusesAnUnknownOne) {
    const auto r = run_cli("help fleet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("emadiag fleet"), HasSubstr("--format"), HasSubstr("--draws")));
    const auto all = run_cli("help");
    EXPECT_THAT(all.output, AllOf(HasSubstr("site"), HasSubstr("test-run"), Not(HasSubstr("generate-docs"))));
    const auto bad = run_cli("help no-such-command");
    EXPECT_NE(bad.exit_code, 0);
    EXPECT_THAT(bad.output, HasSubstr("no-such-command"));
}

TEST_F(InstallCli, ManualPagesAndCompletionComeFromTheDefinitions) {
    const auto man = dir_ / "man1";
    const auto r = run_cli("generate-docs --man-dir " + man.string() + " --bash " + (dir_ / "emadiag.bash").string() + " --zsh " +
                           (dir_ / "_emadiag").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::exists(man / "emadiag.1"));
    EXPECT_FALSE(fs::exists(man / "emadiag-generate-docs.1"));  // hidden
    const std::string fleet = read(man / "emadiag-fleet.1");
    EXPECT_THAT(fleet, AllOf(HasSubstr(".TH EMADIAG-FLEET 1"), HasSubstr("\\fB\\-\\-format\\fR"), HasSubstr("Values: text, json, csv."),
                             HasSubstr("Default: text.")));
    const std::string top = read(man / "emadiag.1");
    EXPECT_THAT(top, AllOf(HasSubstr(".BR emadiag\\-site (1)"), HasSubstr("EMADIAG_MODELS_DIR")));
    // Every visible command has its page.
    for (const char* c : {"estimate", "fleet", "report", "site", "test-run", "trend"}) EXPECT_TRUE(fs::exists(man / ("emadiag-" + std::string(c) + ".1"))) << c;
    // The completion works in bash: commands, and the values of an enumerated option.
    const std::string bash = (dir_ / "emadiag.bash").string();
    const auto complete = [&](const std::string& words, int cword) {
        return run_cli("--version >/dev/null; bash -c 'source " + bash + "; COMP_WORDS=(" + words + "); COMP_CWORD=" + std::to_string(cword) +
                       "; _emadiag; echo \"${COMPREPLY[*]}\"'")
            .output;
    };
    EXPECT_EQ(complete("emadiag tr", 1), "train trend\n");
    EXPECT_EQ(complete("emadiag fleet --format \"\"", 3), "text json csv\n");
    EXPECT_THAT(complete("emadiag site --th", 2), "--threads\n");
    EXPECT_THAT(read(dir_ / "_emadiag"), AllOf(StartsWith("#compdef emadiag"), HasSubstr("(text json csv)")));
}

TEST_F(InstallCli, ModelsInTheCurrentFolderAreNeverRead) {
    ASSERT_EQ(run_cli("simulate --case B --sequence dyn --out " + (dir_ / "run.csv").string()).exit_code, 0);
    fs::create_directories(dir_ / "models");
    std::ofstream(dir_ / "models" / "case_b_typical.json") << "{ \"decoy\": true }";
    const auto r = in_dir(dir_, "estimate run.csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("estimator: network"), HasSubstr(std::string(EMADIAG_SOURCE_DIR) + "/models/"), Not(HasSubstr("decoy")),
                                Not(HasSubstr("skipped models/"))));
}

TEST_F(InstallCli, AnExplicitModelsFolderOverridesAndSaysSo) {
    ASSERT_EQ(run_cli("simulate --case B --sequence dyn --out " + (dir_ / "run.csv").string()).exit_code, 0);
    fs::create_directories(dir_ / "mine");
    fs::copy_file(fs::path(EMADIAG_SOURCE_DIR) / "models" / "case_b.json", dir_ / "mine" / "case_b.json");
    const auto r = in_dir(dir_, "--models mine estimate run.csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("emadiag: shipped models from --models mine, instead of"), HasSubstr("mine/case_b.json")));
    const auto env = in_dir(dir_, "estimate run.csv", "EMADIAG_MODELS_DIR=mine");
    EXPECT_THAT(env.output, HasSubstr("emadiag: shipped models from EMADIAG_MODELS_DIR=mine, instead of"));
    const auto missing = in_dir(dir_, "--models nowhere estimate run.csv");
    EXPECT_NE(missing.exit_code, 0);
    EXPECT_THAT(missing.output, HasSubstr("--models nowhere: no such folder"));
}

}  // namespace
