// The health index and status against hand-computed cases (docs/health-index.md).
#include "core/emadiag_error.hpp"
#include "report/health_index.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace emadiag::report {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kTol = 1e-9;
constexpr double kFdjNominal = 0.08;
constexpr double kEtaANominal = 0.823788;
const prognostics::TrendLimit kFdjLimit{prognostics::LimitSide::Max, 0.096, 1};
const prognostics::TrendLimit kEtaALimit{prognostics::LimitSide::Min, 0.659, 1};

ParameterHealthInput fdj(double value, double se, std::optional<double> rul_lower = std::nullopt) {
    ParameterHealthInput in;
    in.parameter = "FDJ_Nm";
    in.value = value;
    in.std_error = se;
    in.nominal = kFdjNominal;
    in.limit = kFdjLimit;
    in.rul_lower_days = rul_lower;
    return in;
}

TEST(HealthIndex, FractionOfTheMarginLeft) {
    // (0.096 - 0.088) / (0.096 - 0.08) = 0.5
    EXPECT_NEAR(health_index("FDJ_Nm", 0.088, kFdjNominal, kFdjLimit), 0.5, kTol);
    EXPECT_NEAR(health_index("FDJ_Nm", kFdjNominal, kFdjNominal, kFdjLimit), 1.0, kTol);
    EXPECT_NEAR(health_index("FDJ_Nm", 0.096, kFdjNominal, kFdjLimit), 0.0, kTol);
    // Efficiency: (0.7 - 0.659) / (0.823788 - 0.659) = 0.041 / 0.164788 = 0.248804...
    EXPECT_NEAR(health_index("eta_A", 0.7, kEtaANominal, kEtaALimit), 0.041 / 0.164788, kTol);
}

TEST(HealthIndex, ClampedToZeroAndOne) {
    EXPECT_EQ(health_index("FDJ_Nm", 0.07, kFdjNominal, kFdjLimit), 1.0);  // better than new
    EXPECT_EQ(health_index("FDJ_Nm", 0.1, kFdjNominal, kFdjLimit), 0.0);   // past the limit
}

TEST(HealthIndex, NominalOnTheWrongSideIsAnError) {
    EXPECT_THAT([] { (void)health_index("FDJ_Nm", 0.09, 0.1, kFdjLimit); },
                ThrowsMessage<EmadiagError>(HasSubstr("health index of FDJ_Nm: nominal 0.1 is not below its max limit 0.096")));
    EXPECT_THAT([] { (void)health_index("eta_A", 0.7, 0.6, kEtaALimit); },
                ThrowsMessage<EmadiagError>(HasSubstr("nominal 0.6 is not above its min limit 0.659")));
    EXPECT_THAT([] { (void)health_index("FDJ_Nm", std::nan(""), kFdjNominal, kFdjLimit); },
                ThrowsMessage<EmadiagError>(HasSubstr("must be finite")));
}

TEST(AssessParameter, MonitorFromTheLowerIndex) {
    // h = 0.5; h95 = (0.096 - (0.088 + 1.959964 * 0.0005)) / 0.016 = 0.438751... < 0.5 -> MONITOR.
    const ParameterHealth h = assess_parameter(fdj(0.088, 0.0005));
    EXPECT_NEAR(*h.index, 0.5, kTol);
    EXPECT_NEAR(*h.index_lower_95, (0.096 - 0.088 - 1.959963984540054 * 0.0005) / 0.016, kTol);
    EXPECT_EQ(h.status, HealthStatus::Monitor);
    EXPECT_THAT(h.reason, HasSubstr("95 % lower index 0.4388 < 0.5"));
}

TEST(AssessParameter, OkWhenTheMarginIsWide) {
    // h = (0.096 - 0.082) / 0.016 = 0.875; h95 = (0.096 - 0.08298) / 0.016 = 0.81375.
    const ParameterHealth h = assess_parameter(fdj(0.082, 0.0005, 400.0));
    EXPECT_NEAR(*h.index, 0.875, kTol);
    EXPECT_EQ(h.status, HealthStatus::Ok);
}

