// The ProgPy prognostic metrics against hand-computed profiles.
#include "core/emadiag_error.hpp"
#include "prognostics/prognostics_metrics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

namespace emadiag::prognostics {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// EoL at 100. Predictions at 20, 40, 60, 80; true RULs 80, 60, 40, 20.
std::vector<RulPrediction> profile() {
    return {
        {20, 50.0, {40, 50, 60, kInf}},     // bounds (alpha 0.2) [64, 96]: 0 of 4 within
        {40, 55.0, {50, 55, 70, 75}},       // [48, 72]: 50, 55, 70 -> 3 of 4
        {60, 41.0, {30, 41, 45, 60}},       // [32, 48]: 41, 45 -> 2 of 4
        {80, 20.0, {16, 20, 24, 30}},       // [16, 24]: 16, 20, 24 (bounds included) -> 3 of 4
    };
}

TEST(FractionWithinAlpha, BoundsIncludedInfinityOutside) {
    EXPECT_DOUBLE_EQ(fraction_within_alpha({16, 20, 24, 30}, 20, 0.2), 0.75);
    EXPECT_DOUBLE_EQ(fraction_within_alpha({kInf, 100}, 100, 0.2), 0.5);
    EXPECT_DOUBLE_EQ(fraction_within_alpha({0}, 10, 0.5), 0.0);
}

TEST(AlphaLambda, UsesThePredictionAtOrAfterLambda) {
    // t_P = 20, lambda 0.5: t_lambda = 20 + 0.5 (100 - 20) = 60 -> the prediction at 60: 2 of 4 within.
    const AlphaLambdaResult r = alpha_lambda(profile(), 100, 0.5, 0.2, 0.5);
    EXPECT_TRUE(r.evaluated);
    EXPECT_DOUBLE_EQ(r.t_lambda, 60);
    EXPECT_DOUBLE_EQ(r.t_evaluated, 60);
    EXPECT_DOUBLE_EQ(r.true_rul, 40);
    EXPECT_DOUBLE_EQ(r.fraction_within, 0.5);
    EXPECT_TRUE(r.met);  // 0.5 >= beta 0.5
    EXPECT_FALSE(alpha_lambda(profile(), 100, 0.5, 0.2, 0.6).met);
    // lambda 0.3: t_lambda = 44 -> the next prediction, at 60.
    EXPECT_DOUBLE_EQ(alpha_lambda(profile(), 100, 0.3, 0.2, 0.5).t_evaluated, 60);
    // lambda 0.25: t_lambda = 40 exactly -> the prediction at 40, 3 of 4.
    EXPECT_DOUBLE_EQ(alpha_lambda(profile(), 100, 0.25, 0.2, 0.5).fraction_within, 0.75);
    // lambda 0.9: t_lambda = 92, no prediction at or after it.
    EXPECT_FALSE(alpha_lambda(profile(), 100, 0.9, 0.2, 0.5).evaluated);
}

TEST(RelativeAccuracy, OneMinusTheRelativeError) {
    EXPECT_DOUBLE_EQ(relative_accuracy(41, 40), 0.975);
    EXPECT_DOUBLE_EQ(relative_accuracy(30, 40), 0.75);
    EXPECT_DOUBLE_EQ(relative_accuracy(40, 40), 1.0);
    EXPECT_DOUBLE_EQ(relative_accuracy(100, 40), -0.5);
    EXPECT_THAT([] { (void)relative_accuracy(10, 0); }, ThrowsMessage<EmadiagError>(HasSubstr("true RUL 0")));
}

TEST(PrognosticHorizon, FirstPredictionMeetingTheCriterion) {
    // beta 0.5: the prediction at 40 (3 of 4) is the first -> PH = 100 - 40 = 60.
    EXPECT_DOUBLE_EQ(*prognostic_horizon(profile(), 100, 0.2, 0.5), 60);
    // beta 0.75: also the one at 40.
    EXPECT_DOUBLE_EQ(*prognostic_horizon(profile(), 100, 0.2, 0.75), 60);
    // beta 1: none has all four within.
    EXPECT_FALSE(prognostic_horizon(profile(), 100, 0.2, 1.0));
    // alpha 0.5 at t = 20: bounds [40, 120] hold 40, 50, 60 -> 3 of 4 -> PH 80.
    EXPECT_DOUBLE_EQ(*prognostic_horizon(profile(), 100, 0.5, 0.5), 80);
}

TEST(PrognosticMetrics, BadInputIsNamed) {
    auto p = profile();
    p[2].t = 30;
    EXPECT_THAT([&] { (void)prognostic_horizon(p, 100, 0.2, 0.5); },
                ThrowsMessage<EmadiagError>(HasSubstr("prediction 2 time 30 is not after prediction 1's 40")));
    EXPECT_THAT([] { (void)alpha_lambda(profile(), 70, 0.5, 0.2, 0.5); },
                ThrowsMessage<EmadiagError>(HasSubstr("prediction 3 time 80 is not before the true end of life 70")));
    EXPECT_THAT([] { (void)alpha_lambda(profile(), 100, 1.5, 0.2, 0.5); }, ThrowsMessage<EmadiagError>(HasSubstr("lambda 1.5")));
    EXPECT_THAT([] { (void)alpha_lambda(profile(), 100, 0.5, 0, 0.5); }, ThrowsMessage<EmadiagError>(HasSubstr("alpha 0")));
    EXPECT_THAT([] { (void)alpha_lambda(profile(), 100, 0.5, 0.2, 0); }, ThrowsMessage<EmadiagError>(HasSubstr("beta 0")));
    EXPECT_THAT([] { (void)fraction_within_alpha({1, std::nan("")}, 10, 0.2); },
                ThrowsMessage<EmadiagError>(HasSubstr("RUL sample 1 is NaN")));
    EXPECT_THAT([] { (void)fraction_within_alpha({}, 10, 0.2); }, ThrowsMessage<EmadiagError>(HasSubstr("no RUL samples")));
}

}  // namespace
}  // namespace emadiag::prognostics
