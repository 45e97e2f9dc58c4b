// Issue 21 item 1: `emadiag trend` must never fit one line through two actuators. The main job's
// history (scripts/run-main.sh): tail N456EM with LH-ELEV wearing four times as fast as RH-ELEV
// (serial 2002); each position's trend and RUL must be its own, the LH-ELEV 90 % interval must start
// before the true crossing, and the HTML must name the positions it has (never "One position (ALL)").
// And a serial swap at one position: the new actuator's trend starts afresh, the old one keeps its
// own (--serial), and no line is fitted through both. The old trend pooled every session of the tail
// (RUL 302 days [169, 610] where the truth is 70).
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <unistd.h>

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using json = nlohmann::json;
using Result = emadiag::test::CliResult;
Result run(const std::string& args, bool merge_stderr = true) { return emadiag::test::run_cli(args, merge_stderr); }

constexpr double kZ95 = 1.959963984540054;
constexpr double kFdjStartNm = 0.08;  // history-sim's default
constexpr double kFdjLimitNm = 0.096;
constexpr int kSessions = 12;  // the main job's
constexpr double kDaysBetween = 30.0;
constexpr double kLastDay = (kSessions - 1) * kDaysBetween;  // 330
/// The main job's rates, N m per 100 days, and the true RUL after the last session.
constexpr double kLhRate = 0.004, kRhRate = 0.001;
constexpr double kLhTrueRul = (kFdjLimitNm - kFdjStartNm) / kLhRate * 100.0 - kLastDay;  // 400 - 330 = 70 days
constexpr double kRhTrueRul = (kFdjLimitNm - kFdjStartNm) / kRhRate * 100.0 - kLastDay;  // 1600 - 330 = 1270 days
/// How far a point RUL may be from the truth: a fifth of the true RUL plus two sessions' spacing
/// (the pooled fit was 232 days off on LH-ELEV).
double rul_tolerance(double true_rul) { return 0.2 * true_rul + 2 * kDaysBetween; }

std::string read(const std::string& path) {
    std::ifstream f(path);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

/// The series of `position` in a trend JSON (fails the test when missing or repeated).
json series_at(const json& j, const std::string& position) {
    json found;
    int n = 0;
    for (const auto& s : j.at("series"))
        if (s.at("kind") == "position" && s.at("position") == position) {
            found = s;
            ++n;
        }
    EXPECT_EQ(n, 1) << "series of position " << position << " in " << j.dump().substr(0, 400);
    return found;
}

json fdj_of(const json& series) {
    const json& p = series.at("parameters").at(0);
    EXPECT_EQ(p.at("parameter"), "FDJ_Nm");
    return p;
}

/// The HTML of one section: from its <h2> heading to the next.
std::string section(const std::string& html, const std::string& heading) {
    const std::size_t at = html.find("<h2>" + heading + " ");
    if (at == std::string::npos) return "";
    const std::size_t end = html.find("<h2>", at + 4);
    return html.substr(at, end == std::string::npos ? std::string::npos : end - at);
}

class HostileTrend : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = std::filesystem::temp_directory_path() / ("emadiag_hostile_trend_" + std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        const std::string common = " --tail N456EM --sessions " + std::to_string(kSessions) + " --days-between 30";
        lh_ = run("history-sim --db " + main_db() + common + " --position LH-ELEV --fdj-rate-per-100d 0.004 --fsj-rate-per-100d 0.002 --seed 3");
        rh_ = run("history-sim --db " + main_db() + common +
                  " --position RH-ELEV --serial 2002 --fdj-rate-per-100d 0.001 --fsj-rate-per-100d 0.0005 --seed 4");
        // LH-ELEV of N77EM: SN-OLD worn (FDJ 0.085 rising 0.004 per 100 days) for 6 sessions, then SN-NEW
        // fresh (0.080 rising 0.004) for 6 sessions from day 180.
        old_ = run("history-sim --db " + swap_db() +
                   " --tail N77EM --position LH-ELEV --serial SN-OLD --sessions 6 --days-between 30 --fdj-start 0.085 "
                   "--fdj-rate-per-100d 0.004 --seed 7");
        new_ = run("history-sim --db " + swap_db() +
                   " --tail N77EM --position LH-ELEV --serial SN-NEW --sessions 6 --days-between 30 --start-utc 2026-07-04T08:00:00Z "
                   "--fdj-start 0.08 --fdj-rate-per-100d 0.004 --seed 8");
    }
    static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
    static std::string main_db() { return (dir_ / "main.db").string(); }
    static std::string swap_db() { return (dir_ / "swap.db").string(); }
    static void ready() {
        ASSERT_EQ(lh_.exit_code, 0) << lh_.output;
        ASSERT_EQ(rh_.exit_code, 0) << rh_.output;
    }
    static void swap_ready() {
        ASSERT_EQ(old_.exit_code, 0) << old_.output;
        ASSERT_EQ(new_.exit_code, 0) << new_.output;
    }
    static inline std::filesystem::path dir_;
    static inline Result lh_, rh_, old_, new_;
};

