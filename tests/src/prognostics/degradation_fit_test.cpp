// The degradation fits: weighted least squares against the closed form, the covariance scaled by
// the scatter, the model choice by AICc, and the cases where a model cannot be fitted.
#include "prognostics/degradation_fit.hpp"
#include "prognostics/synthetic_history.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

namespace emadiag::prognostics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr double kTolerance = 1e-10;
constexpr double kRelTolerance = 1e-9;

std::uint64_t test_seed() {
    const char* env = std::getenv("EMADIAG_TEST_SEED");
    return env ? std::strtoull(env, nullptr, 10) : 20261123ULL;
}

std::vector<TrendPoint> points(const std::vector<double>& t, const std::vector<double>& y, const std::vector<double>& se) {
    std::vector<TrendPoint> out;
    for (std::size_t i = 0; i < t.size(); ++i) out.push_back({static_cast<std::int64_t>(i + 1), "", t[i], y[i], se[i], {}});
    return out;
}

TEST(DegradationFit, EqualWeightsGiveTheTextbookLine) {
    // t = 0, 1, 2; y = 1, 2, 4; se = 1: b = Sxy/Sxx = 3/2, a = ybar - b tbar = 7/3 - 3/2 = 5/6;
    // var b = 1/Sxx = 1/2, var a = 1/n + tbar^2/Sxx = 5/6, cov = -tbar/Sxx = -1/2;
    // residuals 1/6, -1/3, 1/6: chi2 = 1/6 < dof 1, so the covariance is not scaled.
    const DegradationFit f = fit_linear(points({0, 1, 2}, {1, 2, 4}, {1, 1, 1}));
    ASSERT_TRUE(f.fitted) << f.note;
    EXPECT_NEAR(f.a, 5.0 / 6.0, kTolerance);
    EXPECT_NEAR(f.b, 1.5, kTolerance);
    EXPECT_NEAR(f.chi2, 1.0 / 6.0, kTolerance);
    EXPECT_NEAR(f.reduced_chi2, 1.0 / 6.0, kTolerance);
    EXPECT_DOUBLE_EQ(f.covariance_scale, 1.0);
    EXPECT_NEAR(f.covariance(0, 0), 5.0 / 6.0, kTolerance);
    EXPECT_NEAR(f.covariance(1, 1), 0.5, kTolerance);
    EXPECT_NEAR(f.covariance(0, 1), -0.5, kTolerance);
    EXPECT_NEAR(f.covariance(1, 0), -0.5, kTolerance);
}

TEST(DegradationFit, MoreScatterThanTheStandardErrorsClaimWidensTheCovariance) {
    // The same points with se = 0.1: chi2 = (1/6) / 0.01 = 50/3 on 1 dof, so the covariance
    // (1/Sxx = 0.01/2 for b) is scaled by 50/3.
    const DegradationFit f = fit_linear(points({0, 1, 2}, {1, 2, 4}, {0.1, 0.1, 0.1}));
    ASSERT_TRUE(f.fitted);
    EXPECT_NEAR(f.b, 1.5, kTolerance);
    EXPECT_NEAR(f.covariance_scale, 50.0 / 3.0, 1e-9);
    EXPECT_NEAR(f.covariance(1, 1), 0.005 * 50.0 / 3.0, 1e-12);
}

TEST(DegradationFit, UnequalWeightsMatchTheNormalEquations) {
    const std::vector<double> t{0, 30, 60, 90, 150}, y{0.081, 0.0808, 0.0835, 0.0839, 0.0871}, se{0.0005, 0.001, 0.0004, 0.002, 0.0006};
    const DegradationFit f = fit_linear(points(t, y, se));
    ASSERT_TRUE(f.fitted);
    // The normal equations (X' W X) p = X' W y solved independently (Eigen, fixed size).
    Eigen::Matrix2d n = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < t.size(); ++i) {
        const Eigen::Vector2d x(1.0, t[i]);
        const double w = 1 / (se[i] * se[i]);
        n += w * x * x.transpose();
        rhs += w * y[i] * x;
    }
    const Eigen::Vector2d p = n.inverse() * rhs;
    double chi2 = 0;
    for (std::size_t i = 0; i < t.size(); ++i) chi2 += std::pow((y[i] - p(0) - p(1) * t[i]) / se[i], 2);
    const Eigen::Matrix2d cov = n.inverse() * std::max(1.0, chi2 / 3);
    EXPECT_NEAR(f.a, p(0), kRelTolerance * std::abs(p(0)));
    EXPECT_NEAR(f.b, p(1), kRelTolerance * std::abs(p(1)));
    EXPECT_NEAR(f.chi2, chi2, kRelTolerance * chi2);
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) EXPECT_NEAR(f.covariance(i, j), cov(i, j), kRelTolerance * std::abs(cov(i, j)));
}

