// The whole report from a maintenance database (":memory:"): the phase filter, the time axis from the
// tail's first session, the per-parameter results, the JSON schema, and the unknown-tail message.
#include "core/emadiag_error.hpp"
#include "emadiag/db/database.hpp"
#include "emadiag/db/test_session_store.hpp"
#include "prognostics/trend_report.hpp"
#include "prognostics/utc_time.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace emadiag::prognostics {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kDayTolerance = 1e-6;
constexpr double kFdjLimitNm = 0.096;

db::StoredFinding fdj(double value, double se) {
    db::StoredFinding f;
    f.parameter = "FDJ_Nm";
    f.estimator = "physics:dyn";
    f.value = value;
    f.std_error = se;
    f.limit_value = kFdjLimitNm;
    f.limit_kind = "max";
    f.status = "WITHIN";
    return f;
}

/// Stores sessions every 30 days from 2026-01-05 with FDJ 0.08 + 4e-5 t (exact), alternating phases
/// when `mixed` (even index pre-flight, odd post-flight).
void store_history(db::Database& database, const std::string& tail, int sessions, bool mixed) {
    const double start = parse_utc_days_or_throw("2026-01-05T08:00:00Z", "start");
    for (int i = 0; i < sessions; ++i) {
        db::StoredTestSession s;
        s.tail_number = tail;
        s.phase = mixed && i % 2 == 1 ? "post-flight" : "pre-flight";
        s.started_utc = format_utc_time(start + 30.0 * i);
        s.verdict = "SERVICEABLE";
        s.findings.push_back(fdj(0.08 + 4e-5 * 30.0 * i, 0.0005));
        (void)db::store_test_session(database, s);
    }
}

TEST(TrendReport, PredictsTheCrossingOfAnExactDriftFromTheDatabase) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, false);
    const TrendReport r = load_trend_report(database, "N123EM", {});
    EXPECT_EQ(r.sessions_total, 8);
    EXPECT_EQ(r.sessions_in_phase, 8);
    EXPECT_EQ(r.origin_utc, "2026-01-05T08:00:00Z");
    ASSERT_EQ(r.parameters.size(), 4u);
    const ParameterTrend& p = r.parameters[0];
    EXPECT_EQ(p.series.parameter, "FDJ_Nm");
    EXPECT_EQ(p.rul.status, RulStatus::Predicted);
    EXPECT_NEAR(*p.rul.crossing_t_days, 400.0, kDayTolerance);
    EXPECT_NEAR(*p.rul.rul_days, 190.0, kDayTolerance);
    EXPECT_NEAR(*p.trend_per_period, 0.004, 1e-12);
    EXPECT_EQ(format_utc_date(*p.crossing_days_since_epoch), "2027-02-09");
    EXPECT_EQ(r.parameters[1].rul.status, RulStatus::InsufficientData);
    EXPECT_EQ(r.parameters[1].rul.summary, "insufficient data (0 sessions; need >= 3)");
}

TEST(TrendReport, ThePhaseFilterKeepsTheTimeAxisOfTheTail) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, true);
    TrendOptions o;
    o.phase = "post-flight";
    const TrendReport r = load_trend_report(database, "N123EM", o);
    EXPECT_EQ(r.sessions_total, 8);
    EXPECT_EQ(r.sessions_in_phase, 4);
    EXPECT_THAT(r.notes, ElementsAre(HasSubstr("4 of the tail's 8 test sessions are of another phase and left out")));
    const auto& pts = r.parameters[0].series.points;
    ASSERT_EQ(pts.size(), 4u);
    EXPECT_NEAR(pts.front().t_days, 30.0, kDayTolerance);  // day 0 is the first (pre-flight) session
    EXPECT_NEAR(*r.parameters[0].rul.crossing_t_days, 400.0, kDayTolerance);
    o.phase = kPhaseAll;
    EXPECT_EQ(load_trend_report(database, "N123EM", o).sessions_in_phase, 8);
}

TEST(TrendReport, AnUnknownTailListsTheTailsInTheDatabase) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 3, false);
    store_history(database, "D-AXYZ", 3, false);
    EXPECT_THAT(list_tail_numbers(database), ElementsAre("D-AXYZ", "N123EM"));
    EXPECT_THAT([&] { (void)load_trend_report(database, "N999ZZ", {}); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("tail number \"N999ZZ\" is not in :memory:"),
                                                  HasSubstr("its tail numbers: D-AXYZ, N123EM"))));
    db::Database empty(":memory:");
    EXPECT_THAT([&] { (void)load_trend_report(empty, "N1", {}); }, ThrowsMessage<EmadiagError>(HasSubstr("it holds no aircraft")));
}

TEST(TrendReport, ABadPhaseIsNamed) {
    TrendOptions o;
    o.phase = "in-flight";
    EXPECT_THAT([&] { (void)build_trend_report("N1", {}, o); },
                ThrowsMessage<EmadiagError>(HasSubstr("phase \"in-flight\": expected pre-flight, post-flight or all")));
}

TEST(TrendReport, JsonCarriesTheDocumentedFields) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, false);
    const auto j = to_json(load_trend_report(database, "N123EM", {}));
    EXPECT_EQ(j.at("schema"), "emadiag-trend");
    EXPECT_EQ(j.at("version"), 1);
    EXPECT_EQ(j.at("tail_number"), "N123EM");
    EXPECT_EQ(j.at("monte_carlo").at("seed"), 1);
    const auto& p = j.at("parameters").at(0);
    EXPECT_EQ(p.at("parameter"), "FDJ_Nm");
    EXPECT_EQ(p.at("status"), "predicted");
    EXPECT_EQ(p.at("points").size(), 8u);
    EXPECT_EQ(p.at("model").at("chosen"), "linear");
    EXPECT_EQ(p.at("crossing").at("date_utc"), "2027-02-09");
    EXPECT_NEAR(p.at("rul").at("estimate_days").get<double>(), 190.0, kDayTolerance);
    EXPECT_EQ(p.at("rul").at("ci90_days").size(), 2u);
    EXPECT_TRUE(p.at("fits").at("linear").at("fitted").get<bool>());
    EXPECT_NEAR(p.at("trend_per_100_days").at("value").get<double>(), 0.004, 1e-12);
    const auto& q = j.at("parameters").at(2);
    EXPECT_EQ(q.at("status"), "insufficient_data");
    EXPECT_TRUE(q.at("model").is_null());
    EXPECT_TRUE(q.at("rul").at("ci90_days").is_null());
}

}  // namespace
}  // namespace emadiag::prognostics
