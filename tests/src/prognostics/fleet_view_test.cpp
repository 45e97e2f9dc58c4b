// The fleet view's fit from the summary sums against fit_linear over the same points (a fast path
// checked against the slow reference), and the ranking by the RUL lower bound.
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "prognostics/degradation_fit.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/fleet_view.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace emadiag::prognostics {
namespace {

db::StoredTestSession session(const std::string& tail, const std::string& utc, std::int64_t cycles, double fdj, double se) {
    db::StoredTestSession s;
    s.tail_number = tail;
    s.position = "LH-ELEV";
    s.position_ata = "27-30";
    s.actuator_serial = "SN-" + tail;
    s.phase = "pre-flight";
    s.started_utc = utc;
    s.cycles = cycles;
    s.verdict = "SERVICEABLE";
    s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj, se, 0.12, "max", "WITHIN", ""});
    return s;
}

TEST(FleetView, FitFromTheSummarySumsEqualsFitLinearOverThePoints) {
    const std::uint64_t seed = 77;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    db::Database db(":memory:");
    for (int i = 0; i < 25; ++i) {
        char utc[32];
        std::snprintf(utc, sizeof utc, "2026-%02d-%02dT08:00:00Z", 1 + i / 3, 1 + 9 * (i % 3));
        const double se = 0.0005 + 0.0003 * (i % 4);
        (void)db::store_session(db, session("N1EM", utc, 1000 + 37 * i, 0.08 + 0.0004 * i + se * noise(rng), se));
    }
    const auto stats = db::list_series_stats(db, std::string("N1EM"));
    ASSERT_EQ(stats.size(), 1u);
    FleetRecordOptions o;
    const FleetRecord record = build_fleet_record(db, "N1EM", o);
    const auto& fdj = record.positions.at(0).parameters.at(0);
    for (const auto& axis : fdj.axes) {
        const DegradationFit reference = fit_linear(axis.trend.series.points);
        const DegradationFit fast = fit_from_stats(stats[0], axis.axis == std::string(kAxisCycles));
        ASSERT_TRUE(reference.fitted && fast.fitted) << axis.axis;
        // Same slope; intercepts differ only by the axis origin (both t = 0 at the first session).
        EXPECT_NEAR(fast.b, reference.b, 1e-9 * std::abs(reference.b) + 1e-15) << axis.axis << ", seed " << seed;
        EXPECT_NEAR(fast.a, reference.a, 1e-9) << axis.axis << ", seed " << seed;
        EXPECT_NEAR(fast.covariance(1, 1), reference.covariance(1, 1), 1e-9 * reference.covariance(1, 1)) << axis.axis;
        EXPECT_NEAR(fast.reduced_chi2, reference.reduced_chi2, 1e-6 * reference.reduced_chi2) << axis.axis;
    }
}

TEST(FleetView, RanksByTheLowerBoundOfTheRulThenByStatus) {
    db::Database db(":memory:");
    for (int i = 0; i < 6; ++i) {
        char utc[32];
        std::snprintf(utc, sizeof utc, "2026-%02d-01T08:00:00Z", 1 + i);
        (void)db::store_session(db, session("N1EM", utc, 100 * i, 0.08 + 0.001 * i, 0.0005));   // slow
        (void)db::store_session(db, session("N2EM", utc, 100 * i, 0.08 + 0.006 * i, 0.0005));   // fast: near the limit
        (void)db::store_session(db, session("N3EM", utc, 100 * i, 0.08, 0.0005));               // flat
    }
    FleetOptions o;
    const auto rows = build_fleet_view(db, o);
    ASSERT_EQ(rows.size(), 3u);
    EXPECT_EQ(rows[0].tail_number, "N2EM");
    EXPECT_EQ(rows[0].driving_parameter, "FDJ_Nm");
    EXPECT_EQ(rows[1].tail_number, "N1EM");
    EXPECT_EQ(rows[2].tail_number, "N3EM");
    EXPECT_EQ(rows[0].parameters.at(0).axis, "cycles");
    ASSERT_TRUE(rows[0].urgency_days.has_value());
    ASSERT_TRUE(rows[1].urgency_days.has_value());
    EXPECT_LT(*rows[0].urgency_days, *rows[1].urgency_days);
}

}  // namespace
}  // namespace emadiag::prognostics
