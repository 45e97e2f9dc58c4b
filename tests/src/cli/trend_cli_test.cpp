// `emadiag history-sim` then `emadiag trend` end to end: a simulated maintenance history with FDJ
// drifting at a known rate (ground routine per session: DYN then BRK, case A, typical noise), the
// trend report's slope and RUL interval against the truth, the stored truth, the text report and the
// errors (docs/trend-report.md).
#include "support/cli_runner.hpp"
#include "emadiag/db/database.hpp"
#include "emadiag/db/run_store.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

/// The history: 8 sessions 30 days apart, FDJ 0.08 N m rising 0.004 N m per 100 days. The limit
/// (section 8 envelope) 0.096 N m is reached at day (0.096 - 0.08) / 0.004 * 100 = 400, the last
/// session is at day 210: true RUL 190 days.
constexpr int kSessions = 8;
constexpr double kDaysBetween = 30.0;
constexpr double kFdjStartNm = 0.08;
constexpr double kFdjRateNmPer100d = 0.004;
constexpr double kFdjLimitNm = 0.096;
constexpr double kZ95 = 1.959963984540054;
constexpr double kTrueCrossingDays = (kFdjLimitNm - kFdjStartNm) / kFdjRateNmPer100d * 100.0;
constexpr double kTrueRulDays = kTrueCrossingDays - (kSessions - 1) * kDaysBetween;
constexpr double kTruthTolerance = 1e-12;

using Result = emadiag::test::CliResult;
Result run(const std::string& args, bool merge_stderr = true) { return emadiag::test::run_cli(args, merge_stderr); }

class TrendCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = std::filesystem::temp_directory_path() / ("emadiag_trend_cli_" + std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        history_ = run("history-sim --db " + db() + " --tail N123EM --sessions " + std::to_string(kSessions) + " --days-between 30" +
                       " --fdj-start 0.08 --fdj-rate-per-100d 0.004 --seed 11");
    }
    static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
    static std::string db() { return (dir_ / "history.db").string(); }
    static inline std::filesystem::path dir_;
    static inline Result history_;
};

TEST_F(TrendCli, HistorySimStoresOneSessionPerStepWithTheTruthInTheRuns) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    EXPECT_THAT(history_.output, HasSubstr("stored 8 test sessions of N123EM"));
    emadiag::db::Database database(db());
    const auto runs = emadiag::db::list_runs(database, "N123EM");
    ASSERT_EQ(runs.size(), 2u * kSessions);  // DYN then BRK per session
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const auto meta = nlohmann::json::parse(runs[i].meta_json);
        const double day = kDaysBetween * static_cast<double>(i / 2);
        EXPECT_EQ(runs[i].source, "history-sim");
        EXPECT_EQ(runs[i].sequence, i % 2 == 0 ? "dyn" : "brk");
        EXPECT_NEAR(std::stod(meta.at("true_FDJ_Nm").get<std::string>()), kFdjStartNm + kFdjRateNmPer100d * day / 100.0, kTruthTolerance);
        EXPECT_EQ(meta.at("true_FSJ_Nm").get<std::string>(), "0.12");
        EXPECT_EQ(runs[i].session_id.has_value(), true);
    }
    EXPECT_EQ(runs.front().started_utc, "2026-01-05T08:00:00Z");
    EXPECT_EQ(runs.back().started_utc, "2026-08-03T08:00:00Z");
}

