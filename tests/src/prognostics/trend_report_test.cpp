// The whole report from a maintenance database (":memory:"): one series per position (the serial
// installed now) or per serial, never two actuators pooled; the phase filter, the time axis from the
// series' first session, the per-parameter results, the JSON schema, and the messages for an unknown
// tail, position or serial.
#include "core/emadiag_error.hpp"
#include "emadiag/db/database.hpp"
#include "emadiag/db/session_store.hpp"
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

/// Stores sessions every 30 days from 2026-01-05 (from session `first` on) with FDJ fdj0 + rate t
/// (exact, t in days since 2026-01-05), alternating phases when `mixed` (even index pre-flight, odd
/// post-flight), at `position` with `serial` ("" = none).
void store_history(db::Database& database, const std::string& tail, int sessions, bool mixed, const std::string& position = "",
                   const std::string& serial = "", double rate_per_day = 4e-5, int first = 0, double fdj0 = 0.08) {
    const double start = parse_utc_days_or_throw("2026-01-05T08:00:00Z", "start");
    for (int i = first; i < first + sessions; ++i) {
        db::StoredTestSession s;
        s.tail_number = tail;
        if (!position.empty()) {
            s.position = position;
            s.position_ata = "27-30";
        }
        s.actuator_serial = serial;
        s.phase = mixed && i % 2 == 1 ? "post-flight" : "pre-flight";
        s.started_utc = format_utc_time(start + 30.0 * i);
        s.verdict = "SERVICEABLE";
        s.findings.push_back(fdj(fdj0 + rate_per_day * 30.0 * i, 0.0005));
        (void)db::store_test_session(database, s);
    }
}

/// The one series of a report (a copy: the report is often a temporary).
TrendSeries only_series(const TrendReport& r) {
    EXPECT_EQ(r.series.size(), 1u);
    return r.series.at(0);
}

TEST(TrendReport, PredictsTheCrossingOfAnExactDriftFromTheDatabase) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, false);
    const TrendReport r = load_trend_report(database, "N123EM", {});
    EXPECT_EQ(r.sessions_total, 8);
    const TrendSeries t = only_series(r);
    EXPECT_EQ(t.kind, "position");
    EXPECT_EQ(t.position, "(none)");  // stored without a position: named so, not "ALL"
    EXPECT_EQ(t.sessions_in_trend, 8);
    EXPECT_EQ(t.origin_utc, "2026-01-05T08:00:00Z");
    ASSERT_EQ(t.parameters.size(), 4u);
    const ParameterTrend& p = t.parameters[0];
    EXPECT_EQ(p.series.parameter, "FDJ_Nm");
    EXPECT_EQ(p.rul.status, RulStatus::Predicted);
    EXPECT_NEAR(*p.rul.crossing_t_days, 400.0, kDayTolerance);
    EXPECT_NEAR(*p.rul.rul_days, 190.0, kDayTolerance);
    EXPECT_NEAR(*p.trend_per_period, 0.004, 1e-12);
    EXPECT_EQ(format_utc_date(*p.crossing_days_since_epoch), "2027-02-09");
    EXPECT_EQ(t.parameters[1].rul.status, RulStatus::InsufficientData);
    EXPECT_EQ(t.parameters[1].rul.summary, "insufficient data (0 sessions; need >= 3)");
}

TEST(TrendReport, ThePhaseFilterPicksTheSessionsOfTheTrend) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, true);
    TrendOptions o;
    o.phase = "post-flight";
    const TrendReport r = load_trend_report(database, "N123EM", o);
    EXPECT_EQ(r.sessions_total, 8);
    const TrendSeries t = only_series(r);
    EXPECT_EQ(t.sessions_total, 8);
    EXPECT_EQ(t.sessions_in_trend, 4);
    EXPECT_THAT(t.notes, ElementsAre(HasSubstr("4 session(s) of another phase than post-flight left out of the trends")));
    const auto& pts = t.parameters[0].series.points;
    ASSERT_EQ(pts.size(), 4u);
    EXPECT_EQ(t.origin_utc, "2026-02-04T08:00:00Z");  // day 0 is the series' first (post-flight) session
    EXPECT_NEAR(pts.front().t_days, 0.0, kDayTolerance);
    EXPECT_NEAR(*t.parameters[0].rul.crossing_t_days, 370.0, kDayTolerance);
    EXPECT_EQ(format_utc_date(*t.parameters[0].crossing_days_since_epoch), "2027-02-09");
    o.phase = kPhaseAll;
    EXPECT_EQ(only_series(load_trend_report(database, "N123EM", o)).sessions_in_trend, 8);
}

