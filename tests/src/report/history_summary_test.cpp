// A long history on one page (history_summary.hpp, docs/report-html.md "Long histories"): a section
// up to the threshold is shown whole and byte-for-byte as before; above it the page lists the recent
// sessions and every one that is not SERVICEABLE with the one after it, draws those points and both
// points of each limit crossing as measured, holds every earlier bar inside the envelope, says what was
// summarised and links (or names) where every session is; the CSV holds every session.
#include "emadiag/io/text_field.hpp"
#include "estimation/health_estimate.hpp"
#include "report/history_summary.hpp"
#include "report/html_report.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

namespace emadiag::report {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr double kLimit = 1.0;
constexpr double kFirstDay = 20000;

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

/// A position with n sessions, one a day; FDJ-like values 0.5 + a small wobble, beyond the limit 1.0
/// for the sessions in [beyond_from, beyond_to).
ReportSection section(std::size_t n, std::size_t beyond_from = 0, std::size_t beyond_to = 0) {
    ReportSection s;
    s.name = "LH-ELEV";
    s.kind = "position";
    ReportParameter p;
    p.name = "FDJ_Nm";
    p.unit = "N m";
    p.limit = prognostics::TrendLimit{prognostics::LimitSide::Max, kLimit, 0};
    for (std::size_t i = 0; i < n; ++i) {
        ReportSession x;
        x.id = std::to_string(1000 + i);
        x.started_utc = "2026-01-01T00:00:00Z";
        x.tail_number = "N1";
        x.position = "LH-ELEV";
        x.serial = "SN-1";
        x.verdict = kServiceableVerdict;
        x.cycles = static_cast<double>(i);
        s.sessions.push_back(x);
        const double v = (i >= beyond_from && i < beyond_to) ? 1.2 : 0.5 + 0.01 * static_cast<double>(i % 7);
        p.points.push_back({kFirstDay + static_cast<double>(i), v, 0.002 * static_cast<double>(1 + i % 3), x.id});
    }
    s.parameters.push_back(p);
    return s;
}

ReportDocument document(const ReportSection& s) {
    ReportDocument d;
    d.tail_number = "N1";
    d.generated_utc = "2026-11-28T00:00:00Z";
    d.positions.push_back(s);
    return d;
}

TEST(HistorySummary, UpToTheThresholdTheSectionIsShownWhole) {
    const HistoryLimits limits;
    const ReportSection s = section(limits.full_max);
    EXPECT_FALSE(summarised(s, limits));
    EXPECT_TRUE(summarised(section(limits.full_max + 1), limits));
    const std::string html = render_html(document(s));
    EXPECT_THAT(html, Not(HasSubstr("Long history")));
    EXPECT_THAT(html, HasSubstr("Session history (" + std::to_string(limits.full_max) + ")</h3>"));
    EXPECT_EQ(count(html, "<circle cx"), limits.full_max + 1);  // every point drawn as measured, and the legend's
    // Links and options do not change a page that is not summarised.
    HtmlOptions o;
    o.full_history_href["position-1"] = "elsewhere.csv";
    EXPECT_EQ(render_html(document(s), o), html);
}

TEST(HistorySummary, ListsTheRecentAndEveryAttentionSessionWithTheOneAfter) {
    HistoryLimits limits;
    limits.full_max = 50;
    limits.recent = 10;
    ReportSection s = section(100);
    s.sessions[20].verdict = "UNSERVICEABLE";
    s.sessions[21].verdict = "INCONCLUSIVE";
    s.sessions[95].verdict = "UNSERVICEABLE";
    std::vector<std::size_t> expected = {20, 21, 22};
    for (std::size_t i = 90; i < 100; ++i) expected.push_back(i);
    EXPECT_EQ(listed_sessions(s, limits), expected);
    // The newest session needing attention has no session after it: nothing past the end.
    s.sessions[99].verdict = "UNSERVICEABLE";
    EXPECT_EQ(listed_sessions(s, limits), expected);
}

TEST(HistorySummary, PlotKeepsListedRecentAndCrossingsAndEnvelopesEveryEarlierBar) {
    HistoryLimits limits;
    limits.recent = 30;
    limits.columns = 20;
    const ReportSection s = section(500, 200, 210);
    const ReportParameter& p = s.parameters[0];
    const PlotSummary ps = summarise_plot(p, {"1050"}, limits);
    std::vector<std::string> shown;
    for (const auto& pt : ps.shown.points) shown.push_back(pt.session_id);
    std::vector<std::string> expected = {"1050", "1199", "1200", "1209", "1210"};  // listed; both sides of each crossing
    for (std::size_t i = 470; i < 500; ++i) expected.push_back(std::to_string(1000 + i));
    EXPECT_EQ(shown, expected);
    EXPECT_EQ(ps.enveloped, 470u - 5u);
    ASSERT_TRUE(ps.envelope && ps.means);
    const Band& b = *ps.envelope;
    EXPECT_LE(b.x.size(), 2 * limits.columns);
    EXPECT_TRUE(std::is_sorted(b.x.begin(), b.x.end()));
    EXPECT_LE(ps.means->x.size(), limits.columns);
    // Every earlier point's bar lies inside the envelope where it is drawn (the step of its column).
    for (std::size_t i = 0; i < 470; ++i) {
        const ReportPoint& pt = p.points[i];
        const auto at = std::find(b.x.begin(), b.x.end(), pt.x);
        const std::size_t k = at != b.x.end() ? static_cast<std::size_t>(at - b.x.begin())
                                              : static_cast<std::size_t>(std::upper_bound(b.x.begin(), b.x.end(), pt.x) - b.x.begin()) - 1;
        EXPECT_LE(b.lower[k], pt.value - kZ95 * pt.std_error) << i;
        EXPECT_GE(b.upper[k], pt.value + kZ95 * pt.std_error) << i;
    }
    // The envelope reaches above the limit where the points did.
    EXPECT_GT(*std::max_element(b.upper.begin(), b.upper.end()), kLimit);
    // Few points: nothing older than the recent ones, no envelope.
    const PlotSummary few = summarise_plot(section(20).parameters[0], {}, limits);
    EXPECT_EQ(few.shown.points.size(), 20u);
    EXPECT_FALSE(few.envelope);
}

TEST(HistorySummary, PageSaysWhatWasSummarisedAndLinksTheRest) {
    const HistoryLimits limits;
    ReportSection s = section(limits.full_max + 100, 100, 120);
    s.sessions[60].verdict = "UNSERVICEABLE";
    HtmlOptions o;
    o.full_history_href["position-1"] = "tail-N1.position-1.csv";
    const std::string html = render_html(document(s), o);
    const std::size_t listed = limits.recent + 2;  // and session 60 and the one after it
    EXPECT_THAT(html, HasSubstr("Long history: " + std::to_string(s.sessions.size()) + " sessions."));
    EXPECT_THAT(html, HasSubstr("(" + std::to_string(listed) + " in all)"));
    EXPECT_THAT(html, HasSubstr("<a class=\"full-history\" href=\"tail-N1.position-1.csv\">"));
    EXPECT_THAT(html, HasSubstr("Session history (" + std::to_string(s.sessions.size()) + ", " + std::to_string(listed) + " listed)"));
    EXPECT_EQ(count(html, "<td>" + std::string(kServiceableVerdict) + "</td>"), listed - 1);
    EXPECT_EQ(count(html, "<td>UNSERVICEABLE</td>"), 1u);
    EXPECT_THAT(html, HasSubstr("<td>1060</td>"));
    EXPECT_THAT(html, HasSubstr("<td>1061</td>"));
    EXPECT_THAT(html, Not(HasSubstr("<td>1062</td>")));
    // Drawn as measured: the listed, both sides of the two crossings.
    EXPECT_THAT(html, HasSubstr(std::to_string(listed + 4) + " of " + std::to_string(s.sessions.size()) + " points drawn as measured, " +
                                std::to_string(s.sessions.size() - listed - 4) + " in the envelope only."));
    EXPECT_EQ(count(html, "<circle cx"), listed + 4 + 1);  // and the legend's
    EXPECT_THAT(html, HasSubstr(">earlier " + std::to_string(s.sessions.size() - limits.recent) + ": 95 % bars<"));
    // Without a link the page names the command that lists every session.
    EXPECT_THAT(render_html(document(s)), HasSubstr("<code>emadiag export --tail N1 --format csv</code>"));
}

TEST(HistorySummary, CsvHoldsEverySessionQuotedAndDefused) {
    ReportSection s = section(450);
    s.sessions[3].note = "seal, \"worn\"";
    s.sessions[4].operator_id = "=cmd|' /C calc'!A0";
    s.sessions[5].hours = 12.5;
    const std::string csv = sessions_csv(s);
    EXPECT_EQ(count(csv, "\n"), 451u);
    EXPECT_EQ(csv.rfind("session,started_utc,tail,position,serial,phase,kind,operator,cycles,hours,verdict,note,emadiag\n", 0), 0u);
    EXPECT_THAT(csv, HasSubstr(",\"seal, \"\"worn\"\"\","));
    EXPECT_THAT(csv, HasSubstr(",'=cmd|' /C calc'!A0,"));
    EXPECT_THAT(csv, HasSubstr("\n1005,2026-01-01T00:00:00Z,N1,LH-ELEV,SN-1,,,,5,12.5,SERVICEABLE,,\n"));
    EXPECT_THAT(csv, HasSubstr("\n1449,"));
}

TEST(HistorySummary, CsvCellsAreThoseOfTheToolsCsvWriter) {
    // sessions_csv appends plain cells as they are: the same bytes as io::csv_field for any text.
    const std::vector<std::string> texts = {"",         "LH-ELEV",   "2026-01-01T06:00:00Z", "-1.5",      "-x",         "+1",
                                            "@a",       "=1+1",      "a,b",                  "say \"hi\"", "tab\there", "line\nbreak",
                                            "caf\xc3\xa9", "\xff\xfe", "emadiag 0.1.0 (git 60705b1, Release)", "J. Doe (CERT-1); note #3",
                                            "a/b_c:d",  " lead"};
    ReportSection s = section(0);
    for (const auto& t : texts) {
        ReportSession x;
        x.id = x.started_utc = x.tail_number = x.position = x.serial = x.phase = x.kind = x.operator_id = x.verdict = x.note = x.tool_version = t;
        s.sessions.push_back(x);
    }
    const std::string csv = sessions_csv(s);
    std::istringstream lines(csv);
    std::string line;
    std::getline(lines, line);  // the header
    for (const auto& t : texts) {
        ASSERT_TRUE(std::getline(lines, line)) << t;
        const std::string c = io::csv_field(t);
        EXPECT_EQ(line, c + "," + c + "," + c + "," + c + "," + c + "," + c + "," + c + "," + c + ",,," + c + "," + c + "," + c) << t;
    }
}

}  // namespace
}  // namespace emadiag::report
