// The SVG plot builder: nice ticks and their labels, date ticks, the mapping of data to the viewBox,
// escaping, determinism, degenerate data (none, one point, zero range) and the errors naming the
// series and index of a bad value.
#include "core/emadiag_error.hpp"
#include "prognostics/utc_time.hpp"
#include "report/svg_plot.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace emadiag::report {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

constexpr double kTickTolerance = 1e-12;

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

double days(const std::string& utc) { return prognostics::parse_utc_days_or_throw(utc, "test date"); }

std::vector<std::string> labels(const std::vector<DateTick>& ticks) {
    std::vector<std::string> out;
    for (const auto& t : ticks) out.push_back(t.label);
    return out;
}

TEST(NiceTicks, UnitRangeInFifths) {
    const auto t = nice_ticks(0, 1);
    ASSERT_EQ(t.size(), 6u);
    for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], 0.2 * static_cast<double>(i), kTickTolerance);
}

TEST(NiceTicks, StepsOfTwoAcrossZero) {
    // range 10 -> nice 10; 10 / 5 = 2 -> step 2; first multiple of 2 at or above -3 is -2.
    const auto t = nice_ticks(-3, 7);
    EXPECT_THAT(t, ElementsAre(-2, 0, 2, 4, 6));
}

TEST(NiceTicks, FrictionScaleStepOfFiveThousandths) {
    // range 0.0179 -> nice 0.02; 0.02 / 5 = 0.004 -> rounded to 0.005.
    const auto t = nice_ticks(0.0803, 0.0982);
    ASSERT_EQ(t.size(), 3u);
    EXPECT_NEAR(t[0], 0.085, kTickTolerance);
    EXPECT_NEAR(t[1], 0.090, kTickTolerance);
    EXPECT_NEAR(t[2], 0.095, kTickTolerance);
}

TEST(NiceTicks, AllWithinTheRange) {
    for (const auto& [lo, hi] : std::vector<std::pair<double, double>>{{0.001, 0.0013}, {-1e6, 3e6}, {12.3, 12.31}, {-5, -4}}) {
        const auto t = nice_ticks(lo, hi);
        ASSERT_GE(t.size(), 2u) << lo << " " << hi;
        for (const double v : t) {
            EXPECT_GE(v, lo - 1e-12 * std::abs(lo));
            EXPECT_LE(v, hi + 1e-12 * std::abs(hi));
        }
    }
}

TEST(NiceTicks, BadRangeIsAnError) {
    EXPECT_THAT([] { (void)nice_ticks(1, 1); }, ThrowsMessage<EmadiagError>(HasSubstr("range [1, 1]")));
    EXPECT_THAT([] { (void)nice_ticks(std::nan(""), 1); }, ThrowsMessage<EmadiagError>(HasSubstr("must be finite")));
}

TEST(FormatTick, DecimalsFromTheStep) {
    EXPECT_EQ(format_tick(0.085, 0.005), "0.085");
    EXPECT_EQ(format_tick(120, 20), "120");
    EXPECT_EQ(format_tick(0.5, 0.1), "0.5");
    EXPECT_EQ(format_tick(-0.0, 0.1), "0.0");
    EXPECT_EQ(format_tick(2.5e-7, 1e-7), "2.5e-07");
    EXPECT_EQ(format_tick(3e8, 1e8), "3e+08");
}

TEST(DateTicks, SevenMonthsGetEveryOtherMonth) {
    // 210 days / 5 = 42 days per tick -> 2 months; odd months after 2026-01-05.
    EXPECT_THAT(labels(date_ticks(days("2026-01-05T08:00:00Z"), days("2026-08-03T08:00:00Z"))), ElementsAre("2026-03", "2026-05", "2026-07"));
}

TEST(DateTicks, ThirtyYearsGetEveryFifthYear) {
    const auto t = date_ticks(days("2000-01-01T00:00:00Z"), days("2030-01-01T00:00:00Z"));
    EXPECT_THAT(labels(t), ElementsAre("2000", "2005", "2010", "2015", "2020", "2025", "2030"));
    EXPECT_DOUBLE_EQ(t.front().days, days("2000-01-01T00:00:00Z"));
}