TEST(AssessParameter, RulWindowsPlanAndMonitor) {
    EXPECT_EQ(assess_parameter(fdj(0.082, 0.0005, 179.0)).status, HealthStatus::Plan);
    EXPECT_THAT(assess_parameter(fdj(0.082, 0.0005, 179.0)).reason, HasSubstr("RUL 90 % lower bound 179 days < 180"));
    EXPECT_EQ(assess_parameter(fdj(0.082, 0.0005, 180.0)).status, HealthStatus::Monitor);
    EXPECT_EQ(assess_parameter(fdj(0.082, 0.0005, 364.0)).status, HealthStatus::Monitor);
    EXPECT_EQ(assess_parameter(fdj(0.082, 0.0005, 365.0)).status, HealthStatus::Ok);
}

TEST(AssessParameter, PlanFromALowEfficiency) {
    // eta_A 0.7 +/- 0.01: h = 0.248804, h95 = (0.7 - 0.0195996 - 0.659) / 0.164788 = 0.129866 < 0.25 -> PLAN.
    ParameterHealthInput in;
    in.parameter = "eta_A";
    in.value = 0.7;
    in.std_error = 0.01;
    in.nominal = kEtaANominal;
    in.limit = kEtaALimit;
    const ParameterHealth h = assess_parameter(in);
    EXPECT_NEAR(*h.index, 0.041 / 0.164788, kTol);
    EXPECT_NEAR(*h.index_lower_95, (0.7 - 1.959963984540054 * 0.01 - 0.659) / 0.164788, kTol);
    EXPECT_EQ(h.status, HealthStatus::Plan);
}

TEST(AssessParameter, ReplaceAtOrPastTheLimit) {
    EXPECT_EQ(assess_parameter(fdj(0.097, 0.0005)).status, HealthStatus::Replace);
    EXPECT_EQ(assess_parameter(fdj(0.096, 0.0005)).status, HealthStatus::Replace);
    EXPECT_EQ(*assess_parameter(fdj(0.097, 0.0005)).index, 0.0);
    ParameterHealthInput in;
    in.parameter = "FDJ_Nm";
    in.limit_already_exceeded = true;  // no measurement, but the trend says so
    EXPECT_EQ(assess_parameter(in).status, HealthStatus::Replace);
}

TEST(AssessParameter, NoDataWithoutMeasurementOrLimit) {
    ParameterHealthInput in = fdj(0.088, 0.0005);
    in.limit.reset();
    EXPECT_EQ(assess_parameter(in).status, HealthStatus::NoData);
    EXPECT_FALSE(assess_parameter(in).index);
    EXPECT_THAT(assess_parameter(in).reason, HasSubstr("no limit"));
    in = fdj(0.088, 0.0005);
    in.value.reset();
    EXPECT_THAT(assess_parameter(in).reason, HasSubstr("no measurement"));
}

TEST(AssessParameter, BadStandardErrorIsAnError) {
    EXPECT_THAT([] { (void)assess_parameter(fdj(0.088, -1)); },
                ThrowsMessage<EmadiagError>(HasSubstr("health index of FDJ_Nm: standard error -1")));
}

TEST(AssessPosition, MinimumIndexAndWorstStatus) {
    ParameterHealthInput eta;
    eta.parameter = "eta_A";
    eta.value = 0.8;  // h = (0.8 - 0.659) / 0.164788 = 0.855645
    eta.std_error = 0.001;
    eta.nominal = kEtaANominal;
    eta.limit = kEtaALimit;
    eta.rul_lower_days = 100;  // -> PLAN
    ParameterHealthInput none;
    none.parameter = "eta_O";
    const PositionHealth p = assess_position({fdj(0.088, 0.0005), eta, none});
    EXPECT_NEAR(*p.index, 0.5, kTol);
    EXPECT_EQ(p.index_parameter, "FDJ_Nm");
    EXPECT_EQ(p.status, HealthStatus::Plan);
    EXPECT_EQ(p.status_parameter, "eta_A");
    ASSERT_EQ(p.parameters.size(), 3u);
    EXPECT_EQ(p.parameters[2].status, HealthStatus::NoData);
}

TEST(AssessPosition, NoDataAtAll) {
    ParameterHealthInput none;
    none.parameter = "eta_O";
    const PositionHealth p = assess_position({none});
    EXPECT_EQ(p.status, HealthStatus::NoData);
    EXPECT_FALSE(p.index);
    EXPECT_STREQ(to_string(p.status), "NO DATA");
}

}  // namespace
}  // namespace emadiag::report
