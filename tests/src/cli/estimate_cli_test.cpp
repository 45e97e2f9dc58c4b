// `emadiag estimate` end to end: the binary on run CSVs written by `emadiag simulate`: text and
// --json output (docs/estimate-json.md), and the clear errors of issue 4 part 5.
#include "support/cli_runner.hpp"
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <functional>
#include <vector>
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

class EstimateCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = std::filesystem::temp_directory_path() / ("emadiag_estimate_cli_" + std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        ASSERT_EQ(run("simulate --case B --sequence dyn --out " + path("b_dyn.csv")).exit_code, 0);
        ASSERT_EQ(run("simulate --case A --sequence dyn --out " + path("a_dyn.csv")).exit_code, 0);
        ASSERT_EQ(run("simulate --case B --sequence brk --out " + path("b_brk.csv")).exit_code, 0);
    }
    static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
    static std::string path(const std::string& name) { return (dir_ / name).string(); }

    /// A copy of b_dyn.csv with one data row changed by `edit(fields)`.
    static std::string edited_copy(const std::string& name, int data_row, const std::function<void(std::vector<std::string>&)>& edit) {
        std::ifstream in(path("b_dyn.csv"));
        std::ofstream out(path(name));
        std::string line;
        int row = 0;
        bool header_seen = false;
        while (std::getline(in, line)) {
            if (!line.empty() && line[0] != '#' && !header_seen) {
                header_seen = true;
            } else if (header_seen && ++row == data_row) {
                std::vector<std::string> f;
                std::stringstream ss(line);
                std::string cell;
                while (std::getline(ss, cell, ',')) f.push_back(cell);
                edit(f);
                line.clear();
                for (std::size_t i = 0; i < f.size(); ++i) line += (i ? "," : "") + f[i];
            }
            out << line << '\n';
        }
        return path(name);
    }
    static inline std::filesystem::path dir_;
};

TEST_F(EstimateCli, TextReportsEveryParameterWithUncertaintyAndMethod) {
    const Result r = run("estimate " + path("b_dyn.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("estimator: physics"));
    EXPECT_THAT(r.output, HasSubstr("FDJ_Nm  0.0799"));
    EXPECT_THAT(r.output, HasSubstr("[physics-wrls]"));
    EXPECT_THAT(r.output, HasSubstr("eta_O   0.85"));
    EXPECT_THAT(r.output, HasSubstr("[eq4]"));
    EXPECT_THAT(r.output, HasSubstr("FSJ_Nm  not identifiable"));
    EXPECT_THAT(r.output, HasSubstr("95 % ["));
}

TEST_F(EstimateCli, BothMethodsAgreeOnCleanDataWhenAModelApplies) {
    const Result r = run("estimate " + path("b_dyn.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    // The shipped models (models/) are part of the product: a missing case-B model is a failure.
    ASSERT_THAT(r.output, HasSubstr("estimator: network")) << "no network model for case B found in models/";
    EXPECT_THAT(r.output, HasSubstr("agreement"));
    EXPECT_THAT(r.output, HasSubstr("FDJ_Nm  "));
    EXPECT_THAT(r.output, Not(HasSubstr("DISAGREE")));
}

TEST_F(EstimateCli, CaseASaysEtaIsNotIdentifiable) {
    const Result r = run("estimate " + path("a_dyn.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("eta_O   not identifiable"));
    EXPECT_THAT(r.output, HasSubstr("|F_R| spread"));
}

TEST_F(EstimateCli, JsonFollowsTheDocumentedSchema) {
    const Result r = run("estimate " + path("b_brk.csv") + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j.at("schema"), "emadiag-estimate");
    EXPECT_EQ(j.at("version"), 1);
    EXPECT_EQ(j.at("run").at("case"), "B");
    EXPECT_EQ(j.at("run").at("sequence"), "brk");
    const auto& phys = j.at("estimates").at(0);
    EXPECT_EQ(phys.at("estimator"), "physics");
    const auto& params = phys.at("parameters");
    ASSERT_EQ(params.size(), 4u);
    EXPECT_EQ(params[0].at("name"), "FDJ_Nm");
    EXPECT_EQ(params[1].at("name"), "FSJ_Nm");
    EXPECT_NEAR(params[1].at("value").get<double>(), 0.12, 0.0012);
    EXPECT_GT(params[1].at("std_error").get<double>(), 0.0);
    EXPECT_EQ(params[1].at("ci95").size(), 2u);
    EXPECT_EQ(params[1].at("method"), "physics-breakaway");
    EXPECT_TRUE(params[2].at("value").is_null());
    EXPECT_FALSE(params[2].at("identifiable").get<bool>());
    EXPECT_THAT(params[2].at("note").get<std::string>(), HasSubstr("not identifiable"));
    EXPECT_TRUE(phys.at("diagnostics").is_object());
}

TEST_F(EstimateCli, ANanIsAClearErrorNamingTheRow) {
    const auto file = edited_copy("nan.csv", 12, [](auto& f) { f[1] = "nan"; });
    const Result r = run("estimate " + file);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("emadiag: error:"));
    // The reader refuses non-finite cells itself, naming the file line (sample row 12 is line 26).
    EXPECT_THAT(r.output, HasSubstr("nan.csv:26: column 'current_A': 'nan' is not a finite number"));
}

TEST_F(EstimateCli, TimeGoingBackwardsIsAClearError) {
    const auto file = edited_copy("time.csv", 100, [](auto& f) { f[0] = "0.01"; });
    const Result r = run("estimate " + file);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("time does not increase"));
    EXPECT_THAT(r.output, HasSubstr("100"));
}

TEST_F(EstimateCli, MissingConstantsAreAClearError) {
    std::ifstream in(path("b_dyn.csv"));
    std::ofstream out(path("noconst.csv"));
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("# J_kgm2=", 0) == 0) continue;
        out << line << '\n';
    }
    out.close();
    const Result r = run("estimate " + path("noconst.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("J_kgm2"));
}

TEST_F(EstimateCli, TooFewSlippingSamplesIsAClearError) {
    std::ifstream in(path("b_dyn.csv"));
    std::ofstream out(path("short.csv"));
    std::string line;
    int data = 0;
    bool header_seen = false;
    while (std::getline(in, line)) {
        if (!line.empty() && line[0] != '#') {
            if (header_seen && ++data > 40) break;
            header_seen = true;
        }
        out << line << '\n';
    }
    out.close();
    const Result r = run("estimate " + path("short.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("too few slipping samples"));
}

TEST_F(EstimateCli, ACandumpLogWithoutASessionIsAClearError) {
    { std::ofstream(path("empty.log")) << "(0.000000) vcan0 123#00\n"; }
    const Result r = run("estimate " + path("empty.log"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("emadiag: error:"));
    EXPECT_THAT(r.output, HasSubstr("empty.log"));
}

TEST_F(EstimateCli, UnknownFormatsAndMissingFilesAreClearErrors) {
    const Result r = run("estimate " + path("run.txt"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("unknown run format"));
    const Result m = run("estimate " + path("absent.csv"));
    EXPECT_EQ(m.exit_code, 1);
    EXPECT_THAT(m.output, HasSubstr("absent.csv"));
}

}  // namespace