TEST(TrendReport, EachPositionIsItsOwnSeriesNeverPooled) {
    // LH-ELEV wears 4e-5 N m/day (limit at day 400), RH-ELEV 1e-5 (day 1600): pooled, neither is right.
    db::Database database(":memory:");
    store_history(database, "N456EM", 12, false, "LH-ELEV", "SN-L", 4e-5);
    store_history(database, "N456EM", 12, false, "RH-ELEV", "SN-R", 1e-5);
    const TrendReport r = load_trend_report(database, "N456EM", {});
    EXPECT_EQ(r.sessions_total, 24);
    ASSERT_EQ(r.series.size(), 2u);
    EXPECT_EQ(r.series[0].position, "LH-ELEV");
    EXPECT_EQ(r.series[0].serial, "SN-L");
    EXPECT_EQ(r.series[1].position, "RH-ELEV");
    EXPECT_EQ(r.series[1].serial, "SN-R");
    for (const auto& [t, crossing] : {std::pair{&r.series[0], 400.0}, std::pair{&r.series[1], 1600.0}}) {
        const ParameterTrend& p = t->parameters[0];
        EXPECT_EQ(p.series.points.size(), 12u) << t->position;
        EXPECT_NEAR(*p.rul.crossing_t_days, crossing, kDayTolerance) << t->position;
        EXPECT_NEAR(*p.rul.rul_days, crossing - 330.0, kDayTolerance) << t->position;
        ASSERT_TRUE(p.rul.rul_lower_days.has_value()) << t->position;
        EXPECT_LE(*p.rul.rul_lower_days, crossing - 330.0) << t->position;
    }
    // The filters: one position, one serial.
    TrendOptions o;
    o.position = "RH-ELEV";
    EXPECT_EQ(only_series(load_trend_report(database, "N456EM", o)).serial, "SN-R");
    o.position.clear();
    o.serial = "SN-L";
    const TrendSeries l = only_series(load_trend_report(database, "N456EM", o));
    EXPECT_EQ(l.kind, "serial");
    EXPECT_EQ(l.place, "N456EM LH-ELEV");
    EXPECT_NEAR(*l.parameters[0].rul.crossing_t_days, 400.0, kDayTolerance);
}

TEST(TrendReport, ASerialChangeAtAPositionStartsANewSeries) {
    // SN-OLD for sessions 0-5 from FDJ 0.085; SN-NEW from session 6 (day 180) from 0.080, both
    // rising 4e-5 N m/day. One line through both would fall; each alone rises at 4e-5.
    db::Database database(":memory:");
    store_history(database, "N77EM", 6, false, "LH-ELEV", "SN-OLD", 4e-5, 0, 0.085);
    store_history(database, "N77EM", 6, false, "LH-ELEV", "SN-NEW", 4e-5, 6, 0.08 - 4e-5 * 180.0);
    const TrendSeries t = only_series(load_trend_report(database, "N77EM", {}));
    EXPECT_EQ(t.serial, "SN-NEW");
    EXPECT_EQ(t.sessions_total, 12);
    EXPECT_EQ(t.sessions_in_trend, 6);
    EXPECT_EQ(t.origin_utc, format_utc_time(parse_utc_days_or_throw("2026-01-05T08:00:00Z", "start") + 180.0));
    EXPECT_THAT(t.notes, ElementsAre(HasSubstr("6 session(s) of earlier serials (SN-OLD) are in the history only")));
    const ParameterTrend& p = t.parameters[0];
    ASSERT_EQ(p.series.points.size(), 6u);
    EXPECT_NEAR(*p.trend_per_period, 0.004, 1e-12);
    EXPECT_NEAR(*p.rul.crossing_t_days, 400.0, kDayTolerance);  // 0.080 + 4e-5 t = 0.096 at the new actuator's day 400
    TrendOptions o;
    o.serial = "SN-OLD";
    const TrendSeries old = only_series(load_trend_report(database, "N77EM", o));
    ASSERT_EQ(old.parameters[0].series.points.size(), 6u);
    EXPECT_NEAR(*old.parameters[0].trend_per_period, 0.004, 1e-12);
    EXPECT_NEAR(*old.parameters[0].rul.crossing_t_days, 275.0, kDayTolerance);  // 0.085 + 4e-5 t = 0.096
}

