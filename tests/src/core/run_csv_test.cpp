// The run CSV hand-over format: a write and a read give back the same data; bad files are
// reported with file:line and every problem.
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/sim_run.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

namespace emadiag {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

Run simulated_run() {
    sim::SimConfig c;
    c.noise = sim::NoiseProfile::Typical;
    c.seed = 5;
    c.params.effects.viscous_nm_s_rad = 1e-5;
    return make_run(c, sim::simulate(c));
}

TEST(RunCsv, WriteThenReadGivesBackTheSameData) {
    emadiag::Run run = simulated_run();
    run.extra_columns.emplace_back("extra_col", std::vector<double>(run.samples.size(), 1.0 / 3.0));
    std::stringstream ss;
    write_run_csv(ss, run);
    const emadiag::Run back = read_run_csv(ss, "mem.csv");
    ASSERT_EQ(back.samples.size(), run.samples.size());
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const auto& a = run.samples[i];
        const auto& b = back.samples[i];
        ASSERT_EQ(a.t_s, b.t_s);
        ASSERT_EQ(a.current_a, b.current_a);
        ASSERT_EQ(a.speed_rad_s, b.speed_rad_s);
        ASSERT_EQ(a.theta_m_rad, b.theta_m_rad);
        ASSERT_EQ(a.hinge_moment_nm, b.hinge_moment_nm);
        ASSERT_EQ(a.command_deg, b.command_deg);
    }
    EXPECT_EQ(back.meta, run.meta);
    EXPECT_EQ(back.constants.k_t_nm_per_a, 0.2);
    EXPECT_EQ(back.constants.j_kgm2, 1.65e-4);
    EXPECT_EQ(back.constants.tau, 800.0);
    EXPECT_EQ(back.constants.sample_period_s, 5e-4);
    EXPECT_EQ(back.load_case, sim::LoadCase::B);
    EXPECT_EQ(back.sequence, sim::Sequence::Dyn);
    ASSERT_EQ(back.extra_columns.size(), 1U);
    EXPECT_EQ(back.extra_columns[0].second[3], 1.0 / 3.0);
}

TEST(RunCsv, HeaderCarriesTruthAndEffectsForSimulatedRuns) {
    const emadiag::Run run = simulated_run();
    EXPECT_EQ(run.meta_value("true_FDJ_Nm").value(), "0.080000000000000002");
    EXPECT_TRUE(run.meta_value("effect_viscous").has_value());
    for (const auto& [k, v] : run.analysis_meta()) {
        EXPECT_NE(k.rfind("true_", 0), 0U) << k;
        EXPECT_NE(k.rfind("effect_", 0), 0U) << k;
    }
}

TEST(RunCsv, ReportsEveryProblemWithFileAndLine) {
    std::istringstream in(
        "# k_t_Nm_per_A=0.2\n"
        "# tau=abc\n"
        "# case=B\n"
        "t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg\n"
        "0.0005,1,2,3,4,5\n"
        "0.001,1,x,3,4,5\n"
        "0.0015,1,2,3\n");
    EXPECT_THAT([&] { (void)read_run_csv(in, "bad.csv"); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("bad.csv:6: column 'speed_rad_s': 'x' is not a finite number"),
                                                  HasSubstr("bad.csv:7: expected 6 columns, found 4"),
                                                  HasSubstr("missing metadata key 'J_kgm2'"),
                                                  HasSubstr("metadata tau=abc is not a positive number"),
                                                  HasSubstr("missing metadata key 'sequence'"))));
}

TEST(RunCsv, WrongHeaderIsNamed) {
    std::istringstream in("# case=B\nt,current_A\n");
    EXPECT_THAT([&] { (void)read_run_csv(in, "h.csv"); },
                ThrowsMessage<EmadiagError>(HasSubstr("h.csv:2: header column 1 must be 't_s', found 't'")));
}

TEST(RunCsv, MissingFileIsNamed) {
    EXPECT_THAT([] { (void)read_run_csv_file("/nonexistent/run.csv"); },
                ThrowsMessage<EmadiagError>(HasSubstr("cannot open run file /nonexistent/run.csv")));
}

}  // namespace
}  // namespace emadiag
