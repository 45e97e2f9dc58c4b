// The HTML report: self-contained (no script, no URL, the CSP), every stored string escaped, the
// plots and tables per section, bad numbers named; and the document of a maintenance record on the
// days axis (sessions in an in-memory database, an exact drift whose crossing is known).
#include "core/emadiag_error.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/db/database.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/utc_time.hpp"
#include "report/html_report.hpp"
#include "report/record_adapter.hpp"
#include "report/trend_adapter.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <regex>

namespace emadiag::report {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

namespace pg = emadiag::prognostics;

constexpr double kFdjLimitNm = 0.096;
const std::string kEvil = "<script>alert('x')</script>\"&";
const std::string kEvilEscaped = "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&quot;&amp;";

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

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

/// 8 sessions of LH-ELEV (serial SN-1) every 30 days from 2026-01-05, FDJ 0.08 + 4e-5 t exactly:
/// crossing at day 400.
void store_history(db::Database& database) {
    const double start = pg::parse_utc_days_or_throw("2026-01-05T08:00:00Z", "start");
    for (int i = 0; i < 8; ++i) {
        db::StoredTestSession s;
        s.tail_number = "N123EM";
        s.position = "LH-ELEV";
        s.position_ata = "27-30";
        s.actuator_serial = "SN-1";
        s.phase = "pre-flight";
        s.started_utc = pg::format_utc_time(start + 30.0 * i);
        s.verdict = "SERVICEABLE";
        s.verdict_note = "note " + kEvil;
        s.findings.push_back(fdj(0.08 + 4e-5 * 30.0 * i, 0.0005));
        (void)db::store_test_session(database, s);
    }
}

/// The maintenance record's document of that history (what `report` and `trend --format html`
/// render), with its one position section (the serial's section, the same trends, left out).
ReportDocument adapted() {
    db::Database database(":memory:");
    store_history(database);
    ReportDocument d = from_fleet_record(pg::build_fleet_record(database, "N123EM", {}), {"2026-11-24T10:00:00Z", "0.1.0", "maintenance.db"});
    d.serials.clear();
    return d;
}

TEST(DaysAxisDocument, OnePositionWithTheTrendsAndTheHealth) {
    const ReportDocument d = adapted();
    EXPECT_EQ(d.tail_number, "N123EM");
    EXPECT_EQ(d.time_axis, TimeAxis::Date);  // no session carries cycles
    ASSERT_EQ(d.positions.size(), 1u);
    const ReportSection& s = d.positions[0];
    EXPECT_EQ(s.name, "LH-ELEV");
    EXPECT_EQ(s.sessions.size(), 8u);
    ASSERT_EQ(s.parameters.size(), 4u);
    const ReportParameter& p = s.parameters[0];
    EXPECT_EQ(p.name, "FDJ_Nm");
    EXPECT_EQ(p.unit, "N m");
    EXPECT_DOUBLE_EQ(p.nominal, 0.08);
    ASSERT_EQ(p.points.size(), 8u);
    EXPECT_EQ(pg::format_utc_date(p.points[0].x), "2026-01-05");
    EXPECT_EQ(p.crossing_label, "2027-02-09");  // day 400
    ASSERT_EQ(p.rul.size(), 1u);
    EXPECT_NEAR(*p.rul[0].estimate, 190.0, 1e-6);
    // Latest 0.08 + 4e-5 * 210 = 0.0884: h = (0.096 - 0.0884) / 0.016 = 0.475.
    EXPECT_NEAR(*p.health.index, 0.475, 1e-9);
    EXPECT_EQ(s.health.index_parameter, "FDJ_Nm");
    EXPECT_NE(s.health.status, HealthStatus::NoData);
    // One serial, installed since the first session.
    ASSERT_EQ(s.installations.size(), 1u);
    EXPECT_EQ(s.installations[0].serial, "SN-1");
    EXPECT_EQ(s.installations[0].from_utc, "2026-01-05T08:00:00Z");
    EXPECT_EQ(s.current, "SN-1");
}

TEST(DaysAxisDocument, FitCurveAndBandFollowTheFit) {
    const ReportDocument d = adapted();
    const ReportParameter& p = d.positions[0].parameters[0];
    ASSERT_TRUE(p.fit);
    const ReportCurve& c = *p.fit;
    ASSERT_EQ(c.x.size(), static_cast<std::size_t>(kCurveSamples));
    EXPECT_DOUBLE_EQ(c.x.front(), p.points.front().x);
    // Drawn far enough to show the crossing at day 400 (origin + 400).
    EXPECT_GT(c.x.back(), *p.crossing_x);
    for (std::size_t i = 0; i < c.x.size(); ++i) {
        EXPECT_LE(c.lower[i], c.mean[i]);
        EXPECT_GE(c.upper[i], c.mean[i]);
        const double t = c.x[i] - p.points.front().x;
        EXPECT_NEAR(c.mean[i], 0.08 + 4e-5 * t, 1e-9);
    }
    // The band widens away from the data.
    EXPECT_GT(c.upper.back() - c.lower.back(), c.upper[c.x.size() / 4] - c.lower[c.x.size() / 4]);
    // No points: no fit.
    EXPECT_FALSE(d.positions[0].parameters[1].fit);
}

TEST(HtmlReport, SelfContainedWithoutScriptOrUrl) {
    const std::string html = render_html(adapted());
    EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
    EXPECT_THAT(html, HasSubstr("Content-Security-Policy\" content=\"default-src 'none'"));
    EXPECT_THAT(html, Not(HasSubstr("<script")));
    EXPECT_THAT(html, Not(HasSubstr("http://")));
    EXPECT_THAT(html, Not(HasSubstr("https://")));
    EXPECT_THAT(html, Not(HasSubstr("src=")));
    EXPECT_THAT(html, Not(HasSubstr("url(http")));
    // Links only within the page.
    const std::regex href("href=\"([^\"]*)\"");
    for (auto it = std::sregex_iterator(html.begin(), html.end(), href); it != std::sregex_iterator(); ++it)
        EXPECT_EQ((*it)[1].str().front(), '#') << (*it)[1].str();
}

TEST(HtmlReport, OnePlotPerParameterWithItsParts) {
    const std::string html = render_html(adapted());
    EXPECT_EQ(count(html, "<svg"), 4u);
    EXPECT_EQ(count(html, "</svg>"), 4u);
    EXPECT_EQ(count(html, "class=\"errorbar\""), 8u);  // FDJ's 8 points; FSJ and eta have none
    EXPECT_EQ(count(html, "class=\"band\""), 1u);
    EXPECT_EQ(count(html, "class=\"hline\""), 1u);  // only FDJ has a limit in these findings
    EXPECT_THAT(html, HasSubstr(">crossing 2027-02-09<"));
    EXPECT_THAT(html, HasSubstr(">last session<"));
    EXPECT_THAT(html, HasSubstr("no data"));
    // Unique clip paths.
    EXPECT_THAT(html, HasSubstr("id=\"p1-1-clip\""));
    EXPECT_THAT(html, HasSubstr("id=\"p1-4-clip\""));
    EXPECT_THAT(html, HasSubstr("190 [")) << "RUL with its interval";
    EXPECT_THAT(html, HasSubstr("Session history (8)"));
}

TEST(HtmlReport, EveryStoredStringIsEscaped) {
    ReportDocument d = adapted();
    d.tail_number = kEvil;
    ReportSection& s = d.positions[0];
    s.current = kEvil;
    for (auto& x : s.sessions) x.serial = x.tail_number = kEvil;
    s.name = kEvil;
    s.ata_reference = kEvil;
    s.notes.push_back(kEvil);
    s.sessions[0].operator_id = kEvil;
    s.sessions[0].kind = kEvil;
    s.findings.push_back({kEvil, kEvil, kEvil, kEvil, kEvil, kEvil});
    s.parameters[0].name = kEvil;
    s.parameters[0].unit = kEvil;
    s.parameters[0].notes.push_back(kEvil);
    s.parameters[0].crossing_label = kEvil;
    d.title = kEvil;
    d.notes.push_back(kEvil);
    d.method_note = kEvil;
    d.generated_utc = kEvil;
    ReportSection serial = s;
    serial.kind = "serial";
    d.serials.push_back(serial);
    const std::string html = render_html(d);
    EXPECT_THAT(html, Not(HasSubstr("<script")));
    EXPECT_THAT(html, Not(HasSubstr("alert('x')")));
    EXPECT_GE(count(html, kEvilEscaped), 20u);
    EXPECT_EQ(count(html, "<svg"), 8u);
    EXPECT_THAT(html, HasSubstr("Open discovery findings (1)"));
}

TEST(HtmlReport, SameDocumentSameBytes) { EXPECT_EQ(render_html(adapted()), render_html(adapted())); }

TEST(HtmlReport, BadNumberNamesSectionParameterAndPoint) {
    ReportDocument d = adapted();
    d.positions[0].parameters[0].points[3].std_error = std::nan("");
    EXPECT_THAT([&] { (void)render_html(d); },
                ThrowsMessage<EmadiagError>(HasSubstr("position \"LH-ELEV\" parameter \"FDJ_Nm\" points[3].std_error = nan is not a finite number")));
}

TEST(HtmlReport, BadFitIsNamed) {
    ReportDocument d = adapted();
    d.positions[0].parameters[0].fit->upper[5] = std::numeric_limits<double>::infinity();
    EXPECT_THAT([&] { (void)render_html(d); },
                ThrowsMessage<EmadiagError>(HasSubstr("position \"LH-ELEV\" parameter \"FDJ_Nm\" fit[5].upper = inf is not a finite number")));
    d = adapted();
    d.positions[0].parameters[0].fit->lower[7] = 1.0;
    EXPECT_THAT([&] { (void)render_html(d); }, ThrowsMessage<EmadiagError>(HasSubstr("fit[7]: the band [1, ")));
    d = adapted();
    d.positions[0].parameters[0].fit->mean.pop_back();
    EXPECT_THAT([&] { (void)render_html(d); }, ThrowsMessage<EmadiagError>(HasSubstr("fit has 80 x, 79 mean")));
}

TEST(HtmlReport, CyclesAxisAndRulInTwoUnits) {
    ReportDocument d;
    d.tail_number = "N1";
    d.time_axis = TimeAxis::Cycles;
    ReportSection s;
    s.name = "LH-ELEV";
    s.kind = "position";
    ReportParameter p;
    p.name = "FDJ_Nm";
    p.unit = "N m";
    p.nominal = 0.08;
    p.limit = pg::TrendLimit{pg::LimitSide::Max, 0.096, 1};
    for (int i = 0; i < 4; ++i) p.points.push_back({1000.0 * i, 0.08 + 0.001 * i, 0.0005, std::to_string(i + 1)});
    p.rul.push_back({"cycles", "predicted", "crossing at cycle 16000", 13000.0, 11000.0, 16000.0, true, 50000});
    p.rul.push_back({"days", "predicted", "crossing in 400 days", 400.0, 350.0, 480.0, true, 3650});
    s.parameters.push_back(p);
    d.positions.push_back(s);
    const std::string html = render_html(d);
    EXPECT_THAT(html, HasSubstr(">flight cycles<"));
    EXPECT_THAT(html, HasSubstr("13000 [11000, 16000] cycles<br/>400 [350, 480] days"));
}

TEST(TrendAdapter, UnknownParameterHasNoNominal) {
    EXPECT_THAT([] { (void)datasheet_nominal("FOO"); }, ThrowsMessage<EmadiagError>(HasSubstr("\"FOO\"")));
}

}  // namespace
}  // namespace emadiag::report
