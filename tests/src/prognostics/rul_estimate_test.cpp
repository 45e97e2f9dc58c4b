// The limit crossing and the remaining useful life: exact on noise-free data for both models, the
// special cases (insufficient data, already exceeded, flat or improving, beyond the horizon), the
// seeded Monte Carlo interval, and the option checks.
#include "core/emadiag_error.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/synthetic_history.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace emadiag::prognostics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kDayTolerance = 1e-6;
constexpr TrendLimit kFdjMax{LimitSide::Max, 0.096, 8};

/// FDJ 0.08 N m rising 0.004 N m per 100 days, 8 sessions 30 days apart: the limit 0.096 is reached
/// at day 400, 190 days after the last session (day 210).
constexpr double kStart = 0.08, kRatePerDay = 4e-5;
constexpr double kTrueCrossingDays = 400.0, kLastDay = 210.0;

std::vector<TrendPoint> drift(double start, double rate_per_day, int sessions = 8) {
    return synthetic_points({sessions, 30.0, 0.0005}, [=](double t) { return start + rate_per_day * t; }, nullptr);
}

TEST(RulEstimate, LinearCrossingAndRulAreExactWithoutNoise) {
    const auto pts = drift(kStart, kRatePerDay);
    const ModelFits m = fit_models(pts);
    ASSERT_EQ(m.choice.model, DegradationModel::Linear) << m.choice.reason;
    const RulEstimate r = estimate_rul(pts, m.chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::Predicted);
    ASSERT_TRUE(r.crossing_t_days && r.rul_days);
    EXPECT_NEAR(*r.crossing_t_days, kTrueCrossingDays, kDayTolerance);
    EXPECT_NEAR(*r.rul_days, kTrueCrossingDays - kLastDay, kDayTolerance);
    EXPECT_EQ(r.summary, "crossing predicted at day 400, RUL 190 days");
    ASSERT_TRUE(r.rul_lower_days && r.rul_upper_days);
    EXPECT_LT(*r.rul_lower_days, *r.rul_days);
    EXPECT_GT(*r.rul_upper_days, *r.rul_days);
    EXPECT_EQ(r.draws, kDefaultMonteCarloDraws);
    EXPECT_EQ(r.draws_beyond_horizon, 0);
}

TEST(RulEstimate, LogLinearCrossingIsExactWithoutNoise) {
    // Efficiency decaying as 0.8 e^(-t/1000) against a minimum of 0.6: t = 1000 ln(0.8/0.6) = 287.7.
    const auto pts = synthetic_points({8, 30.0, 0.002}, [](double t) { return 0.8 * std::exp(-t / 1000.0); }, nullptr);
    const DegradationFit f = fit_log_linear(pts);
    const RulEstimate r = estimate_rul(pts, f, TrendLimit{LimitSide::Min, 0.6, 8}, {});
    EXPECT_EQ(r.status, RulStatus::Predicted);
    ASSERT_TRUE(r.crossing_t_days);
    EXPECT_NEAR(*r.crossing_t_days, 1000.0 * std::log(0.8 / 0.6), kDayTolerance);
    EXPECT_NEAR(*r.rul_days, 1000.0 * std::log(0.8 / 0.6) - kLastDay, kDayTolerance);
}

TEST(RulEstimate, FewerThanThreeSessionsIsInsufficientDataNotAnError) {
    const auto pts = drift(kStart, kRatePerDay, 2);
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::InsufficientData);
    EXPECT_EQ(r.summary, "insufficient data (2 sessions; need >= 3)");
    EXPECT_FALSE(r.rul_days.has_value());
    EXPECT_FALSE(r.interval_computed);
}

TEST(RulEstimate, ALastMeasurementBeyondTheLimitIsRulZero) {
    auto pts = drift(kStart, kRatePerDay, 5);
    pts.back().value = 0.0965;
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::AlreadyExceeded);
    ASSERT_TRUE(r.rul_days);
    EXPECT_EQ(*r.rul_days, 0.0);
    EXPECT_EQ(r.exceeded_session_id, 5);
    EXPECT_THAT(r.summary, AllOf(HasSubstr("limit already exceeded at session 5"), HasSubstr("0.0965 against max 0.096")));
}

