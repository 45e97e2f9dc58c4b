#include "report/html_report.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/utc_time.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>

namespace emadiag::report {
namespace {

constexpr const char* kPointColor = "#1f5fa8";
constexpr const char* kFitColor = "#d2691e";
constexpr const char* kLimitColor = "#c0392b";
constexpr const char* kCrossingColor = "#8e44ad";
constexpr const char* kLastSessionColor = "#555555";

/// The browser loads nothing and runs nothing: only the inline style is allowed.
constexpr const char* kContentSecurityPolicy = "default-src 'none'; style-src 'unsafe-inline'";

constexpr const char* kStyle = R"(
body { font-family: sans-serif; font-size: 14px; color: #222; margin: 16px 24px; max-width: 1240px; }
h1 { font-size: 22px; margin: 0 0 4px 0; }
h2 { font-size: 18px; border-bottom: 2px solid #34495e; padding-bottom: 2px; margin-top: 28px; }
h3 { font-size: 15px; margin: 18px 0 6px 0; }
p.meta, p.note, footer { color: #555; }
table { border-collapse: collapse; margin: 4px 0 8px 0; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #eef2f7; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.status { display: inline-block; padding: 1px 8px; border-radius: 3px; font-weight: bold; color: #fff; }
.s-ok { background: #2e8b57; }
.s-monitor { background: #c9a400; }
.s-plan { background: #e67e22; }
.s-replace { background: #c0392b; }
.s-nodata { background: #888; }
.plots { display: flex; flex-wrap: wrap; gap: 12px; }
figure { margin: 0; border: 1px solid #ddd; padding: 4px; }
figcaption { font-size: 12px; color: #444; max-width: 560px; }
svg { max-width: 100%; height: auto; }
)";

std::string h(const std::string& s) { return xml_escape(s); }

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

std::string whole(double v) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << v;
    std::string s = os.str();
    if (s == "-0") s = "0";
    return s;
}

std::string status_class(HealthStatus s) {
    switch (s) {
        case HealthStatus::Ok: return "s-ok";
        case HealthStatus::Monitor: return "s-monitor";
        case HealthStatus::Plan: return "s-plan";
        case HealthStatus::Replace: return "s-replace";
        case HealthStatus::NoData: return "s-nodata";
    }
    return "s-nodata";
}

std::string status_badge(HealthStatus s) { return "<span class=\"status " + status_class(s) + "\">" + h(to_string(s)) + "</span>"; }

std::string optional_num(const std::optional<double>& v, int digits = 4) { return v ? num(*v, digits) : "-"; }


std::string rul_text(const ReportRul& r) {
    const std::string beyond = "&gt; " + h(whole(r.horizon));
    std::string s;
    if (r.estimate) s = h(whole(*r.estimate));
    else if (r.status == "no_crossing") s = beyond;
    else return "-";
    if (r.interval_computed) {
        s += " [" + (r.lower ? h(whole(*r.lower)) : beyond) + ", " + (r.upper ? h(whole(*r.upper)) : beyond) + "]";
    }
    return s + " " + h(r.unit);
}

void check_number(double v, const std::string& where) {
    if (!std::isfinite(v)) {
        std::ostringstream os;
        os << "report: " << where << " = " << v << " is not a finite number";
        throw EmadiagError(os.str());
    }
}

void check_parameter(const ReportParameter& p, const std::string& where) {
    const std::string at = where + " parameter \"" + p.name + "\"";
    check_number(p.nominal, at + " nominal");
    if (p.limit) check_number(p.limit->value, at + " limit");
    for (std::size_t i = 0; i < p.points.size(); ++i) {
        const ReportPoint& q = p.points[i];
        if (std::isfinite(q.x) && std::isfinite(q.value) && std::isfinite(q.std_error)) continue;  // the names only for a bad one
        check_number(q.x, at + " points[" + std::to_string(i) + "].x");
        check_number(q.value, at + " points[" + std::to_string(i) + "].value");
        check_number(q.std_error, at + " points[" + std::to_string(i) + "].std_error");
    }
    if (p.crossing_x) check_number(*p.crossing_x, at + " crossing_x");
    if (p.fit) {
        const ReportCurve& c = *p.fit;
        if (c.mean.size() != c.x.size() || c.lower.size() != c.x.size() || c.upper.size() != c.x.size()) {
            throw EmadiagError("report: " + at + " fit has " + std::to_string(c.x.size()) + " x, " + std::to_string(c.mean.size()) + " mean, " +
                               std::to_string(c.lower.size()) + " lower and " + std::to_string(c.upper.size()) + " upper values");
        }
        for (std::size_t i = 0; i < c.x.size(); ++i) {
            if (std::isfinite(c.x[i]) && std::isfinite(c.mean[i]) && std::isfinite(c.lower[i]) && std::isfinite(c.upper[i]) &&
                c.lower[i] <= c.mean[i] && c.mean[i] <= c.upper[i])
                continue;  // the names only for a bad one
            const std::string fi = at + " fit[" + std::to_string(i) + "]";
            check_number(c.x[i], fi + ".x");
            check_number(c.mean[i], fi + ".mean");
            check_number(c.lower[i], fi + ".lower");
            check_number(c.upper[i], fi + ".upper");
            if (!(c.lower[i] <= c.mean[i] && c.mean[i] <= c.upper[i])) {
                std::ostringstream os;
                os << "report: " << fi << ": the band [" << c.lower[i] << ", " << c.upper[i] << "] does not hold the mean " << c.mean[i];
                throw EmadiagError(os.str());
            }
        }
    }
}

std::string table_row(const std::vector<std::string>& cells, const std::vector<bool>& numeric = {}) {
    std::string s = "<tr>";
    for (std::size_t i = 0; i < cells.size(); ++i) s += (i < numeric.size() && numeric[i] ? "<td class=\"num\">" : "<td>") + cells[i] + "</td>";
    return s + "</tr>\n";
}

std::string header_row(const std::vector<std::string>& cells) {
    std::string s = "<tr>";
    for (const auto& c : cells) s += "<th>" + h(c) + "</th>";
    return s + "</tr>\n";
}

std::string earliest_rul_lower(const ReportSection& s) {
    std::optional<double> best;
    std::string unit;
    for (const auto& p : s.parameters) {
        if (p.rul.empty()) continue;
        const ReportRul& r = p.rul.front();
        if (r.interval_computed && r.lower && (!best || *r.lower < *best)) {
            best = r.lower;
            unit = r.unit;
        }
    }
    return best ? h(whole(*best)) + " " + h(unit) : "-";
}

/// The time span of everything a section plots, padded like an automatic axis; empty without data.
std::optional<std::pair<double, double>> section_x_range(const ReportSection& s) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& p : s.parameters) {
        for (const auto& pt : p.points) {
            lo = std::min(lo, pt.x);
            hi = std::max(hi, pt.x);
        }
        if (p.fit) {
            for (const double x : p.fit->x) {
                lo = std::min(lo, x);
                hi = std::max(hi, x);
            }
        }
    }
    if (!(lo < hi)) return std::nullopt;
    const double pad = (hi - lo) * kAutoRangePadding;
    return std::make_pair(lo - pad, hi + pad);
}

/// What a summarised section shows and where the rest is (history_summary.hpp).
void write_summary_note(std::ostringstream& o, const ReportSection& s, std::size_t listed, const std::string& tail, const std::string& anchor,
                        const HtmlOptions& opt) {
    o << "<p class=\"note history-summary\">Long history: " << s.sessions.size() << " sessions. Listed below: the " << opt.history.recent
      << " most recent, every session whose verdict is not " << kServiceableVerdict << " and the one after it (" << listed
      << " in all). Plots: those sessions and both points of every crossing of the limit as measured; every earlier point lies in the shaded envelope of "
         "the 95 % bars (" << opt.history.columns << " time columns), the dashed line is the mean of each column. Every session: ";
    const auto href = opt.full_history_href.find(anchor);
    if (href != opt.full_history_href.end())
        o << "<a class=\"full-history\" href=\"" << h(href->second) << "\">" << h(href->second) << "</a>";
    else
        o << "<code>emadiag export --tail " << h(tail) << " --format csv</code> (sessions.csv)";
    o << ".</p>\n";
}

void write_sessions(std::ostringstream& o, const ReportSection& s, const std::vector<std::size_t>& listed) {
    o << "<h3>Session history (" << s.sessions.size();
    if (listed.size() != s.sessions.size()) o << ", " << listed.size() << " listed";
    o << ")</h3>\n";
    if (s.sessions.empty()) {
        o << "<p class=\"note\">no sessions</p>\n";
        return;
    }
    o << "<table class=\"sessions\">\n"
      << header_row({"session", "started (UTC)", "tail", "position", "serial", "phase", "kind", "operator", "cycles", "hours", "verdict",
                     "note", "emadiag"});
    for (const std::size_t i : listed) {
        const ReportSession& x = s.sessions[i];
        o << table_row({h(x.id), h(x.started_utc), h(x.tail_number), h(x.position), h(x.serial), h(x.phase), h(x.kind), h(x.operator_id),
                        x.cycles ? h(whole(*x.cycles)) : "-", x.hours ? h(num(*x.hours, 6)) : "-", h(x.verdict), h(x.note), h(x.tool_version)},
                       {false, false, false, false, false, false, false, false, true, true});
    }
    o << "</table>\n";
}

void write_section(std::ostringstream& o, const ReportSection& s, std::size_t index, TimeAxis axis, const std::string& tail, const HtmlOptions& opt) {
    const std::string anchor = section_anchor(s, index);
    const bool summary = summarised(s, opt.history);
    std::vector<std::size_t> listed;
    if (summary) {
        listed = listed_sessions(s, opt.history);
    } else {
        listed.resize(s.sessions.size());
        for (std::size_t i = 0; i < listed.size(); ++i) listed[i] = i;
    }
    std::set<std::string> listed_ids;
    if (summary)
        for (const std::size_t i : listed) listed_ids.insert(s.sessions[i].id);
    o << "<section class=\"" << h(s.kind) << "\" id=\"" << anchor << "\">\n";
    o << "<h2>" << h(s.kind == "serial" ? "Serial " : "Position ") << h(s.name) << " " << status_badge(s.health.status) << "</h2>\n";
    o << "<p>";
    if (!s.ata_reference.empty()) o << h(s.ata_reference) << " &#183; ";
    if (!s.current.empty()) o << (s.kind == "serial" ? "installed at " : "serial installed ") << "<b>" << h(s.current) << "</b> &#183; ";
    o << "health index <b>" << h(optional_num(s.health.index, 3)) << "</b> (95 % lower " << h(optional_num(s.health.index_lower_95, 3))
      << (s.health.index_parameter.empty() ? "" : ", from " + h(s.health.index_parameter)) << ") &#183; status "
      << status_badge(s.health.status) << " " << h(s.health.reason) << "</p>\n";
    for (const auto& n : s.notes) o << "<p class=\"note\">" << h(n) << "</p>\n";
    if (summary) write_summary_note(o, s, listed.size(), tail, anchor, opt);

    o << "<h3>Parameters</h3>\n<table class=\"parameters\">\n"
      << header_row({"parameter", "latest [95 %]", "nominal", "limit", "health index (95 % lower)", "trend", "model", "crossing",
                     "RUL [90 %]", "status"});
    for (const auto& p : s.parameters) {
        std::string latest = "-";
        if (!p.points.empty()) {
            const auto& l = p.points.back();
            latest = h(num(l.value)) + " [" + h(num(l.value - kZ95 * l.std_error)) + ", " + h(num(l.value + kZ95 * l.std_error)) + "]";
        }
        const std::string unit = p.unit.empty() ? "" : " " + h(p.unit);
        const std::string limit = p.limit ? h(prognostics::to_string(p.limit->side)) + " " + h(num(p.limit->value)) + unit : "-";
        const std::string hi = p.health.index ? h(num(*p.health.index, 3)) + " (" + h(num(*p.health.index_lower_95, 3)) + ")" : "-";
        const std::string trend = p.trend_per_period
                                      ? h((*p.trend_per_period >= 0 ? "+" : "") + num(*p.trend_per_period, 3)) + " &#177; " +
                                            h(num(p.trend_per_period_se.value_or(0), 2)) + " per " + h(p.trend_period)
                                      : "-";
        std::string rul;
        for (const auto& r : p.rul) rul += (rul.empty() ? "" : "<br/>") + rul_text(r);
        if (rul.empty()) rul = "-";
        o << table_row({h(p.name), latest + unit, h(num(p.nominal)) + unit, limit, hi, trend, h(p.fit ? p.fit->model : std::string("-")),
                        p.crossing_x ? h(p.crossing_label) : "-", rul, status_badge(p.health.status) + " " + h(p.health.reason)},
                       {false, true, true, true, true, true});
    }
    o << "</table>\n";

    o << "<div class=\"plots\">\n";
    const auto x_range = section_x_range(s);
    for (std::size_t i = 0; i < s.parameters.size(); ++i) {
        const auto& p = s.parameters[i];
        const std::string id = (s.kind == "serial" ? "s" : "p") + std::to_string(index + 1) + "-" + std::to_string(i + 1);
        std::string caption;
        if (summary) {
            const PlotSummary ps = summarise_plot(p, listed_ids, opt.history);
            SvgPlot plot = trend_plot(ps.shown, axis, id, x_range);
            if (ps.envelope) plot.add_band(*ps.envelope);
            if (ps.means) plot.add_line(*ps.means);
            o << "<figure>\n" << plot.render();
            caption = std::to_string(ps.shown.points.size()) + " of " + std::to_string(p.points.size()) + " points drawn as measured, " +
                      std::to_string(ps.enveloped) + " in the envelope only. ";
        } else {
            o << "<figure>\n" << trend_plot(p, axis, id, x_range).render();
        }
        o << "<figcaption>" << h(caption);
        for (const auto& r : p.rul) o << "RUL (" << h(r.unit) << "): " << h(r.summary) << ". ";
        if (p.fit && !p.model_note.empty()) o << "Model: " << h(p.model_note) << ". ";
        for (const auto& n : p.notes) o << h(n) << ". ";
        o << "</figcaption>\n</figure>\n";
    }
    o << "</div>\n";

    if (!s.installations.empty()) {
        o << "<h3>Installations</h3>\n<table class=\"installations\">\n" << header_row({"serial", "tail", "position", "from", "to", "note"});
        for (const auto& in : s.installations)
            o << table_row({h(in.serial), h(in.tail_number), h(in.position), h(in.from_utc), in.to_utc.empty() ? "installed" : h(in.to_utc),
                            h(in.note)});
        o << "</table>\n";
    }

    write_sessions(o, s, listed);

    o << "<h3>Open discovery findings (" << s.findings.size() << ")</h3>\n";
    if (s.findings.empty()) {
        o << "<p class=\"note\">none recorded</p>\n";
    } else {
        o << "<table class=\"findings\">\n" << header_row({"finding", "session", "found (UTC)", "effect", "summary", "status"});
        for (const auto& f : s.findings)
            o << table_row({h(f.id), h(f.session_id), h(f.found_utc), h(f.effect), h(f.summary), h(f.status)});
        o << "</table>\n";
    }
    o << "</section>\n";
}

}  // namespace

std::string section_anchor(const ReportSection& section, std::size_t index) {
    return (section.kind == "serial" ? "serial-" : "position-") + std::to_string(index + 1);
}

std::string html_escape(const std::string& text) { return xml_escape(text); }

SvgPlot trend_plot(const ReportParameter& p, TimeAxis axis, const std::string& id, std::optional<std::pair<double, double>> x_range) {
    check_parameter(p, "trend plot");
    Axis x_axis{axis == TimeAxis::Date ? "date (UTC)" : "flight cycles", axis == TimeAxis::Date ? AxisFormat::Date : AxisFormat::Number, {}, {}};
    if (x_range) {
        x_axis.min = x_range->first;
        x_axis.max = x_range->second;
    }
    Axis y_axis{p.name + (p.unit.empty() ? "" : " [" + p.unit + "]"), AxisFormat::Number, {}, {}};
    SvgPlot plot(p.name + " trend", x_axis, y_axis);
    plot.set_size(kTrendPlotWidth, kTrendPlotHeight).set_id(id).set_standalone(false);
    if (p.fit && !p.fit->x.empty()) {
        plot.add_band(Band{p.fit->band_label, p.fit->x, p.fit->lower, p.fit->upper, kFitColor, 0.18});
        plot.add_line(LineSeries{"fit (" + p.fit->model + ")", p.fit->x, p.fit->mean, kFitColor, false});
    }
    if (p.limit) plot.add_hline(HLine{"limit (" + std::string(prognostics::to_string(p.limit->side)) + ") " + num(p.limit->value), p.limit->value, kLimitColor, true});
    if (!p.points.empty()) {
        PointSeries s{"measured, 95 % bars", {}, {}, {}, kPointColor};
        for (const auto& pt : p.points) {
            s.x.push_back(pt.x);
            s.y.push_back(pt.value);
            s.y_error.push_back(kZ95 * pt.std_error);
        }
        plot.add_vline(VLine{"last session", p.points.back().x, kLastSessionColor, true});
        plot.add_points(std::move(s));
    }
    // The crossing is marked when it lies within what is drawn (a crossing far beyond the projected fit
    // would squeeze the data into a corner; the table gives its date).
    double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
    const auto extend = [&](double x) {
        x_lo = std::min(x_lo, x);
        x_hi = std::max(x_hi, x);
    };
    for (const auto& pt : p.points) extend(pt.x);
    if (p.fit)
        for (const double x : p.fit->x) extend(x);
    if (x_range) {
        x_lo = x_range->first;
        x_hi = x_range->second;
    }
    if (p.crossing_x && *p.crossing_x >= x_lo && *p.crossing_x <= x_hi)
        plot.add_vline(VLine{"crossing " + p.crossing_label, *p.crossing_x, kCrossingColor, true});
    return plot;
}

std::string render_html(const ReportDocument& d, const HtmlOptions& options) {
    for (const auto* list : {&d.positions, &d.serials})
        for (const auto& s : *list)
            for (const auto& p : s.parameters) check_parameter(p, s.kind + " \"" + s.name + "\"");
    std::ostringstream o;
    o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n"
      << "<meta http-equiv=\"Content-Security-Policy\" content=\"" << kContentSecurityPolicy << "\"/>\n"
      << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n"
      << "<title>" << h(d.title) << " " << h(d.tail_number) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
    o << "<header>\n<h1>" << h(d.title) << ": tail " << h(d.tail_number) << "</h1>\n<p class=\"meta\">generated " << h(d.generated_utc);
    if (!d.tool_version.empty()) o << " &#183; emadiag " << h(d.tool_version);
    if (!d.data_source.empty()) o << " &#183; from " << h(d.data_source);
    o << " &#183; " << d.positions.size() << " position(s), " << d.serials.size() << " serial(s)</p>\n";
    for (const auto& n : d.notes) o << "<p class=\"note\">" << h(n) << "</p>\n";
    o << "</header>\n";

    o << "<section class=\"summary\">\n<h2>Summary</h2>\n<table>\n"
      << header_row({"", "name", "ATA", "installed", "health index", "95 % lower", "from", "status", "why", "earliest RUL 90 % lower bound"});
    const auto summary = [&](const ReportSection& s, std::size_t i) {
        const std::string anchor = (s.kind == "serial" ? "#serial-" : "#position-") + std::to_string(i + 1);
        o << table_row({h(s.kind), "<a href=\"" + anchor + "\">" + h(s.name) + "</a>", h(s.ata_reference), h(s.current),
                        h(optional_num(s.health.index, 3)), h(optional_num(s.health.index_lower_95, 3)), h(s.health.index_parameter),
                        status_badge(s.health.status), h(s.health.reason), earliest_rul_lower(s)},
                       {false, false, false, false, true, true});
    };
    for (std::size_t i = 0; i < d.positions.size(); ++i) summary(d.positions[i], i);
    for (std::size_t i = 0; i < d.serials.size(); ++i) summary(d.serials[i], i);
    o << "</table>\n<p class=\"note\">Health index: 1 as new, 0 at the serviceability limit (docs/health-index.md). Status: OK, "
         "MONITOR (95 % lower index below "
      << num(kMonitorIndex) << " or RUL 90 % lower bound below " << whole(kMonitorWindowDays) << " days), PLAN (below " << num(kPlanIndex)
      << " or " << whole(kPlanWindowDays) << " days), REPLACE (at or past the limit).</p>\n</section>\n";

    for (std::size_t i = 0; i < d.positions.size(); ++i) write_section(o, d.positions[i], i, d.time_axis, d.tail_number, options);
    for (std::size_t i = 0; i < d.serials.size(); ++i) write_section(o, d.serials[i], i, d.time_axis, d.tail_number, options);

    o << "<footer>\n<h3>Method</h3>\n<p>" << h(d.method_note) << "</p>\n<p>Plots: points are the sessions' measurements with 95 % bars "
      << "(&#177; " << num(kZ95, 3) << " se); the line is the chosen degradation fit and the shaded area its band; the dashed red line "
      << "is the limit; the dashed vertical lines mark the last session and the predicted crossing of the fitted mean. "
      << "This file loads nothing and runs no script.</p>\n</footer>\n</body>\n</html>\n";
    return o.str();
}

}  // namespace emadiag::report
