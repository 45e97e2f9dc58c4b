// Each effect beyond the datasheet (issue 2 part 5) is off by default and changes the run the way
// the physics says when switched on.
#include "emadiag/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace emadiag::sim {
namespace {

SimResult run_with(const std::string& effect, double value, LoadCase lc = LoadCase::A) {
    SimConfig c;
    c.load_case = lc;
    c.record_truth = true;
    if (!effect.empty()) c.params.effects.set(effect, value);
    return simulate(c);
}

/// Mean |T_F| over samples where |w| is above and below a speed.
double mean_friction(const SimResult& r, double min_speed, double max_speed) {
    double sum = 0;
    int n = 0;
    for (std::size_t i = 0; i < r.samples.size(); ++i) {
        const double w = std::abs(r.samples[i].speed_rad_s);
        if (w >= min_speed && w <= max_speed) {
            sum += std::abs(r.truth[i].friction_torque_nm);
            ++n;
        }
    }
    return n > 0 ? sum / n : 0.0;
}

TEST(Effects, AllOffByDefault) {
    EXPECT_FALSE(Effects{}.any());
    EXPECT_FALSE(EmaParams::datasheet().effects.any());
}

TEST(Effects, ViscousFrictionGrowsWithSpeed) {
    const auto base = run_with("", 0);
    const auto visc = run_with("viscous", 2e-5);
    EXPECT_NEAR(mean_friction(visc, 700, 1e9) - mean_friction(base, 700, 1e9), 2e-5 * 800, 2e-5 * 200);
}

TEST(Effects, StribeckRaisesFrictionOnlyAtLowSpeed) {
    const auto base = run_with("", 0);
    const auto strib = run_with("stribeck_amplitude", 0.04);
    EXPECT_GT(mean_friction(strib, 1, 40) - mean_friction(base, 1, 40), 0.01);
    EXPECT_NEAR(mean_friction(strib, 700, 1e9), mean_friction(base, 700, 1e9), 1e-6);
}

TEST(Effects, SpallAddsFrictionNearItsCentreOnly) {
    SimConfig c;
    c.load_case = LoadCase::A;
    c.record_truth = true;
    c.params.effects.spall_amplitude_nm = 0.05;
    c.params.effects.spall_center_deg = -8.0;
    c.params.effects.spall_width_deg = 0.5;
    const auto spall = simulate(c);
    const auto base = run_with("", 0);
    double near_gain = 0, far_gain = 0;
    for (std::size_t i = 0; i < base.samples.size(); ++i) {
        const double deg = spall.samples[i].theta_m_rad / 800.0 * 180.0 / std::numbers::pi;
        if (std::abs(spall.samples[i].speed_rad_s) < 100) continue;
        const double gain = std::abs(spall.truth[i].friction_torque_nm) - std::abs(base.truth[i].friction_torque_nm);
        if (std::abs(deg + 8.0) < 0.2) near_gain = std::max(near_gain, gain);
        if (std::abs(deg + 8.0) > 3.0) far_gain = std::max(far_gain, std::abs(gain));
    }
    EXPECT_GT(near_gain, 0.04);
    EXPECT_LT(far_gain, 1e-3);
}

TEST(Effects, TorqueRippleModulatesMotorTorque) {
    const auto base = run_with("", 0);
    const auto rip = run_with("ripple_amplitude", 0.05);
    double max_diff = 0;
    for (std::size_t i = 0; i < base.truth.size(); ++i) {
        max_diff = std::max(max_diff, std::abs(rip.truth[i].motor_torque_nm - base.truth[i].motor_torque_nm));
    }
    EXPECT_GT(max_diff, 0.01);
}

TEST(Effects, BacklashLetsTheMotorTurnBeforeTheLoadFollows) {
    const auto base = run_with("", 0);
    const auto bl = run_with("backlash", 0.5);
    // Inside the free play neither the load nor the transmission friction is felt.
    int free_periods = 0;
    for (const auto& t : bl.truth) free_periods += (t.load_torque_nm == 0.0 && t.friction_torque_nm == 0.0) ? 1 : 0;
    EXPECT_GT(free_periods, 0);
    EXPECT_NE(bl.samples[100].theta_m_rad, base.samples[100].theta_m_rad);
}

TEST(Effects, SensorErrorsChangeOnlyTheMeasurement) {
    const auto base = run_with("", 0);
    const auto gain = run_with("current_gain_error", 0.05);
    const auto offset = run_with("hinge_offset", 12.0);
    for (std::size_t i = 0; i < base.samples.size(); i += 97) {
        EXPECT_DOUBLE_EQ(gain.samples[i].current_a, 1.05 * base.samples[i].current_a);
        EXPECT_DOUBLE_EQ(gain.samples[i].theta_m_rad, base.samples[i].theta_m_rad);
        EXPECT_DOUBLE_EQ(offset.samples[i].hinge_moment_nm, base.samples[i].hinge_moment_nm + 12.0);
    }
}

TEST(Effects, TrueInertiaChangesTheDynamicsNotTheDatasheet) {
    const auto base = run_with("", 0);
    const auto heavy = run_with("true_inertia", 2.0 * 1.65e-4);
    // A heavier shaft accelerates more slowly at the current limit.
    EXPECT_LT(std::abs(heavy.samples[5].speed_rad_s), std::abs(base.samples[5].speed_rad_s));
}

}  // namespace
}  // namespace emadiag::sim