TEST(RulEstimate, AlreadyExceededIsReportedEvenWithTooFewSessions) {
    auto pts = drift(0.1, 0.0, 1);
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::AlreadyExceeded);
    EXPECT_THAT(r.summary, HasSubstr("limit already exceeded at session 1"));
}

TEST(RulEstimate, AFlatTrendPredictsNoCrossing) {
    const auto pts = drift(kStart, 0.0);
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::NoCrossing);
    EXPECT_THAT(r.summary, HasSubstr("no crossing predicted within the horizon (3650 days)"));
    EXPECT_FALSE(r.rul_days.has_value());
    EXPECT_FALSE(r.rul_upper_days.has_value());  // "> horizon"
}

TEST(RulEstimate, AnImprovingTrendPredictsNoCrossing) {
    const auto pts = drift(kStart, -kRatePerDay);
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, {});
    EXPECT_EQ(r.status, RulStatus::NoCrossing);
    EXPECT_EQ(r.summary, "no crossing predicted within the horizon (3650 days): the trend is flat or moving away from the limit");
    EXPECT_EQ(r.draws_beyond_horizon, r.draws);
}

TEST(RulEstimate, ACrossingLaterThanTheHorizonIsNoCrossing) {
    const auto pts = drift(kStart, kRatePerDay);
    RulOptions o;
    o.horizon_days = 100;  // the crossing is 190 days after the last session
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), kFdjMax, o);
    EXPECT_EQ(r.status, RulStatus::NoCrossing);
    EXPECT_EQ(r.summary, "no crossing predicted within the horizon (100 days)");
    EXPECT_GT(r.draws_beyond_horizon, r.draws / 2);
}

TEST(RulEstimate, NoLimitNoCrossing) {
    const auto pts = drift(kStart, kRatePerDay);
    const RulEstimate r = estimate_rul(pts, fit_models(pts).chosen(), std::nullopt, {});
    EXPECT_EQ(r.status, RulStatus::NoLimit);
}

TEST(RulEstimate, TheIntervalIsReproducibleFromTheRecordedSeed) {
    NormalSampler noise(5);
    const auto pts = synthetic_points({8, 30.0, 0.0005}, [](double t) { return kStart + kRatePerDay * t; }, &noise);
    const DegradationFit f = fit_models(pts).chosen();
    RulOptions o;
    o.seed = 42;
    const RulEstimate a = estimate_rul(pts, f, kFdjMax, o), b = estimate_rul(pts, f, kFdjMax, o);
    EXPECT_EQ(a.seed, 42u);
    ASSERT_TRUE(a.rul_lower_days && b.rul_lower_days && a.rul_upper_days && b.rul_upper_days);
    EXPECT_EQ(*a.rul_lower_days, *b.rul_lower_days);
    EXPECT_EQ(*a.rul_upper_days, *b.rul_upper_days);
    o.seed = 43;
    const RulEstimate c = estimate_rul(pts, f, kFdjMax, o);
    EXPECT_NE(*a.rul_lower_days, *c.rul_lower_days);
}

TEST(RulEstimate, OptionsOutOfRangeAreNamed) {
    const auto pts = drift(kStart, kRatePerDay);
    const DegradationFit f = fit_models(pts).chosen();
    RulOptions o;
    o.draws = 10;
    EXPECT_THAT([&] { (void)estimate_rul(pts, f, kFdjMax, o); },
                ThrowsMessage<EmadiagError>(HasSubstr("Monte Carlo draws 10 is not in [100, ")));
    o = {};
    o.horizon_days = -1;
    EXPECT_THAT([&] { (void)estimate_rul(pts, f, kFdjMax, o); }, ThrowsMessage<EmadiagError>(HasSubstr("horizon_days -1 is not in (0, ")));
}

TEST(NormalSampler, DrawsHaveMeanZeroAndUnitVariance) {
    constexpr int kDraws = 200000;
    constexpr double kMomentTolerance = 0.01;  // about 4 standard errors of each moment at 2e5 draws
    NormalSampler n(7);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < kDraws; ++i) {
        const double z = n.next();
        sum += z;
        sum2 += z * z;
    }
    EXPECT_NEAR(sum / kDraws, 0.0, kMomentTolerance);
    EXPECT_NEAR(sum2 / kDraws, 1.0, kMomentTolerance);
}

}  // namespace
}  // namespace emadiag::prognostics