TEST(DegradationFit, LogLinearFitsLnYWithRelativeStandardErrors) {
    // Exact exponential growth y = 0.05 e^(t/200): ln y = ln 0.05 + t/200, recovered exactly.
    SyntheticHistory h{6, 60.0, 0.001};
    const auto pts = synthetic_points(h, [](double t) { return 0.05 * std::exp(t / 200.0); }, nullptr);
    const DegradationFit f = fit_log_linear(pts);
    ASSERT_TRUE(f.fitted);
    EXPECT_NEAR(f.a, std::log(0.05), kTolerance);
    EXPECT_NEAR(f.b, 1.0 / 200.0, kTolerance);
    EXPECT_NEAR(f.chi2, 0.0, kTolerance);
    EXPECT_NEAR(f.mean_at(100), 0.05 * std::exp(0.5), kTolerance);
    const auto [slope, se] = f.slope_at(100);
    EXPECT_NEAR(slope, 0.05 * std::exp(0.5) / 200.0, kTolerance);
    EXPECT_GT(se, 0.0);
}

TEST(DegradationFit, AiccPicksLinearOnLinearData) {
    const std::uint64_t seed = test_seed();
    SCOPED_TRACE("seed " + std::to_string(seed) + " (set EMADIAG_TEST_SEED to change)");
    NormalSampler noise(seed);
    // FDJ from 0.05 to 0.116 N m over 330 days: a line, far from an exponential over that range.
    SyntheticHistory h{12, 30.0, 0.0005};
    const ModelFits m = fit_models(synthetic_points(h, [](double t) { return 0.05 + 2e-4 * t; }, &noise));
    ASSERT_TRUE(m.linear.aicc && m.log_linear.aicc);
    EXPECT_LT(*m.linear.aicc, *m.log_linear.aicc - kAiccPreferenceMargin);
    EXPECT_EQ(m.choice.model, DegradationModel::Linear);
    EXPECT_THAT(m.choice.reason, StartsWith("linear: AICc"));
}

TEST(DegradationFit, AiccPicksLogLinearOnExponentialData) {
    const std::uint64_t seed = test_seed();
    SCOPED_TRACE("seed " + std::to_string(seed) + " (set EMADIAG_TEST_SEED to change)");
    NormalSampler noise(seed);
    SyntheticHistory h{12, 30.0, 0.0005};
    const ModelFits m = fit_models(synthetic_points(h, [](double t) { return 0.05 * std::exp(t / 200.0); }, &noise));
    EXPECT_EQ(m.choice.model, DegradationModel::LogLinear) << m.choice.reason;
    EXPECT_THAT(m.choice.reason, StartsWith("log-linear: AICc"));
    EXPECT_NEAR(m.chosen().b, 1.0 / 200.0, 4.0 * std::sqrt(m.chosen().covariance(1, 1)));
}

TEST(DegradationFit, ThreeSessionsLeaveAiccUndefinedAndTheLineChosen) {
    const ModelFits m = fit_models(points({0, 30, 60}, {0.08, 0.081, 0.083}, {0.001, 0.001, 0.001}));
    EXPECT_FALSE(m.linear.aicc.has_value());
    EXPECT_EQ(m.choice.model, DegradationModel::Linear);
    EXPECT_THAT(m.choice.reason, HasSubstr("AICc is undefined"));
}

TEST(DegradationFit, TooFewPointsIsInsufficientData) {
    const DegradationFit f = fit_linear(points({0, 30}, {0.08, 0.081}, {0.001, 0.001}));
    EXPECT_FALSE(f.fitted);
    EXPECT_EQ(f.note, "insufficient data (2 sessions; need >= 3)");
}

TEST(DegradationFit, LogLinearNeedsPositiveValues) {
    const DegradationFit f = fit_log_linear(points({0, 30, 60}, {0.01, -0.002, 0.01}, {0.01, 0.01, 0.01}));
    EXPECT_FALSE(f.fitted);
    EXPECT_THAT(f.note, AllOf(HasSubstr("session 2"), HasSubstr("not positive")));
    const ModelFits m = fit_models(points({0, 30, 60}, {0.01, -0.002, 0.01}, {0.01, 0.01, 0.01}));
    EXPECT_EQ(m.choice.model, DegradationModel::Linear);
    EXPECT_THAT(m.choice.reason, HasSubstr("log-linear model could not be fitted"));
}

TEST(DegradationFit, PointsAllAtOneTimeHaveNoTrend) {
    const DegradationFit f = fit_linear(points({5, 5, 5}, {0.08, 0.081, 0.079}, {0.001, 0.001, 0.001}));
    EXPECT_FALSE(f.fitted);
    EXPECT_THAT(f.note, HasSubstr("same time"));
}

}  // namespace
}  // namespace emadiag::prognostics
