// Residual torque T_R (eq. 7) against the simulator's exact friction torque (SampleTruth), the
// section-7 reference plateaus, and the telescoped window mean.
#include "core/emadiag_error.hpp"
#include "core/residual_torque.hpp"
#include "core/run_summary.hpp"
#include "core/sim_run.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace emadiag {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kPlateauToleranceNm = 5e-5;        // the reference figures have 4 decimals
constexpr double kSlipSpeedRadS = 20.0;
constexpr double kCurrentLimitA = 19.5;             // stay clear of T_max clipping (section 7)
constexpr double kMedianToleranceNm = 1e-4;         // T_R vs exact mean friction, slipping samples
constexpr double kP90ToleranceNm = 2e-3;            // 90th percentile: the speed-loop transients
                                                    // (large third derivative) are where it errs
constexpr double kWindowToleranceNm = 2e-4;         // a 20-sample window mean on the speed plateau
constexpr double kPlateauSpeedRadS = 830.0;  // the steady part of the speed-limit plateau

struct Simulated {
    sim::SimConfig config;
    sim::SimResult result;
    Run run;
};

Simulated simulate_b_dyn(sim::NoiseProfile noise = sim::NoiseProfile::None) {
    Simulated s;
    s.config.record_truth = true;
    s.config.noise = noise;
    s.result = sim::simulate(s.config);
    s.run = make_run(s.config, s.result);
    return s;
}

/// Samples that slip smoothly: fast, same direction for the sample and both neighbours, no clipping.
std::vector<std::size_t> smooth_slip(const Run& run) {
    std::vector<std::size_t> out;
    const auto& s = run.samples;
    for (std::size_t i = 1; i + 1 < s.size(); ++i) {
        const bool fast = std::abs(s[i - 1].speed_rad_s) > kSlipSpeedRadS && std::abs(s[i].speed_rad_s) > kSlipSpeedRadS &&
                          std::abs(s[i + 1].speed_rad_s) > kSlipSpeedRadS;
        const bool same = s[i - 1].speed_rad_s * s[i].speed_rad_s > 0 && s[i].speed_rad_s * s[i + 1].speed_rad_s > 0;
        if (fast && same && std::abs(s[i].current_a) < kCurrentLimitA) out.push_back(i);
    }
    return out;
}

TEST(ResidualTorque, ReproducesTheReferencePlateausOfSection7) {
    const auto s = simulate_b_dyn();
    const RunSummary sum = summarise(s.run);
    ASSERT_TRUE(sum.tr_plateau_down_nm && sum.tr_plateau_up_nm);
    EXPECT_NEAR(*sum.tr_plateau_down_nm, -0.1802, kPlateauToleranceNm);
    EXPECT_NEAR(*sum.tr_plateau_up_nm, 0.1413, kPlateauToleranceNm);
}

TEST(ResidualTorque, MatchesTheSimulatorsExactFrictionTorqueWhileSlipping) {
    const auto s = simulate_b_dyn();
    const auto tr = residual_torque_nm(s.run);
    const auto idx = smooth_slip(s.run);
    ASSERT_GT(idx.size(), 500u);
    std::vector<double> err;
    for (std::size_t i : idx) err.push_back(std::abs(tr[i] - s.result.truth[i].friction_torque_nm));
    std::sort(err.begin(), err.end());
    const double median = err[err.size() / 2];
    const double p90 = err[err.size() * 9 / 10];
    EXPECT_LT(median, kMedianToleranceNm) << "median |T_R - T_F| over " << err.size() << " samples";
    EXPECT_LT(p90, kP90ToleranceNm) << "90th percentile |T_R - T_F|";
}

TEST(ResidualTorque, HasTheSignOfTheMotion) {
    const auto s = simulate_b_dyn();
    const auto tr = residual_torque_nm(s.run);
    for (std::size_t i : smooth_slip(s.run)) {
        EXPECT_GT(tr[i] * s.run.samples[i].speed_rad_s, 0.0) << "sample row " << i + 1;
    }
}

TEST(ResidualTorque, WindowMeanEqualsTheMeanOfTheSamplesAndTelescopes) {
    const auto s = simulate_b_dyn();
    const auto tr = residual_torque_nm(s.run);
    std::size_t first = 0;
    while (std::abs(s.run.samples[first].speed_rad_s) < kPlateauSpeedRadS) ++first;
    first += 10;
    const std::size_t last = first + 19;
    double mean = 0, truth = 0;
    for (std::size_t i = first; i <= last; ++i) {
        mean += tr[i] / 20.0;
        truth += s.result.truth[i].friction_torque_nm / 20.0;
    }
    EXPECT_NEAR(residual_torque_mean_nm(s.run, first, last), mean, 1e-12);
    EXPECT_NEAR(residual_torque_mean_nm(s.run, first, last), truth, kWindowToleranceNm);
}

TEST(ResidualTorque, WindowMeanCutsTheDerivativeNoise) {
    // Typical noise: per sample the derivative noise is J sigma_w / (sqrt 2 T) ~ 0.047 N m; the
    // telescoped mean of n samples has J sigma_w / (n T) ~ 0.0033 N m at n = 20.
    const auto s = simulate_b_dyn(sim::NoiseProfile::Typical);
    const auto tr = residual_torque_nm(s.run);
    const auto idx = smooth_slip(s.run);
    double per_sample = 0, windowed = 0;
    int windows = 0;
    for (std::size_t i : idx) per_sample += std::pow(tr[i] - s.result.truth[i].friction_torque_nm, 2);
    per_sample = std::sqrt(per_sample / static_cast<double>(idx.size()));
    for (std::size_t k = 0; k + 20 < idx.size(); k += 20) {
        if (idx[k + 19] != idx[k] + 19) continue;  // contiguous windows only
        double truth = 0;
        for (std::size_t i = idx[k]; i <= idx[k] + 19; ++i) truth += s.result.truth[i].friction_torque_nm / 20.0;
        windowed += std::pow(residual_torque_mean_nm(s.run, idx[k], idx[k] + 19) - truth, 2);
        ++windows;
    }
    ASSERT_GT(windows, 10);
    windowed = std::sqrt(windowed / windows);
    EXPECT_GT(per_sample, 0.03);
    EXPECT_LT(windowed, per_sample / 5) << "per-sample rms " << per_sample << ", 20-sample window rms " << windowed;
}

TEST(ResidualTorque, TimeThatDoesNotIncreaseIsAnError) {
    auto s = simulate_b_dyn();
    s.run.samples[5].t_s = s.run.samples[3].t_s;
    EXPECT_THAT([&] { (void)residual_torque_nm(s.run); },
                ThrowsMessage<EmadiagError>(HasSubstr("time does not increase at sample row")));
    EXPECT_THAT([&] { (void)residual_torque_mean_nm(s.run, 10, 2000); },
                ThrowsMessage<EmadiagError>(HasSubstr("outside the run")));
}

}  // namespace
}  // namespace emadiag
