#include "report/history_summary.hpp"

#include "emadiag/io/text_field.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <charconv>
#include <limits>

namespace emadiag::report {
namespace {

constexpr const char* kEnvelopeColor = "#1f5fa8";
constexpr double kEnvelopeOpacity = 0.16;
constexpr const char* kMeansColor = "#5b7fb3";

/// One time column of the older points: the range of their 95 % bars and their mean.
struct Column {
    double x_lo = std::numeric_limits<double>::infinity(), x_hi = -std::numeric_limits<double>::infinity();
    double y_lo = std::numeric_limits<double>::infinity(), y_hi = -std::numeric_limits<double>::infinity();
    double x_sum = 0, y_sum = 0;
    std::size_t n = 0;
};

/// io::csv_field of `s` appended to `out`; a cell of plain ASCII (letters, digits, space and . : _ / ( ) -
/// # not first) is what csv_field would return for it, and is appended as it is without the cost.
void append_cell(std::string& out, const std::string& s) {
    const auto plain = [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == ' ' || c == '.' || c == ':' || c == '_' ||
               c == '/' || c == '(' || c == ')' || c == '-' || c == '#';
    };
    if (s.empty() || (s[0] != '-' && std::all_of(s.begin(), s.end(), plain))) {
        out += s;
        return;
    }
    out += io::csv_field(s);
}

/// A number of a session list: fixed without decimals (cycles) or 6 significant digits (hours), the bytes
/// of printf's "%.0f" and "%.6g" (std::to_chars formats as printf does); "-0" is written "0".
std::string cell_number(double v, bool whole) {
    char buf[512];  // room for any double in %.0f
    const auto r = whole ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 0)
                         : std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 6);
    std::string s(buf, r.ptr);
    if (s == "-0") s = "0";
    return s;
}

}  // namespace

bool summarised(const ReportSection& s, const HistoryLimits& limits) { return s.sessions.size() > limits.full_max; }

std::vector<std::size_t> listed_sessions(const ReportSection& s, const HistoryLimits& limits) {
    const std::size_t n = s.sessions.size();
    const std::size_t recent_from = n > limits.recent ? n - limits.recent : 0;
    std::vector<std::size_t> listed;
    bool after_attention = false;  // the previous session's verdict was not SERVICEABLE
    for (std::size_t i = 0; i < n; ++i) {
        const bool attention = s.sessions[i].verdict != kServiceableVerdict;
        if (i >= recent_from || attention || after_attention) listed.push_back(i);
        after_attention = attention;
    }
    return listed;
}

PlotSummary summarise_plot(const ReportParameter& p, const std::set<std::string>& listed_ids, const HistoryLimits& limits) {
    PlotSummary out;
    out.shown = p;
    out.shown.points.clear();
    const std::size_t n = p.points.size();
    const std::size_t older = n > limits.recent ? n - limits.recent : 0;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < older; ++i) {
        lo = std::min(lo, p.points[i].x);
        hi = std::max(hi, p.points[i].x);
    }
    const std::size_t columns = std::max<std::size_t>(1, limits.columns);
    std::vector<Column> cols(older > 0 ? columns : 0);
    const auto beyond = [&](std::size_t i) { return p.limit && prognostics::is_beyond(p.points[i].value, *p.limit); };
    for (std::size_t i = 0; i < n; ++i) {
        const ReportPoint& pt = p.points[i];
        // A limit crossing: this point and its neighbour on the other side of the limit.
        const bool crossing = (i > 0 && beyond(i) != beyond(i - 1)) || (i + 1 < n && beyond(i) != beyond(i + 1));
        if (i >= older || crossing || listed_ids.count(pt.session_id) > 0) out.shown.points.push_back(pt);
        else ++out.enveloped;
        if (i >= older) continue;
        const double at = hi > lo ? (pt.x - lo) / (hi - lo) * static_cast<double>(columns) : 0.0;
        Column& c = cols[std::min(columns - 1, static_cast<std::size_t>(std::max(0.0, at)))];
        c.x_lo = std::min(c.x_lo, pt.x);
        c.x_hi = std::max(c.x_hi, pt.x);
        c.y_lo = std::min(c.y_lo, pt.value - kZ95 * pt.std_error);
        c.y_hi = std::max(c.y_hi, pt.value + kZ95 * pt.std_error);
        c.x_sum += pt.x;
        c.y_sum += pt.value;
        ++c.n;
    }
    if (older == 0) return out;
    Band band{"earlier " + std::to_string(older) + ": 95 % bars", {}, {}, {}, kEnvelopeColor, kEnvelopeOpacity};
    LineSeries means{"earlier: column mean", {}, {}, kMeansColor, true};
    for (const Column& c : cols) {
        if (c.n == 0) continue;
        band.x.push_back(c.x_lo);
        band.lower.push_back(c.y_lo);
        band.upper.push_back(c.y_hi);
        if (c.x_hi > c.x_lo) {
            band.x.push_back(c.x_hi);
            band.lower.push_back(c.y_lo);
            band.upper.push_back(c.y_hi);
        }
        means.x.push_back(c.x_sum / static_cast<double>(c.n));
        means.y.push_back(c.y_sum / static_cast<double>(c.n));
    }
    out.envelope = std::move(band);
    out.means = std::move(means);
    return out;
}

std::string sessions_csv(const ReportSection& s) {
    std::string out = "session,started_utc,tail,position,serial,phase,kind,operator,cycles,hours,verdict,note,emadiag\n";
    out.reserve(out.size() + s.sessions.size() * 160);
    for (const auto& x : s.sessions) {
        for (const std::string* f : {&x.id, &x.started_utc, &x.tail_number, &x.position, &x.serial, &x.phase, &x.kind, &x.operator_id}) {
            append_cell(out, *f);
            out += ',';
        }
        out += x.cycles ? cell_number(*x.cycles, true) : std::string();
        out += ',';
        out += x.hours ? cell_number(*x.hours, false) : std::string();
        for (const std::string* f : {&x.verdict, &x.note, &x.tool_version}) {
            out += ',';
            append_cell(out, *f);
        }
        out += '\n';
    }
    return out;
}

}  // namespace emadiag::report
