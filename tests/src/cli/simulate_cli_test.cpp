// The `emadiag simulate` command end to end: the binary, its options, its CSV and its errors.
#include "support/cli_runner.hpp"
#include "core/run_csv.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace {

using ::testing::HasSubstr;

using Result = emadiag::test::CliResult;
Result run(const std::string& args) { return emadiag::test::run_cli(args); }

TEST(SimulateCli, WritesARunCsvAndPrintsTheSummary) {
    const auto dir = std::filesystem::temp_directory_path() / "emadiag_simulate_cli_test";
    std::filesystem::create_directories(dir);
    const auto csv = (dir / "run.csv").string();
    const auto r = run("simulate --case A --sequence brk --fdj 0.07 --fsj 0.13 --eta-o 0.8 --noise typical --seed 3 "
                       "--effect viscous=1e-5 --out " + csv);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("wrote 1600 samples"));
    const auto run_back = emadiag::read_run_csv_file(csv);
    EXPECT_EQ(run_back.load_case, emadiag::sim::LoadCase::A);
    EXPECT_EQ(run_back.sequence, emadiag::sim::Sequence::Brk);
    EXPECT_EQ(run_back.meta_value("true_FDJ_Nm").value(), "0.070000000000000007");
    EXPECT_EQ(run_back.meta_value("effect_viscous").value(), "1.0000000000000001e-05");
    EXPECT_EQ(run_back.meta_value("noise").value(), "typical");
}

TEST(SimulateCli, ReferenceFiguresOnTheDefaultRun) {
    const auto r = run("simulate");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("between t = 0.2320 s and 0.2325 s"));
    EXPECT_THAT(r.output, HasSubstr("-11.872 .."));
    EXPECT_THAT(r.output, HasSubstr("T_R plateau moving down: -0.1802 N m"));
    EXPECT_THAT(r.output, HasSubstr("T_R plateau moving up  : 0.1413 N m"));
}

TEST(SimulateCli, BadInputIsAClearErrorAndNonZeroExit) {
    auto r = run("simulate --effect warp=1");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("unknown effect 'warp'"));
    r = run("simulate --fdj 0.2");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("fsj_nm = 0.12 must be >= fdj_nm = 0.2"));
    r = run("simulate --eta-o 1.5");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("eta_o = 1.5 is outside the allowed range (0, 1]"));
    r = run("simulate --eta-o 0.8 --eta-a 0.7");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("not both"));
    r = run("simulate --case C");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("unknown load case 'C'"));
    r = run("simulate --effect viscous=abc");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("'abc' is not a number"));
}

}  // namespace