TEST_F(HostileTrend, TwoPositionsWithDifferentRatesAreNeverPooled) {
    ASSERT_NO_FATAL_FAILURE(ready());
    const Result r = run("trend --db " + main_db() + " --tail N456EM --json", false);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const json j = json::parse(r.output);
    ASSERT_EQ(j.at("series").size(), 2u) << "one series per position";
    std::set<std::int64_t> seen;
    for (const auto& [position, serial, rate, truth] :
         {std::tuple{"LH-ELEV", "SIM-N456EM-LH-ELEV", kLhRate, kLhTrueRul}, std::tuple{"RH-ELEV", "2002", kRhRate, kRhTrueRul}}) {
        SCOPED_TRACE(position);
        const json s = series_at(j, position);
        ASSERT_FALSE(s.is_null());
        EXPECT_EQ(s.at("serial"), serial);
        EXPECT_EQ(s.at("sessions").at("in_trend"), kSessions);
        const json fdj = fdj_of(s);
        ASSERT_EQ(fdj.at("points").size(), static_cast<std::size_t>(kSessions));
        for (const auto& pt : fdj.at("points")) EXPECT_TRUE(seen.insert(pt.at("session_id").get<std::int64_t>()).second) << "a session in two series";
        // The slope is the position's own, within 2 se.
        const double slope = fdj.at("trend_per_100_days").at("value"), se = fdj.at("trend_per_100_days").at("std_error");
        EXPECT_LE(std::abs(slope - rate), kZ95 * se) << "slope " << slope << " +/- " << se << " vs the true " << rate;
        ASSERT_EQ(fdj.at("status"), "predicted") << fdj.at("summary");
        const double rul = fdj.at("rul").at("estimate_days");
        EXPECT_NEAR(rul, truth, rul_tolerance(truth)) << fdj.at("rul").dump();
        const json& ci = fdj.at("rul").at("ci90_days");
        ASSERT_TRUE(ci.at(0).is_number()) << ci.dump();
        EXPECT_LT(ci.at(0).get<double>(), truth) << "the 90 % lower bound must come before the true crossing: " << ci.dump();
        EXPECT_TRUE(ci.at(1).is_null() || ci.at(1).get<double>() > truth) << ci.dump();
    }
    EXPECT_EQ(seen.size(), 2u * kSessions);
}

TEST_F(HostileTrend, TheTextReportGivesEachPositionItsOwnRul) {
    ASSERT_NO_FATAL_FAILURE(ready());
    const Result r = run("trend --db " + main_db() + " --tail N456EM");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("POSITION LH-ELEV: serial SIM-N456EM-LH-ELEV (installed now), 12 of 12 sessions in the trend"),
                                HasSubstr("POSITION RH-ELEV: serial 2002 (installed now), 12 of 12 sessions in the trend"),
                                HasSubstr("FDJ_Nm at LH-ELEV (limit max 0.096): crossing predicted"),
                                HasSubstr("FDJ_Nm at RH-ELEV (limit max 0.096): crossing predicted"), Not(HasSubstr("FDJ_Nm  24"))));
}

TEST_F(HostileTrend, PositionAndSerialFiltersPickOneActuator) {
    ASSERT_NO_FATAL_FAILURE(ready());
    const Result lh = run("trend --db " + main_db() + " --tail N456EM --position LH-ELEV --json", false);
    ASSERT_EQ(lh.exit_code, 0) << lh.output;
    const json j = json::parse(lh.output);
    ASSERT_EQ(j.at("series").size(), 1u);
    EXPECT_EQ(j.at("filter").at("position"), "LH-ELEV");
    EXPECT_EQ(j.at("series").at(0).at("position"), "LH-ELEV");
    const Result rh = run("trend --db " + main_db() + " --tail N456EM --serial 2002 --json", false);
    ASSERT_EQ(rh.exit_code, 0) << rh.output;
    const json k = json::parse(rh.output);
    ASSERT_EQ(k.at("series").size(), 1u);
    EXPECT_EQ(k.at("series").at(0).at("kind"), "serial");
    EXPECT_EQ(k.at("series").at(0).at("place"), "N456EM RH-ELEV");
    EXPECT_EQ(fdj_of(k.at("series").at(0)).at("points").size(), static_cast<std::size_t>(kSessions));
    // Both filters: the position when that serial is installed there now.
    EXPECT_EQ(run("trend --db " + main_db() + " --tail N456EM --position RH-ELEV --serial 2002 --json", false).exit_code, 0);
    // What is not there is named, with what is.
    EXPECT_THAT(run("trend --db " + main_db() + " --tail N456EM --position NOSE-GEAR").output,
                AllOf(HasSubstr("position \"NOSE-GEAR\" has no session of tail N456EM"), HasSubstr("its positions: LH-ELEV, RH-ELEV")));
    EXPECT_THAT(run("trend --db " + main_db() + " --tail N456EM --serial 9999").output,
                AllOf(HasSubstr("serial \"9999\" has no session on tail N456EM"), HasSubstr("2002, SIM-N456EM-LH-ELEV")));
    const Result both = run("trend --db " + main_db() + " --tail N456EM --position LH-ELEV --serial 2002");
    EXPECT_EQ(both.exit_code, 1);
    EXPECT_THAT(both.output, AllOf(HasSubstr("serial \"2002\" is not the serial installed at N456EM LH-ELEV now (it holds SIM-N456EM-LH-ELEV)"),
                                   HasSubstr("--serial 2002 alone")));
}

