// paper-tables: the eta-confound floor and a quick run of every table.
#include "research/paper_tables.hpp"

#include "estimation/nn_trainer.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace emadiag {
namespace {

using ::testing::HasSubstr;

TEST(PaperTablesTest, ConfoundFloorMatchesTheUniformConvolution) {
    // With c(eta)|F_R| nearly uniform of width w (normalised), E[FDJ | s] has MSE close to w^2 / 12
    // away from the ends of the range and less near them: the floor lies between w^2/12 * (1 - w) and w^2/12.
    const ConfoundFloor f = case_a_fdj_floor(5.0, 800.0, 4000, 1);
    const double f_r = 5.0 / 800.0;
    const double w = (0.988546 - 0.659031) * f_r / 0.032;  // c = 1 - eta_A spans the eta_A range
    EXPECT_LT(f.mse, w * w / 12 * 1.05);
    EXPECT_GT(f.mse, w * w / 12 * (1 - 2 * w) * 0.95);
    EXPECT_LT(f.c_difference_max, 1e-5);
    // No load, no confound; more load, a higher floor.
    EXPECT_LT(case_a_fdj_floor(0.0, 800.0, 500, 1).mse, 1e-20);
    EXPECT_GT(case_a_fdj_floor(20.0, 800.0, 500, 1).mse, 4 * f.mse);
}

TEST(PaperTablesTest, QuickRunHasEveryTableAndBothMethods) {
    PaperTablesOptions o;
    o.quick = true;
    o.seed = 3;
    int lines = 0;
    const std::string md = paper_tables_markdown(o, [&](const std::string&) { ++lines; });
    EXPECT_GT(lines, 10);
    for (const char* heading : {"## Table 2", "## Table 3", "## Table 4", "## Table 5", "## Table 6", "## Table 7",
                                "## Table 8", "## Goals", "## Calibration"}) {
        EXPECT_THAT(md, HasSubstr(heading));
    }
    EXPECT_THAT(md, HasSubstr("| Test | 2.601e-06 |"));
    EXPECT_THAT(md, HasSubstr("Physics, noise typical"));
    EXPECT_THAT(md, HasSubstr("Quick mode"));
    EXPECT_THAT(md, HasSubstr("the floor:"));
    EXPECT_THAT(md, ::testing::Not(HasSubstr("not run")));
}

TEST(PaperTablesTest, CalibrationQuantileCoversTheResiduals) {
    Eigen::MatrixXd r(1, 99);
    for (int k = 0; k < 99; ++k) r(0, k) = (k % 2 == 0 ? 1 : -1) * (k + 1) * 0.01;
    const std::vector<double> se = calibrate_std_error(r);
    // ceil(100 * 0.95) = 95th smallest |residual| = 0.95
    EXPECT_NEAR(se[0] * kZ95, 0.95, 1e-12);
}

}  // namespace
}  // namespace emadiag
