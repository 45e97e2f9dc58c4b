// The maintenance record of one aircraft (prognostics::FleetRecord from a real database in memory)
// as the HTML report: a section per position and per serial, the plots against flight cycles, the
// RUL in cycles and days, the crossing of an exact drift, the installation change, the open
// discovery finding only where it belongs, and every stored string escaped.
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "prognostics/fleet_record.hpp"
#include "report/html_report.hpp"
#include "report/record_adapter.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>

namespace emadiag::report {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

namespace pg = emadiag::prognostics;

const std::string kEvil = "<script>alert('x')</script>\"&";
const std::string kEvilEscaped = "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&quot;&amp;";
constexpr double kLimit = 0.12;

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

/// Session i of a position: one a month, 100 cycles apart, FDJ = fdj0 + slope * cycles exactly.
db::StoredTestSession session(const std::string& position, const std::string& serial, int i, std::int64_t cycles, double fdj) {
    db::StoredTestSession s;
    s.tail_number = "N42EM";
    s.position = position;
    s.position_ata = "27-30";
    s.actuator_serial = serial;
    s.phase = "pre-flight";
    char utc[32];
    std::snprintf(utc, sizeof utc, "20%02d-%02d-03T08:00:00Z", 26 + i / 12, 1 + i % 12);
    s.started_utc = utc;
    s.cycles = cycles;
    s.technician_name = kEvil;
    s.technician_certificate = "B1-4711";
    s.source = "test-run";
    s.verdict = "SERVICEABLE";
    s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj, 0.0004, kLimit, "max", "WITHIN", ""});
    s.findings.push_back({"FSJ_Nm", "physics:brk", 0.12, 0.001, 0.2, "max", "WITHIN", ""});
    return s;
}

class RecordAdapter : public ::testing::Test {
protected:
    void SetUp() override {
        // LH-ELEV: SN-A for 4 sessions, then SN-B wearing 1e-5 N m per cycle from 0.08: the limit
        // 0.12 is 4000 cycles after SN-B's first session. RH-ELEV: SN-C, flat.
        for (int i = 0; i < 4; ++i) (void)db::store_session(db_, session("LH-ELEV", "SN-A", i, 1000 + 100 * i, 0.081));
        for (int i = 0; i < 8; ++i) (void)db::store_session(db_, session("LH-ELEV", "SN-B", 4 + i, 1400 + 100 * i, 0.08 + 1e-5 * (100.0 * i)));
        for (int i = 0; i < 8; ++i) (void)db::store_session(db_, session("RH-ELEV", "SN-C", i, 1000 + 100 * i, 0.08));
        db::StoredDiscoveryFinding f;
        f.tail_number = "N42EM";
        f.position = "LH-ELEV";
        f.position_ata = "27-30";
        f.actuator_serial = "SN-B";
        f.found_utc = "2026-10-01T10:00:00Z";
        f.summary = "viscous friction " + kEvil;
        (void)db::store_discovery_finding(db_, f);
        record_ = pg::build_fleet_record(db_, "N42EM", pg::FleetRecordOptions{});
        doc_ = from_fleet_record(record_, {"2027-01-01T00:00:00Z", "test", "memory"});
    }
    db::Database db_{":memory:"};
    pg::FleetRecord record_;
    ReportDocument doc_;
};