TEST_F(HostileTrend, ASerialSwapAtOnePositionIsNotFittedAsOneLine) {
    ASSERT_NO_FATAL_FAILURE(swap_ready());
    const Result r = run("trend --db " + swap_db() + " --tail N77EM --json", false);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const json j = json::parse(r.output);
    ASSERT_EQ(j.at("series").size(), 1u);
    const json s = series_at(j, "LH-ELEV");
    EXPECT_EQ(s.at("serial"), "SN-NEW");
    EXPECT_EQ(s.at("sessions").at("total"), 12);
    EXPECT_EQ(s.at("sessions").at("in_trend"), 6);
    EXPECT_EQ(s.at("origin_utc"), "2026-07-04T08:00:00Z");  // the new actuator's first session is its day 0
    EXPECT_THAT(s.at("notes").dump(), HasSubstr("earlier serials (SN-OLD)"));
    const json fdj = fdj_of(s);
    ASSERT_EQ(fdj.at("points").size(), 6u);
    // The new actuator: 0.080 rising 0.004 per 100 days reaches 0.096 at its day 400, 250 days after its last session.
    const double slope = fdj.at("trend_per_100_days").at("value"), se = fdj.at("trend_per_100_days").at("std_error");
    EXPECT_LE(std::abs(slope - 0.004), kZ95 * se) << slope << " +/- " << se;
    ASSERT_EQ(fdj.at("status"), "predicted") << fdj.at("summary");
    const json& ci = fdj.at("rul").at("ci90_days");
    EXPECT_LT(ci.at(0).get<double>(), 250.0) << ci.dump();
    EXPECT_TRUE(ci.at(1).is_null() || ci.at(1).get<double>() > 250.0) << ci.dump();
    // The old actuator keeps its own trend: 0.085 rising 0.004 per 100 days.
    const Result old = run("trend --db " + swap_db() + " --tail N77EM --serial SN-OLD --json", false);
    ASSERT_EQ(old.exit_code, 0) << old.output;
    const json o = json::parse(old.output).at("series").at(0);
    EXPECT_EQ(o.at("serial"), "SN-OLD");
    const json ofdj = fdj_of(o);
    ASSERT_EQ(ofdj.at("points").size(), 6u);
    for (const auto& pt : ofdj.at("points")) EXPECT_LT(pt.at("started_utc").get<std::string>(), "2026-07-04");
    const double oslope = ofdj.at("trend_per_100_days").at("value"), ose = ofdj.at("trend_per_100_days").at("std_error");
    EXPECT_LE(std::abs(oslope - 0.004), kZ95 * ose) << oslope << " +/- " << ose;
}

TEST_F(HostileTrend, TheHtmlStatesThePositionsTruthfully) {
    ASSERT_NO_FATAL_FAILURE(ready());
    const std::string report_html = (dir_ / "report.html").string(), trend_html = (dir_ / "trend.html").string();
    ASSERT_EQ(run("report --db " + main_db() + " --tail N456EM --format html --out " + report_html).exit_code, 0);
    ASSERT_EQ(run("trend --db " + main_db() + " --tail N456EM --format html --out " + trend_html).exit_code, 0);
    for (const auto& path : {report_html, trend_html}) {
        SCOPED_TRACE(path);
        const std::string html = read(path);
        ASSERT_FALSE(html.empty());
        EXPECT_THAT(html, AllOf(Not(HasSubstr("One position (ALL)")), Not(HasSubstr("Position ALL")), Not(HasSubstr("carry no position")),
                                HasSubstr("<h2>Position LH-ELEV "), HasSubstr("<h2>Position RH-ELEV ")));
        // Each position's section holds its own serial only.
        const std::string lh = section(html, "Position LH-ELEV"), rh = section(html, "Position RH-ELEV");
        EXPECT_THAT(lh, AllOf(HasSubstr("SIM-N456EM-LH-ELEV"), Not(HasSubstr(">2002<")), HasSubstr("Session history (12)")));
        EXPECT_THAT(rh, AllOf(HasSubstr(">2002<"), Not(HasSubstr("SIM-N456EM-LH-ELEV")), HasSubstr("Session history (12)")));
    }
    // One position asked for: only its section.
    const Result one = run("trend --db " + main_db() + " --tail N456EM --position RH-ELEV --format html", false);
    ASSERT_EQ(one.exit_code, 0);
    EXPECT_THAT(one.output, AllOf(HasSubstr("<h2>Position RH-ELEV "), Not(HasSubstr("<h2>Position LH-ELEV "))));
}

}  // namespace
