// `emadiag discover` end to end: the binary on run CSVs written by `emadiag simulate` (text,
// --json, --out-model, --out-params read back by `simulate --params`) and its clear errors.
#include "support/cli_runner.hpp"
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using ::testing::HasSubstr;
using ::testing::Not;

using Result = emadiag::test::CliResult;
Result run(const std::string& args) { return emadiag::test::run_cli(args); }

class DiscoverCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = std::filesystem::temp_directory_path() / ("emadiag_discover_cli_" + std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        ASSERT_EQ(run("simulate --case B --sequence dyn --noise typical --seed 4 --effect viscous=5e-5 --out " +
                      path("visc.csv")).exit_code, 0);
        ASSERT_EQ(run("simulate --case B --sequence dyn --noise typical --seed 4 --out " + path("clean.csv")).exit_code, 0);
    }
    static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
    static std::string path(const std::string& name) { return (dir_ / name).string(); }
    static std::string read(const std::string& name) {
        std::ifstream in(path(name));
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }
    static inline std::filesystem::path dir_;
};

TEST_F(DiscoverCli, TextNamesTheEffectAndTheErrorBeforeAndAfter) {
    const Result r = run("discover " + path("visc.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("added effects: viscous"));
    EXPECT_THAT(r.output, HasSubstr("ADDED"));
    EXPECT_THAT(r.output, HasSubstr("viscous_nm_s_rad"));
    EXPECT_THAT(r.output, HasSubstr("  before current"));
    EXPECT_THAT(r.output, HasSubstr("  after  current"));
    EXPECT_THAT(r.output, HasSubstr("ratio before/after: current"));
    EXPECT_THAT(r.output, HasSubstr("FSJ_Nm: datasheet value (not identifiable"));
}

TEST_F(DiscoverCli, CleanRunFindsNothing) {
    const Result r = run("discover " + path("clean.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("no missing effect found"));
    EXPECT_THAT(r.output, Not(HasSubstr("ADDED")));
}

TEST_F(DiscoverCli, JsonAndModelFilesAndSimulateReadsTheParams) {
    const Result r = run("discover " + path("visc.csv") + " --json --out-model " + path("model.json") + " --out-params " +
                         path("params.json"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j["schema"], "emadiag-discover");
    EXPECT_EQ(j["added_effects"], nlohmann::json::array({"viscous"}));
    EXPECT_GT(j["ratio_before_after"]["current_rms"].get<double>(), 1.0);
    const auto model = nlohmann::json::parse(read("model.json"));
    EXPECT_EQ(model["version"], 1);
    EXPECT_EQ(model["terms"][0]["effect"], "viscous_nm_s_rad");
    EXPECT_EQ(model["terms"][0]["value"], j["model"]["terms"][0]["value"]);
    const Result sim = run("simulate --case B --sequence dyn --params " + path("params.json") + " --out " + path("resim.csv"));
    ASSERT_EQ(sim.exit_code, 0) << sim.output;
    EXPECT_THAT(read("resim.csv"), HasSubstr("# effect_viscous="));
}

TEST_F(DiscoverCli, BadInputsAreClearErrors) {
    const Result missing = run("discover " + path("nope.csv"));
    EXPECT_NE(missing.exit_code, 0);
    EXPECT_THAT(missing.output, HasSubstr("nope.csv"));
    // A NaN current in data row 5.
    std::ifstream in(path("clean.csv"));
    std::ofstream out(path("nan.csv"));
    std::string line;
    int data_row = -1;  // the column header is row 0
    while (std::getline(in, line)) {
        if (!line.empty() && line[0] != '#' && ++data_row == 5) line = line.substr(0, line.find(',')) + ",nan" + line.substr(line.find(',', line.find(',') + 1));
        out << line << '\n';
    }
    out.close();
    const Result nan = run("discover " + path("nan.csv"));
    EXPECT_NE(nan.exit_code, 0);
    EXPECT_THAT(nan.output, HasSubstr("current_A"));
}

TEST_F(DiscoverCli, ManyRunsPlotAndTermsInjectedBySimulate) {
    // A constant torque injected as a term, plus the viscous and clean runs: each run's report, then
    // the comparison across the runs; the plot is an SVG.
    ASSERT_EQ(run("simulate --case B --sequence dyn --noise typical --seed 5 --term 'torque: 0.035' --out " +
                  path("const.csv")).exit_code, 0);
    const Result r = run("discover " + path("const.csv") + " " + path("visc.csv") + " " + path("clean.csv") +
                         " --plot " + path("p.svg"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("hypotheses with the same torque residual"));
    EXPECT_THAT(r.output, HasSubstr("added constant_torque"));
    EXPECT_THAT(r.output, HasSubstr("no significant discrepancy"));
    EXPECT_THAT(r.output, HasSubstr("=== across 3 runs ==="));
    EXPECT_THAT(read("p.svg"), HasSubstr("<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox="));
    const Result j = run("discover " + path("const.csv") + " " + path("clean.csv") + " --json");
    ASSERT_EQ(j.exit_code, 0) << j.output;
    EXPECT_EQ(nlohmann::json::parse(j.output)["schema"], "emadiag-discover-runs");
}

TEST_F(DiscoverCli, TailNeedsADatabaseAndBadTermsAreClearErrors) {
    const Result r = run("discover --tail N123EM");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("--tail needs --db FILE"));
    const Result t = run("simulate --term 'torque: 0.1*sgn(q)' --out " + path("x.csv"));
    EXPECT_NE(t.exit_code, 0);
    EXPECT_THAT(t.output, HasSubstr("expected a signal"));
}

}  // namespace
