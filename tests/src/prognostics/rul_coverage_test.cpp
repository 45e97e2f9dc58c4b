// Property: over many synthetic linear-drift histories with Gaussian noise of known se, the 90 % RUL
// interval covers the true RUL in about 90 % of them (85 % to 95 % accepted: the binomial spread at
// 200 histories is +/- 2.1 %, and the max(1, reduced chi2) scaling and the model choice may widen or
// shift the intervals a little). Seed and count: EMADIAG_TEST_SEED, EMADIAG_TEST_COUNT.
#include "prognostics/degradation_fit.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/synthetic_history.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

namespace emadiag::prognostics {
namespace {

constexpr int kDefaultHistories = 200;
constexpr double kMinCoverage = 0.85;
constexpr double kMaxCoverage = 0.95;
constexpr double kLimitNm = 0.096;
constexpr double kStartNm = 0.08;
/// Drift and noise ranges of the histories (per day, N m).
constexpr double kMinRateNmPerDay = 2e-5, kMaxRateNmPerDay = 5e-5;
constexpr double kMinSeNm = 3e-4, kMaxSeNm = 1e-3;
constexpr int kMinSessions = 6, kMaxSessions = 10;
constexpr double kDaysBetween = 30.0;

std::uint64_t env_or(const char* name, std::uint64_t fallback) {
    const char* v = std::getenv(name);
    return v ? std::strtoull(v, nullptr, 10) : fallback;
}

TEST(RulCoverage, NinetyPercentIntervalCoversTheTrueRulAboutNinetyPercentOfTheTime) {
    const std::uint64_t seed = env_or("EMADIAG_TEST_SEED", 20261123ULL);
    const int count = static_cast<int>(env_or("EMADIAG_TEST_COUNT", kDefaultHistories));
    SCOPED_TRACE("seed " + std::to_string(seed) + ", " + std::to_string(count) + " histories (EMADIAG_TEST_SEED, EMADIAG_TEST_COUNT)");
    ASSERT_GT(count, 0);
    NormalSampler rng(seed);
    int covered = 0, log_linear_chosen = 0;
    for (int i = 0; i < count; ++i) {
        const double rate = kMinRateNmPerDay + (kMaxRateNmPerDay - kMinRateNmPerDay) * rng.uniform();
        const double se = kMinSeNm + (kMaxSeNm - kMinSeNm) * rng.uniform();
        const int sessions = kMinSessions + static_cast<int>(rng.uniform() * (kMaxSessions - kMinSessions + 1));
        const SyntheticHistory h{sessions, kDaysBetween, se};
        const auto pts = synthetic_points(h, [&](double t) { return kStartNm + rate * t; }, &rng);
        const double true_rul = (kLimitNm - kStartNm) / rate - pts.back().t_days;
        const ModelFits m = fit_models(pts);
        if (m.choice.model == DegradationModel::LogLinear) ++log_linear_chosen;
        RulOptions o;
        o.seed = seed + static_cast<std::uint64_t>(i);
        const RulEstimate r = estimate_rul(pts, m.chosen(), TrendLimit{LimitSide::Max, kLimitNm, sessions}, o);
        const bool lo_ok = r.rul_lower_days ? *r.rul_lower_days <= true_rul : false;  // a lower bound beyond the horizon misses
        const bool hi_ok = r.rul_upper_days ? true_rul <= *r.rul_upper_days : true;   // "> horizon" covers
        if (r.interval_computed && lo_ok && hi_ok) ++covered;
    }
    const double coverage = static_cast<double>(covered) / count;
    std::printf("[ RUL coverage ] seed %llu: %d of %d histories covered (%.1f %%); log-linear chosen in %d\n",
                static_cast<unsigned long long>(seed), covered, count, 100.0 * coverage, log_linear_chosen);
    EXPECT_GE(coverage, kMinCoverage);
    EXPECT_LE(coverage, kMaxCoverage);
}

}  // namespace
}  // namespace emadiag::prognostics