TEST(DateTicks, TwoWeeksGetDays) {
    const auto t = date_ticks(days("2026-03-01T00:00:00Z"), days("2026-03-15T00:00:00Z"));
    // 14 days / 5 = 2.8 days per tick -> every 5 days (multiples of 5 days since 1970-01-01).
    EXPECT_THAT(labels(t), ElementsAre("2026-03-03", "2026-03-08", "2026-03-13"));
    for (const auto& tick : t) EXPECT_DOUBLE_EQ(tick.days, std::floor(tick.days));
}

TEST(DateTicks, HoursWithinOneDay) {
    const auto t = date_ticks(days("2026-03-06T06:00:00Z"), days("2026-03-06T18:00:00Z"));
    // 12 h / 5 = 144 min -> every 3 hours.
    EXPECT_THAT(labels(t), ElementsAre("2026-03-06 06:00", "2026-03-06 09:00", "2026-03-06 12:00", "2026-03-06 15:00", "2026-03-06 18:00"));
}

TEST(DateTicks, NotDatesIsAnError) {
    EXPECT_THAT([] { (void)date_ticks(0, 1e9); }, ThrowsMessage<EmadiagError>(HasSubstr("not a range of dates")));
}

TEST(XmlEscape, AllFiveSpecialCharacters) { EXPECT_EQ(xml_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;"); }

SvgPlot unit_square() {
    SvgPlot p("square", Axis{"x", AxisFormat::Number, 0.0, 10.0}, Axis{"y", AxisFormat::Number, 0.0, 10.0});
    return p;
}

TEST(SvgPlot, CornersMapToThePlottingArea) {
    // No legend (unnamed series): the area starts 26 below the top, 78 from the left, and ends 18 from
    // the right and 46 above the bottom of 640 x 360.
    SvgPlot p = unit_square();
    p.add_points(PointSeries{"", {0, 10}, {0, 10}, {}, "#000000"});
    const std::string svg = p.render();
    EXPECT_THAT(svg, HasSubstr("<circle cx=\"78.00\" cy=\"314.00\""));
    EXPECT_THAT(svg, HasSubstr("<circle cx=\"622.00\" cy=\"26.00\""));
    EXPECT_THAT(svg, HasSubstr("viewBox=\"0 0 640.00 360.00\""));
}

TEST(SvgPlot, ErrorBarsSpanTheirHalfWidth) {
    SvgPlot p = unit_square();
    p.add_points(PointSeries{"", {5}, {5}, {2.5}, "#000000"});
    // y 2.5 .. 7.5 -> 314 - 72 = 242 .. 314 - 216 = 98.
    EXPECT_THAT(p.render(), HasSubstr("d=\"M350.00,242.00 L350.00,98.00"));
}

TEST(SvgPlot, EveryElementKindIsDrawnAndInTheLegend) {
    SvgPlot p("all kinds", Axis{"t", AxisFormat::Number, {}, {}}, Axis{"v", AxisFormat::Number, {}, {}});
    p.add_band(Band{"band", {0, 1, 2}, {0, 0.5, 1}, {1, 1.5, 2}});
    p.add_line(LineSeries{"fit", {0, 1, 2}, {0.5, 1, 1.5}});
    p.add_points(PointSeries{"measured", {0, 1, 2}, {0.4, 1.1, 1.4}, {0.1, 0.1, 0.1}});
    p.add_hline(HLine{"limit", 1.8});
    p.add_vline(VLine{"now", 2});
    const std::string svg = p.render();
    EXPECT_EQ(count(svg, "class=\"band\""), 1u);
    EXPECT_EQ(count(svg, "class=\"line\""), 1u);
    EXPECT_EQ(count(svg, "class=\"errorbar\""), 3u);
    EXPECT_EQ(count(svg, "class=\"hline\""), 1u);
    EXPECT_EQ(count(svg, "class=\"vline\""), 1u);
    EXPECT_EQ(count(svg, "<circle"), 3u + 1u);  // the points and the legend's marker
    for (const char* name : {">band<", ">fit<", ">measured<", ">limit<", ">now<"}) EXPECT_THAT(svg, HasSubstr(name));
    EXPECT_THAT(svg, Not(HasSubstr("no data")));
}

TEST(SvgPlot, TextIsEscapedEverywhere) {
    const std::string evil = "<script>alert('x')</script>&";
    SvgPlot p(evil, Axis{evil, AxisFormat::Number, {}, {}}, Axis{evil, AxisFormat::Number, {}, {}});
    p.add_points(PointSeries{evil, {1, 2}, {1, 2}, {}, "red\"/><script>"});
    p.add_hline(HLine{evil, 1.5});
    p.add_vline(VLine{evil, 1.5});
    const std::string svg = p.render();
    EXPECT_THAT(svg, Not(HasSubstr("<script")));
    EXPECT_THAT(svg, HasSubstr("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&amp;"));
    EXPECT_THAT(svg, HasSubstr("fill=\"red&quot;/&gt;&lt;script&gt;\""));
}

TEST(SvgPlot, SameInputSameBytes) {
    const auto make = [] {
        SvgPlot p("deterministic", Axis{"d", AxisFormat::Date, {}, {}}, Axis{"y", AxisFormat::Number, {}, {}});
        p.add_points(PointSeries{"pts", {20458.3, 20488.3, 20518.3}, {0.0801, 0.0815, 0.0823}, {0.001, 0.001, 0.001}});
        return p.render();
    };
    EXPECT_EQ(make(), make());
}

TEST(SvgPlot, OnePointSitsInTheMiddle) {
    SvgPlot p("one", Axis{"x", AxisFormat::Number, {}, {}}, Axis{"y", AxisFormat::Number, {}, {}});
    p.add_points(PointSeries{"", {3}, {0.08}, {}, "#000000"});
    // Zero ranges are widened symmetrically: the point is at the centre of 78..622 x 26..314.
    EXPECT_THAT(p.render(), HasSubstr("<circle cx=\"350.00\" cy=\"170.00\""));
}

TEST(SvgPlot, ZeroValueRangeAroundZero) {
    SvgPlot p("zeros", Axis{"x", AxisFormat::Number, {}, {}}, Axis{"y", AxisFormat::Number, {}, {}});
    p.add_points(PointSeries{"", {0, 1}, {0, 0}, {}, "#000000"});
    EXPECT_THAT(p.render(), HasSubstr("cy=\"170.00\""));
}

TEST(SvgPlot, EmptyPlotSaysNoData) {
    SvgPlot p("nothing", Axis{"x", AxisFormat::Number, {}, {}}, Axis{"y", AxisFormat::Number, {}, {}});
    p.add_hline(HLine{"limit", 0.096});
    EXPECT_TRUE(p.empty());
    const std::string svg = p.render();
    EXPECT_THAT(svg, HasSubstr("no data"));
    EXPECT_THAT(svg, HasSubstr("class=\"hline\""));
    SvgPlot dates("no dates", Axis{"date", AxisFormat::Date, {}, {}}, Axis{"y", AxisFormat::Number, {}, {}});
    EXPECT_THAT(dates.render(), HasSubstr("no data"));
}

TEST(SvgPlot, StandaloneOnlyWithNamespace) {
    SvgPlot p = unit_square();
    EXPECT_THAT(p.render(), HasSubstr("xmlns=\"http://www.w3.org/2000/svg\""));
    p.set_standalone(false);
    EXPECT_THAT(p.render(), Not(HasSubstr("xmlns")));
}

TEST(SvgPlot, IdPrefixesTheClipPath) {
    SvgPlot p = unit_square();
    p.set_id("p1-2");
    EXPECT_THAT(p.render(), HasSubstr("<clipPath id=\"p1-2-clip\">"));
    EXPECT_THAT(p.render(), HasSubstr("clip-path=\"url(#p1-2-clip)\""));
    EXPECT_THAT([&] { p.set_id("a b"); }, ThrowsMessage<EmadiagError>(HasSubstr("plot id \"a b\"")));
    EXPECT_THAT([&] { p.set_id("1a"); }, ThrowsMessage<EmadiagError>(HasSubstr("must start with a letter")));
}

TEST(SvgPlot, BadValuesNameTheSeriesAndIndex) {
    SvgPlot p = unit_square();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_THAT([&] { p.add_points(PointSeries{"FDJ", {1, 2, 3}, {1, 2, nan}, {}}); },
                ThrowsMessage<EmadiagError>(HasSubstr("point series \"FDJ\": y[2] = nan is not a finite number")));
    EXPECT_THAT([&] { p.add_points(PointSeries{"FDJ", {1, inf}, {1, 2}, {}}); },
                ThrowsMessage<EmadiagError>(HasSubstr("point series \"FDJ\": x[1] = inf")));
    EXPECT_THAT([&] { p.add_points(PointSeries{"FDJ", {1, 2}, {1}, {}}); },
                ThrowsMessage<EmadiagError>(HasSubstr("point series \"FDJ\": y has 1 values, x has 2")));
    EXPECT_THAT([&] { p.add_points(PointSeries{"FDJ", {1, 2}, {1, 2}, {0.1, -0.1}}); },
                ThrowsMessage<EmadiagError>(HasSubstr("y_error[1] = -0.1 is negative")));
    EXPECT_THAT([&] { p.add_line(LineSeries{"fit", {1, 2}, {nan, 2}}); }, ThrowsMessage<EmadiagError>(HasSubstr("line \"fit\": y[0]")));
    EXPECT_THAT([&] { p.add_band(Band{"band", {1, 2}, {1, 3}, {2, 2}}); },
                ThrowsMessage<EmadiagError>(HasSubstr("band \"band\": lower[1] = 3 is above upper[1] = 2")));
    EXPECT_THAT([&] { p.add_hline(HLine{"limit", inf}); }, ThrowsMessage<EmadiagError>(HasSubstr("horizontal line \"limit\": y[0] = inf")));
    EXPECT_THAT([&] { p.add_vline(VLine{"now", nan}); }, ThrowsMessage<EmadiagError>(HasSubstr("vertical line \"now\": x[0] = nan")));
    EXPECT_TRUE(p.empty());  // nothing bad was kept
}

TEST(SvgPlot, FixedRangeMustBeIncreasing) {
    SvgPlot p("bad", Axis{"cycles", AxisFormat::Number, 5.0, 5.0}, Axis{"y", AxisFormat::Number, {}, {}});
    EXPECT_THAT([&] { (void)p.render(); }, ThrowsMessage<EmadiagError>(HasSubstr("x axis \"cycles\": range [5, 5] is empty")));
}

TEST(SvgPlot, SizeIsChecked) {
    SvgPlot p;
    EXPECT_THAT([&] { p.set_size(100, 100); }, ThrowsMessage<EmadiagError>(HasSubstr("plot size 100 x 100")));
    p.set_size(800, 400);
    EXPECT_THAT(p.render(), HasSubstr("viewBox=\"0 0 800.00 400.00\""));
}

TEST(SvgPlot, DataOutsideAFixedRangeIsClipped) {
    SvgPlot p = unit_square();
    p.set_id("c");
    p.add_line(LineSeries{"", {0, 10}, {-50, 50}});
    const std::string svg = p.render();
    // The line is drawn inside the clipped group, however far it runs.
    const auto group = svg.find("<g clip-path=\"url(#c-clip)\">");
    const auto line = svg.find("class=\"line\"");
    ASSERT_NE(group, std::string::npos);
    EXPECT_GT(line, group);
}

}  // namespace
}  // namespace emadiag::report