TEST(TrendReport, AnUnknownPositionOrSerialIsNamedWithWhatThereIs) {
    db::Database database(":memory:");
    store_history(database, "N456EM", 3, false, "LH-ELEV", "SN-L");
    store_history(database, "N456EM", 3, false, "RH-ELEV", "SN-R");
    TrendOptions o;
    o.position = "NOSE";
    EXPECT_THAT([&] { (void)load_trend_report(database, "N456EM", o); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("position \"NOSE\" has no session of tail N456EM"),
                                                  HasSubstr("its positions: LH-ELEV, RH-ELEV"))));
    o.position.clear();
    o.serial = "SN-X";
    EXPECT_THAT([&] { (void)load_trend_report(database, "N456EM", o); },
                ThrowsMessage<EmadiagError>(HasSubstr("serial \"SN-X\" has no session on tail N456EM in :memory: (the serials seen on "
                                                      "the tail: SN-L, SN-R)")));
    o.position = "LH-ELEV";
    o.serial = "SN-R";
    EXPECT_THAT([&] { (void)load_trend_report(database, "N456EM", o); },
                ThrowsMessage<EmadiagError>(HasSubstr("serial \"SN-R\" is not the serial installed at N456EM LH-ELEV now (it holds SN-L)")));
    o.serial = "SN-L";
    EXPECT_EQ(only_series(load_trend_report(database, "N456EM", o)).position, "LH-ELEV");
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
    db::Database database(":memory:");
    TrendOptions o;
    o.phase = "in-flight";
    EXPECT_THAT([&] { (void)load_trend_report(database, "N1", o); },
                ThrowsMessage<EmadiagError>(HasSubstr("phase \"in-flight\": expected pre-flight, post-flight or all")));
}

TEST(TrendReport, JsonCarriesTheDocumentedFields) {
    db::Database database(":memory:");
    store_history(database, "N123EM", 8, false, "LH-ELEV", "SN-1");
    const auto j = to_json(load_trend_report(database, "N123EM", {}));
    EXPECT_EQ(j.at("schema"), "emadiag-trend");
    EXPECT_EQ(j.at("version"), 2);
    EXPECT_EQ(j.at("tail_number"), "N123EM");
    EXPECT_EQ(j.at("sessions_total"), 8);
    EXPECT_TRUE(j.at("filter").at("position").is_null());
    EXPECT_EQ(j.at("monte_carlo").at("seed"), 1);
    ASSERT_EQ(j.at("series").size(), 1u);
    const auto& v = j.at("series").at(0);
    EXPECT_EQ(v.at("kind"), "position");
    EXPECT_EQ(v.at("position"), "LH-ELEV");
    EXPECT_EQ(v.at("serial"), "SN-1");
    EXPECT_EQ(v.at("sessions").at("in_trend"), 8);
    EXPECT_EQ(v.at("trend_session_ids").size(), 8u);
    EXPECT_EQ(v.at("origin_utc"), "2026-01-05T08:00:00Z");
    EXPECT_EQ(v.at("last_session_utc"), "2026-08-03T08:00:00Z");
    const auto& p = v.at("parameters").at(0);
    EXPECT_EQ(p.at("parameter"), "FDJ_Nm");
    EXPECT_EQ(p.at("status"), "predicted");
    EXPECT_EQ(p.at("points").size(), 8u);
    EXPECT_EQ(p.at("model").at("chosen"), "linear");
    EXPECT_EQ(p.at("crossing").at("date_utc"), "2027-02-09");
    EXPECT_NEAR(p.at("rul").at("estimate_days").get<double>(), 190.0, kDayTolerance);
    EXPECT_EQ(p.at("rul").at("ci90_days").size(), 2u);
    EXPECT_TRUE(p.at("fits").at("linear").at("fitted").get<bool>());
    EXPECT_NEAR(p.at("trend_per_100_days").at("value").get<double>(), 0.004, 1e-12);
    const auto& q = v.at("parameters").at(2);
    EXPECT_EQ(q.at("status"), "insufficient_data");
    EXPECT_TRUE(q.at("model").is_null());
    EXPECT_TRUE(q.at("rul").at("ci90_days").is_null());
}

}  // namespace
}  // namespace emadiag::prognostics
