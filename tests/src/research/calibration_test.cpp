// Calibration of the physics estimator's uncertainties (issue 4: 95 % intervals must cover the
// truth in 90-98 % of runs). The large-sample figures come from bench/calibration_bench; this
// test checks a smaller seeded set against limits wide enough for its binomial spread, plus the
// accuracy goals the estimator owns and the case-A floor.
#include "estimation/health_estimate.hpp"
#include "research/physics_calibration.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

namespace emadiag {
namespace {

constexpr int kRuns = 60;
// With 60 runs the coverage of a calibrated 95 % interval has a binomial sd of 2.8 %.
constexpr double kCoverageLow = 0.85;
constexpr double kCoverageHigh = 1.0;
constexpr double kMeanZ2Low = 0.15;  // mean (err/se)^2: 1 when the se is right on average
constexpr double kMeanZ2High = 3.0;
// Noise-free runs: the error is the deterministic reconstruction error of T_R, and the se must
// be its size, not a bound far above it. A se twice too wide gives a mean (err/se)^2 near 0.2
// (the HAC-only se gave 0.12 to 0.39 on 200 runs); case-B FDJ sits near 0.7 with a 60-run
// spread of about 0.12 (0.50 to 0.80 over test seeds 1-21), hence 0.45.
constexpr double kNoiseFreeMeanZ2Low = 0.45;
constexpr double kNoiseFreeMeanZ2High = 2.0;
constexpr double kCaseBNoneMseGoal = 2.6e-7;  // issue 4 goals table
constexpr double kAExtEtaMseGoal = 5.5e-6;
constexpr double kCaseAFloorFactor = 1.5;

std::uint64_t test_seed() {
    const char* env = std::getenv("EMADIAG_TEST_SEED");
    return env ? std::strtoull(env, nullptr, 10) : 11ULL;
}

CalibrationResult run_set(sim::LoadCase lc, sim::Sequence seq, sim::NoiseProfile noise) {
    CalibrationSpec spec;
    spec.load_case = lc;
    spec.sequence = seq;
    spec.noise = noise;
    spec.count = kRuns;
    spec.seed = test_seed();
    spec.threads = 2;
    const auto r = evaluate_physics(spec);
    std::cout << format_calibration(r);  // the raw figures, with the seed
    return r;
}

void expect_calibrated(const CalibrationResult& r, const char* name) {
    const auto& s = r.score(name);
    ASSERT_GT(s.estimated, 0) << name;
    EXPECT_GE(s.coverage(), kCoverageLow) << name << " coverage";
    EXPECT_LE(s.coverage(), kCoverageHigh) << name << " coverage";
    EXPECT_GT(s.mean_z2, kMeanZ2Low) << name;
    EXPECT_LT(s.mean_z2, kMeanZ2High) << name;
}

TEST(Calibration, CaseBDynTypicalNoise) {
    const auto r = run_set(sim::LoadCase::B, sim::Sequence::Dyn, sim::NoiseProfile::Typical);
    EXPECT_EQ(r.failures, 0);
    expect_calibrated(r, kParamFdj);
    expect_calibrated(r, kParamEtaO);
}

TEST(Calibration, CaseBDynNoiseNoneMeetsTheMseGoal) {
    const auto r = run_set(sim::LoadCase::B, sim::Sequence::Dyn, sim::NoiseProfile::None);
    EXPECT_LE(r.score(kParamFdj).mse_normalised, kCaseBNoneMseGoal);
    EXPECT_LE(r.score(kParamEtaO).mse_normalised, kCaseBNoneMseGoal);
    expect_calibrated(r, kParamFdj);
}

TEST(Calibration, CaseBNoiseFreeSeIsTheSizeOfTheReconstructionError) {
    // Issue 4: on noise-free DYN and sweep runs the 95 % intervals covered the truth in 100 % of
    // runs (the sandwich se treated the deterministic reconstruction error as noise).
    for (auto seq : {sim::Sequence::Dyn, sim::Sequence::Sweep}) {
        const auto r = run_set(sim::LoadCase::B, seq, sim::NoiseProfile::None);
        EXPECT_EQ(r.failures, 0);
        for (const char* name : {kParamFdj, kParamEtaO}) {
            const auto& s = r.score(name);
            ASSERT_GT(s.estimated, 0) << name;
            EXPECT_GE(s.mean_z2, kNoiseFreeMeanZ2Low) << sim::to_string(seq) << " " << name;
            EXPECT_LE(s.mean_z2, kNoiseFreeMeanZ2High) << sim::to_string(seq) << " " << name;
        }
    }
}

TEST(Calibration, ExtendedCaseAEtaMeetsTheMseGoalWithBothNoiseProfiles) {
    for (auto noise : {sim::NoiseProfile::None, sim::NoiseProfile::Typical}) {
        const auto r = run_set(sim::LoadCase::AExt, sim::Sequence::Dyn, noise);
        EXPECT_LE(r.score(kParamEtaO).mse_normalised, kAExtEtaMseGoal) << sim::to_string(noise);
        expect_calibrated(r, kParamEtaO);
    }
}

TEST(Calibration, CaseAFdjIsWithinOneAndAHalfTimesTheEtaConfoundFloor) {
    const double floor = case_a_fdj_floor_normalised(800.0);
    std::cout << "case A FDJ floor (normalised MSE) " << floor << '\n';
    EXPECT_GT(floor, 1e-4);
    EXPECT_LT(floor, 1e-3);
    const auto r = run_set(sim::LoadCase::A, sim::Sequence::Dyn, sim::NoiseProfile::None);
    EXPECT_LE(r.score(kParamFdj).mse_normalised, kCaseAFloorFactor * floor);
    EXPECT_EQ(r.score(kParamEtaO).estimated, 0);
    expect_calibrated(r, kParamFdj);
}

TEST(Calibration, BrkFsjBothNoiseProfiles) {
    for (auto noise : {sim::NoiseProfile::None, sim::NoiseProfile::Typical}) {
        const auto r = run_set(sim::LoadCase::B, sim::Sequence::Brk, noise);
        EXPECT_EQ(r.failures, 0);
        expect_calibrated(r, kParamFsj);
    }
}

TEST(Calibration, CaseABrkFsjNoiseNoneCarriesTheEtaConfoundAtFullWeight) {
    // The 5 N m load makes the unknown eta a uniform error on FSJ; with the breakaway's Gaussian
    // error beside it, a quadrature sum under-covers (issue 4 calibration goal).
    const auto r = run_set(sim::LoadCase::A, sim::Sequence::Brk, sim::NoiseProfile::None);
    EXPECT_EQ(r.failures, 0);
    expect_calibrated(r, kParamFsj);
}

}  // namespace
}  // namespace emadiag
