// Issue 22 part 2: a re-simulation goes from the simulator's enums and parameters straight to
// RunSignals (resimulate_signals), without a Run with string metadata and a second check_run. The
// signals must be those of the old path, run_signals(resimulate(...)), bit for bit.
#include "discovery/model/resimulation.hpp"
#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

namespace emadiag::discovery {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kRunDurationS = 0.25;

emadiag::Run measured_run(sim::Sequence sequence) {
    sim::SimConfig c;
    c.sequence = sequence;
    c.load_case = sim::LoadCase::A;
    c.noise = sim::NoiseProfile::Typical;
    c.seed = 17;
    c.duration_s = kRunDurationS;
    c.params.fdj_nm = 0.1;
    c.params.effects.viscous_nm_s_rad = 2e-5;
    return make_run(c, sim::simulate(c));
}

void expect_same(const RunSignals& a, const RunSignals& b) {
    EXPECT_EQ(a.k_t_nm_per_a, b.k_t_nm_per_a);
    EXPECT_EQ(a.j_kgm2, b.j_kgm2);
    EXPECT_EQ(a.tau, b.tau);
    EXPECT_EQ(a.sample_period_s, b.sample_period_s);
    EXPECT_EQ(a.t_s, b.t_s);
    EXPECT_EQ(a.current_a, b.current_a);
    EXPECT_EQ(a.speed_rad_s, b.speed_rad_s);
    EXPECT_EQ(a.theta_m_rad, b.theta_m_rad);
    EXPECT_EQ(a.theta_start_rad, b.theta_start_rad);
    EXPECT_EQ(a.load_torque_nm, b.load_torque_nm);
    EXPECT_EQ(a.accel_rad_s2, b.accel_rad_s2);
    EXPECT_EQ(a.residual_torque_nm, b.residual_torque_nm);
    EXPECT_EQ(a.slipping, b.slipping);
}

TEST(ResimulationSignals, AreTheSignalsOfTheResimulatedRunBitForBit) {
    for (const auto sequence : {sim::Sequence::Dyn, sim::Sequence::Brk}) {
        SCOPED_TRACE(sim::to_string(sequence));
        const emadiag::Run run = measured_run(sequence);
        sim::EmaParams p = resim_config(run, sim::EmaParams::datasheet()).params;
        p.fdj_nm = 0.12;
        p.fsj_nm = 0.15;
        p.effects.stribeck_amplitude_nm = 0.02;
        expect_same(resimulate_signals(resim_target(run), p), run_signals(resimulate(run, p)));
    }
}

TEST(ResimulationSignals, ABatchGivesEachParamsAloneBitForBit) {
    const emadiag::Run run = measured_run(sim::Sequence::Dyn);
    std::vector<sim::EmaParams> params;
    for (int i = 0; i < 3; ++i) {
        sim::EmaParams p = resim_config(run, sim::EmaParams::datasheet()).params;
        p.fdj_nm = 0.05 + 0.03 * i;
        params.push_back(p);
    }
    params.back().effects.backlash_rad = 0.01;  // lanes share the backlash: this one runs alone
    const std::vector<RunSignals> many = resimulate_signals_many(resim_target(run), params);
    const std::vector<emadiag::Run> runs = resimulate_many(run, params);
    ASSERT_EQ(many.size(), params.size());
    for (std::size_t i = 0; i < params.size(); ++i) {
        SCOPED_TRACE(i);
        expect_same(many[i], run_signals(runs[i]));
    }
}

TEST(ResimulationSignals, ARunAtAnotherSamplePeriodIsRefusedByName) {
    emadiag::Run run = measured_run(sim::Sequence::Dyn);
    run.constants.sample_period_s = 2 * sim::kSamplePeriodS;
    EXPECT_THAT([&] { (void)resim_target(run); },
                ThrowsMessage<EmadiagError>(HasSubstr("sample_period_s 0.001 s is not the simulator's 0.0005 s")));
}

}  // namespace
}  // namespace emadiag::discovery