TEST_F(TrendCli, JsonSlopeAndRulIntervalAgreeWithTheTrueDrift) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const Result r = run("trend --db " + db() + " --tail N123EM --json", false);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j.at("schema"), "emadiag-trend");
    ASSERT_EQ(j.at("series").size(), 1u);  // sessions stored without a position: one position, "(none)"
    const auto& series = j.at("series").at(0);
    EXPECT_EQ(series.at("position"), "(none)");
    EXPECT_EQ(series.at("serial"), "SIM-N123EM");
    EXPECT_EQ(series.at("sessions").at("in_trend"), kSessions);
    const auto& fdj = series.at("parameters").at(0);
    ASSERT_EQ(fdj.at("parameter"), "FDJ_Nm");
    ASSERT_EQ(fdj.at("status"), "predicted") << fdj.dump(2);
    EXPECT_EQ(fdj.at("points").size(), static_cast<std::size_t>(kSessions));
    EXPECT_EQ(fdj.at("points").at(0).at("estimators").size(), 2u);  // physics:brk and physics:dyn combined
    const double slope = fdj.at("trend_per_100_days").at("value");
    const double slope_se = fdj.at("trend_per_100_days").at("std_error");
    EXPECT_LE(std::abs(slope - kFdjRateNmPer100d), kZ95 * slope_se)
        << "slope " << slope << " +/- " << slope_se << " per 100 days vs the true " << kFdjRateNmPer100d;
    const auto& ci = fdj.at("rul").at("ci90_days");
    ASSERT_TRUE(ci.at(0).is_number() && ci.at(1).is_number()) << ci.dump();
    EXPECT_LE(ci.at(0).get<double>(), kTrueRulDays) << fdj.at("rul").dump();
    EXPECT_GE(ci.at(1).get<double>(), kTrueRulDays) << fdj.at("rul").dump();
    EXPECT_EQ(fdj.at("limit").at("kind"), "max");
    EXPECT_DOUBLE_EQ(fdj.at("limit").at("value").get<double>(), kFdjLimitNm);
    // FSJ does not drift: no crossing; eta is not identifiable on the ground (case A).
    EXPECT_EQ(series.at("parameters").at(1).at("status"), "no_crossing");
    EXPECT_EQ(series.at("parameters").at(2).at("status"), "insufficient_data");
}

TEST_F(TrendCli, TextReportHasTheTableAndTheReasons) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const Result r = run("trend --db " + db() + " --tail N123EM --seed 3");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("tail N123EM, phase pre-flight, 8 test sessions"),
                                HasSubstr("POSITION (none): serial SIM-N123EM (installed now), 8 of 8 sessions in the trend"), HasSubstr("RUL days [90 %]"),
                                HasSubstr("FDJ_Nm  8"), HasSubstr("crossing predicted at day"), HasSubstr("seed 3"),
                                HasSubstr("insufficient data (0 sessions; need >= 3)"), HasSubstr("no crossing predicted within the horizon")));
}

TEST_F(TrendCli, TheSameSeedGivesTheSameReport) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const Result a = run("trend --db " + db() + " --tail N123EM --json --seed 5", false);
    const Result b = run("trend --db " + db() + " --tail N123EM --json --seed 5", false);
    EXPECT_EQ(a.output, b.output);
}

TEST_F(TrendCli, HistorySimIsDeterministicForASeed) {
    const std::string common = " --tail N7EM --sessions 3 --fdj-rate-per-100d 0.01 --seed 4";
    const std::string a = (dir_ / "a.db").string(), b = (dir_ / "b.db").string(), c = (dir_ / "c.db").string();
    ASSERT_EQ(run("history-sim --db " + a + common).exit_code, 0);
    ASSERT_EQ(run("history-sim --db " + b + common).exit_code, 0);
    ASSERT_EQ(run("history-sim --db " + c + common + "1").exit_code, 0);  // seed 41
    const Result ra = run("trend --db " + a + " --tail N7EM --json", false), rb = run("trend --db " + b + " --tail N7EM --json", false),
                 rc = run("trend --db " + c + " --tail N7EM --json", false);
    ASSERT_EQ(ra.exit_code, 0) << ra.output;
    EXPECT_EQ(ra.output, rb.output);
    EXPECT_NE(ra.output, rc.output);
}

TEST_F(TrendCli, AnUnknownTailIsAnErrorListingTheKnownTails) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const Result r = run("trend --db " + db() + " --tail N999ZZ");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, AllOf(HasSubstr("tail number \"N999ZZ\" is not in"), HasSubstr("its tail numbers: N123EM")));
}

TEST_F(TrendCli, BadOptionsAreNamed) {
    EXPECT_THAT(run("history-sim --db " + db() + " --tail N1 --sessions 0").output, HasSubstr("--sessions 0 is not in [1, 1000]"));
    EXPECT_THAT(run("history-sim --db " + db() + " --tail N1 --start-utc 2026-01-05").output,
                AllOf(HasSubstr("--start-utc \"2026-01-05\""), HasSubstr("YYYY-MM-DDThh:mm:ss")));
    EXPECT_THAT(run("trend --db " + db() + " --tail N123EM --draws 5").output, HasSubstr("Monte Carlo draws 5 is not in"));
    EXPECT_THAT(run("trend --db " + (dir_ / "missing.db").string() + " --tail N123EM").output, HasSubstr("missing.db"));
}

}  // namespace
