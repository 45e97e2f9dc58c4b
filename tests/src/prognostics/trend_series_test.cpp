// One measurement per session and parameter from the stored findings: the inverse-variance mean of
// the physics findings, the network left out, sessions without a value skipped with a note, the most
// recent limit, and the message for a session whose start time is not a UTC time.
#include "core/emadiag_error.hpp"
#include "prognostics/trend_series.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace emadiag::prognostics {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kTolerance = 1e-12;

db::StoredFinding finding(const std::string& parameter, const std::string& estimator, std::optional<double> value, double se,
                          double limit = 0.096) {
    db::StoredFinding f;
    f.parameter = parameter;
    f.estimator = estimator;
    f.value = value;
    if (value) f.std_error = se;
    f.limit_value = limit;
    f.limit_kind = "max";
    f.status = value ? "WITHIN" : "NOT_IDENTIFIABLE";
    return f;
}

db::StoredTestSession session(std::int64_t id, const std::string& utc, std::vector<db::StoredFinding> findings) {
    db::StoredTestSession s;
    s.session_id = id;
    s.tail_number = "N123EM";
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.verdict = "SERVICEABLE";
    s.findings = std::move(findings);
    return s;
}

TEST(TrendSeries, CombinesThePhysicsFindingsByInverseVariance) {
    const std::vector<db::StoredTestSession> sessions{
        session(1, "2026-01-05T08:00:00Z",
                {finding("FDJ_Nm", "physics:dyn", 0.080, 0.001), finding("FDJ_Nm", "physics:brk", 0.083, 0.002),
                 finding("FDJ_Nm", "network:dyn", 0.070, 0.0001)}),
        session(2, "2026-01-15T20:00:00Z", {finding("FDJ_Nm", "physics:dyn", 0.081, 0.001)}),
    };
    const auto days = session_days(sessions);
    const ParameterSeries s = build_series(sessions, days, "FDJ_Nm", days.front());
    ASSERT_EQ(s.points.size(), 2u);
    // w = 1e6 and 2.5e5: (0.080 * 1e6 + 0.083 * 2.5e5) / 1.25e6 = 0.0806; se = 1 / sqrt(1.25e6).
    EXPECT_NEAR(s.points[0].value, 0.0806, kTolerance);
    EXPECT_NEAR(s.points[0].std_error, 1.0 / std::sqrt(1.25e6), kTolerance);
    EXPECT_THAT(s.points[0].estimators, ElementsAre("physics:dyn", "physics:brk"));
    EXPECT_NEAR(s.points[0].t_days, 0.0, kTolerance);
    EXPECT_NEAR(s.points[1].t_days, 10.5, 1e-9);
    EXPECT_EQ(s.points[1].session_id, 2);
    ASSERT_TRUE(s.limit.has_value());
    EXPECT_EQ(s.limit->side, LimitSide::Max);
    EXPECT_DOUBLE_EQ(s.limit->value, 0.096);
}

TEST(TrendSeries, SkipsSessionsWithoutAPhysicsValueAndSaysWhich) {
    const std::vector<db::StoredTestSession> sessions{
        session(4, "2026-01-05T08:00:00Z", {finding("eta_O", "physics:dyn", std::nullopt, 0)}),
        session(5, "2026-02-05T08:00:00Z", {finding("eta_O", "physics:dyn", 0.8, 0.01)}),
        session(6, "2026-03-05T08:00:00Z", {finding("eta_O", "network:dyn", 0.8, 0.01)}),
    };
    const auto days = session_days(sessions);
    const ParameterSeries s = build_series(sessions, days, "eta_O", days.front());
    ASSERT_EQ(s.points.size(), 1u);
    EXPECT_EQ(s.points[0].session_id, 5);
    EXPECT_THAT(s.notes, ElementsAre(AllOf(HasSubstr("2 session(s) without a physics value of eta_O"), HasSubstr(": 4, 6"))));
}

TEST(TrendSeries, AFindingWithoutStandardErrorIsNotUsedAndNoted) {
    auto f = finding("FDJ_Nm", "physics:dyn", 0.08, 0.0);
    const std::vector<db::StoredTestSession> sessions{session(1, "2026-01-05T08:00:00Z", {f})};
    const ParameterSeries s = build_series(sessions, session_days(sessions), "FDJ_Nm", 0);
    EXPECT_TRUE(s.points.empty());
    EXPECT_THAT(s.notes, ::testing::Contains(HasSubstr("without a positive standard error")));
}

TEST(TrendSeries, TheMostRecentLimitWinsAndAChangeIsNoted) {
    const std::vector<db::StoredTestSession> sessions{
        session(1, "2026-01-05T08:00:00Z", {finding("FDJ_Nm", "physics:dyn", 0.08, 0.001, 0.096)}),
        session(2, "2026-02-05T08:00:00Z", {finding("FDJ_Nm", "physics:dyn", 0.08, 0.001, 0.090)}),
    };
    const ParameterSeries s = build_series(sessions, session_days(sessions), "FDJ_Nm", 0);
    ASSERT_TRUE(s.limit.has_value());
    EXPECT_DOUBLE_EQ(s.limit->value, 0.090);
    EXPECT_EQ(s.limit->session_id, 2);
    EXPECT_THAT(s.notes, ElementsAre(HasSubstr("the limit changed from max 0.096 (session 1) to max 0.09 (session 2)")));
}

TEST(TrendSeries, ABadStartTimeNamesEverySessionAndValue) {
    const std::vector<db::StoredTestSession> sessions{
        session(1, "2026-01-05T08:00:00Z", {}),
        session(7, "2026-13-01T08:00:00Z", {}),
        session(9, "2026-01-05T08:00:00+01:00", {}),
    };
    EXPECT_THAT([&] { (void)session_days(sessions); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("2 test session(s)"), HasSubstr("test session 7 started_utc \"2026-13-01T08:00:00Z\""),
                                                  HasSubstr("month 13"), HasSubstr("test session 9"), HasSubstr("time zone offsets"))));
}

}  // namespace
}  // namespace emadiag::prognostics