TEST_F(RecordAdapter, SectionsPerPositionAndSerialAgainstCycles) {
    EXPECT_EQ(doc_.time_axis, TimeAxis::Cycles);
    ASSERT_EQ(doc_.positions.size(), 2u);
    ASSERT_EQ(doc_.serials.size(), 3u);
    const ReportSection& lh = doc_.positions[0];
    EXPECT_EQ(lh.name, "LH-ELEV");
    EXPECT_EQ(lh.current, "SN-B");
    EXPECT_THAT(lh.ata_reference, HasSubstr("27-30"));
    EXPECT_EQ(lh.sessions.size(), 12u);  // the history shows both serials
    ASSERT_EQ(lh.installations.size(), 2u);
    EXPECT_EQ(lh.installations[0].serial, "SN-A");
    EXPECT_EQ(lh.installations[0].to_utc, lh.installations[1].from_utc);  // SN-A ended when SN-B came
    EXPECT_TRUE(lh.installations[1].to_utc.empty());
    EXPECT_THAT(lh.installations[1].note, HasSubstr("replaced SN-A"));
    ASSERT_EQ(lh.parameters.size(), 4u);
    const ReportParameter& fdj = lh.parameters[0];
    EXPECT_EQ(fdj.name, "FDJ_Nm");
    ASSERT_EQ(fdj.points.size(), 8u);  // the trend is SN-B's, since its installation
    EXPECT_DOUBLE_EQ(fdj.points.front().x, 0.0);
    EXPECT_DOUBLE_EQ(fdj.points.back().x, 700.0);
    ASSERT_TRUE(fdj.fit.has_value());
    ASSERT_TRUE(fdj.crossing_x.has_value());
    EXPECT_NEAR(*fdj.crossing_x, 4000.0, 1.0);  // (0.12 - 0.08) / 1e-5
    EXPECT_EQ(fdj.crossing_label, "cycle 4000");
    ASSERT_EQ(fdj.rul.size(), 2u);
    EXPECT_EQ(fdj.rul[0].unit, "cycles");
    EXPECT_EQ(fdj.rul[1].unit, "days");
    ASSERT_TRUE(fdj.rul[0].estimate.has_value());
    EXPECT_NEAR(*fdj.rul[0].estimate, 3300.0, 1.0);  // from the last session at cycle 700
    EXPECT_TRUE(fdj.rul[0].interval_computed);
    ASSERT_TRUE(fdj.health.index.has_value());
    EXPECT_NEAR(*fdj.health.index, (kLimit - 0.087) / (kLimit - datasheet_nominal("FDJ_Nm")), 1e-9);
    // The finding is on LH-ELEV and SN-B only.
    ASSERT_EQ(lh.findings.size(), 1u);
    EXPECT_TRUE(doc_.positions[1].findings.empty());
    std::size_t serial_findings = 0;
    for (const auto& s : doc_.serials) serial_findings += s.findings.size();
    EXPECT_EQ(serial_findings, 1u);
    // eta_O and eta_A have no data here: no points, no fit, status NO DATA for them.
    EXPECT_TRUE(lh.parameters[2].points.empty());
    EXPECT_EQ(lh.parameters[2].health.status, HealthStatus::NoData);
}

TEST_F(RecordAdapter, HtmlHasEveryPlotAndEscapesStoredStrings) {
    const std::string html = render_html(doc_);
    EXPECT_EQ(count(html, "<svg"), 20u);  // 5 sections x 4 parameters
    EXPECT_THAT(html, HasSubstr("flight cycles"));
    EXPECT_THAT(html, HasSubstr(kEvilEscaped));
    EXPECT_THAT(html, Not(HasSubstr(kEvil)));
    EXPECT_THAT(html, Not(HasSubstr("<script")));
    EXPECT_THAT(html, HasSubstr("viscous friction"));
    EXPECT_THAT(html, HasSubstr("SN-B"));
}

TEST(RecordAdapterAxis, DatesWhenASessionHasNoCycles) {
    db::Database db(":memory:");
    for (int i = 0; i < 6; ++i) {
        auto s = session("LH-ELEV", "SN-A", i, 1000 + 100 * i, 0.08 + 0.001 * i);
        if (i == 2) s.cycles.reset();
        (void)db::store_session(db, s);
    }
    const auto doc = from_fleet_record(pg::build_fleet_record(db, "N42EM", pg::FleetRecordOptions{}), {"now", "test", "memory"});
    EXPECT_EQ(doc.time_axis, TimeAxis::Date);
    const ReportParameter& fdj = doc.positions.at(0).parameters.at(0);
    ASSERT_EQ(fdj.points.size(), 6u);
    // x in days since 1970: 2026-01-03 is day 20456.
    EXPECT_NEAR(fdj.points.front().x, 20456.0 + 8.0 / 24.0, 1e-6);
    EXPECT_THAT(render_html(doc), HasSubstr("date (UTC)"));
}

}  // namespace
}  // namespace emadiag::report
