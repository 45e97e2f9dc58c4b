#include "report/svg_plot.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <sstream>

namespace emadiag::report {
namespace {

/// Margins around the plotting area, in SVG user units.
constexpr double kMarginLeft = 78;
constexpr double kMarginRight = 18;
constexpr double kMarginBottom = 46;
constexpr double kTitleHeight = 26;
constexpr double kLegendRowHeight = 16;
constexpr double kLegendGap = 8;
/// Rough width of one character of the 11-unit sans-serif font, for laying out the legend.
constexpr double kCharWidth = 6.2;
constexpr double kLegendSymbolWidth = 22;
constexpr double kLegendEntryGap = 14;
constexpr double kPointRadius = 3.2;
constexpr double kErrorCapHalfWidth = 3;
/// Dates further than this from 1970 are not dates (about 27 000 years).
constexpr double kMaxDateDays = 1e7;
constexpr double kDaysPerMonth = 30.436875;
constexpr double kDaysPerYear = 365.2425;
constexpr double kMinutesPerDay = 1440.0;
/// Spans shorter than this get ticks at times of day ("2026-03-06 12:00").
constexpr double kMinDateTickSpanDays = 3.0;

/// A coordinate with two decimals; "-0.00" is written "0.00" so the output does not depend on the sign of zero.
std::string fmt(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    std::string s = buf;
    if (s == "-0.00") s = "0.00";
    return s;
}

void check_finite(const std::vector<double>& v, const std::string& kind, const std::string& name, const std::string& field) {
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!std::isfinite(v[i])) {
            std::ostringstream os;
            os << "plot " << kind << " \"" << name << "\": " << field << "[" << i << "] = " << v[i] << " is not a finite number";
            throw EmadiagError(os.str());
        }
    }
}

void check_same_size(std::size_t expected, const std::vector<double>& v, const std::string& kind, const std::string& name,
                     const std::string& field) {
    if (v.size() != expected) {
        throw EmadiagError("plot " + kind + " \"" + name + "\": " + field + " has " + std::to_string(v.size()) + " values, x has " +
                           std::to_string(expected));
    }
}

/// Heckbert, "Nice numbers for graph labels", Graphics Gems (1990): 1, 2, 5 or 10 times a power of 10.
double nice_number(double x, bool round) {
    const double exponent = std::floor(std::log10(x));
    const double fraction = x / std::pow(10.0, exponent);
    double nice = 10;
    if (round) {
        if (fraction < 1.5) nice = 1;
        else if (fraction < 3) nice = 2;
        else if (fraction < 7) nice = 5;
    } else {
        if (fraction <= 1) nice = 1;
        else if (fraction <= 2) nice = 2;
        else if (fraction <= 5) nice = 5;
    }
    return nice * std::pow(10.0, exponent);
}

// Howard Hinnant's civil calendar algorithms (proleptic Gregorian), days since 1970-01-01.
struct Civil {
    std::int64_t year;
    int month, day;
};

Civil civil_from_days(std::int64_t z) {
    z += 719468;
    const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
    const auto doe = static_cast<unsigned>(z - era * 146097);
    const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const std::int64_t y = static_cast<std::int64_t>(yoe) + era * 400;
    const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const unsigned mp = (5 * doy + 2) / 153;
    const unsigned d = doy - (153 * mp + 2) / 5 + 1;
    const unsigned m = mp < 10 ? mp + 3 : mp - 9;
    return {y + (m <= 2 ? 1 : 0), static_cast<int>(m), static_cast<int>(d)};
}

std::int64_t days_from_civil(std::int64_t y, int m, int d) {
    y -= m <= 2 ? 1 : 0;
    const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
    const auto yoe = static_cast<unsigned>(y - era * 400);
    const unsigned doy = (153 * static_cast<unsigned>(m > 2 ? m - 3 : m + 9) + 2) / 5 + static_cast<unsigned>(d) - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

std::string date_label(std::int64_t days, int parts) {
    const Civil c = civil_from_days(days);
    char buf[48];
    if (parts == 3) std::snprintf(buf, sizeof buf, "%04lld-%02d-%02d", static_cast<long long>(c.year), c.month, c.day);
    else if (parts == 2) std::snprintf(buf, sizeof buf, "%04lld-%02d", static_cast<long long>(c.year), c.month);
    else std::snprintf(buf, sizeof buf, "%04lld", static_cast<long long>(c.year));
    return buf;
}

struct Range {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -std::numeric_limits<double>::infinity();
    void add(double v) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    [[nodiscard]] bool valid() const { return lo <= hi; }
};

/// The axis range: fixed bounds as given, the rest from the data with padding; a zero-width range
/// is widened so that a single value sits in the middle.
std::pair<double, double> axis_range(const Axis& axis, Range data, const std::string& which) {
    if (!data.valid()) {
        data.lo = 0;
        data.hi = 1;
    }
    double lo = data.lo, hi = data.hi;
    if (hi - lo <= 0) {
        const double half = lo == 0 ? 1.0 : std::abs(lo) * 0.1;
        lo -= half;
        hi += half;
    } else {
        const double pad = (hi - lo) * kAutoRangePadding;
        lo -= pad;
        hi += pad;
    }
    if (axis.min) lo = *axis.min;
    if (axis.max) hi = *axis.max;
    if (!(lo < hi)) {
        std::ostringstream os;
        os << "plot " << which << " axis \"" << axis.label << "\": range [" << lo << ", " << hi << "] is empty (min must be below max)";
        throw EmadiagError(os.str());
    }
    return {lo, hi};
}

struct LegendEntry {
    enum Kind { Point, Line, Area, HRule, VRule } kind;
    std::string name, color;
    bool dashed = false;
    double opacity = 1;
};

}  // namespace

std::string xml_escape(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
        std::ostringstream os;
        os << "nice_ticks: range [" << lo << ", " << hi << "] must be finite with lo < hi";
        throw EmadiagError(os.str());
    }
    if (target < 2) throw EmadiagError("nice_ticks: target " + std::to_string(target) + " must be at least 2");
    const double step = nice_number(nice_number(hi - lo, false) / (target - 1), true);
    const double first = std::ceil(lo / step - 1e-9);
    std::vector<double> ticks;
    for (double k = first;; k += 1) {
        const double t = k * step;
        if (t > hi + step * 1e-9) break;
        ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
    }
    return ticks;
}

std::string format_tick(double value, double step) {
    char buf[64];
    const double magnitude = std::max(std::abs(value), std::abs(step));
    const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(std::abs(step)) + 1e-9)));
    if (magnitude >= 1e7 || decimals > 6) {
        std::snprintf(buf, sizeof buf, "%.3g", value);
    } else {
        std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
    }
    std::string s = buf;
    if (s.size() > 1 && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);  // "-0.0" -> "0.0"
    return s;
}

std::vector<DateTick> date_ticks(double lo, double hi, int target) {
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
        std::ostringstream os;
        os << "date_ticks: range [" << lo << ", " << hi << "] must be finite with lo < hi";
        throw EmadiagError(os.str());
    }
    if (std::abs(lo) > kMaxDateDays || std::abs(hi) > kMaxDateDays) {
        std::ostringstream os;
        os << "date_ticks: range [" << lo << ", " << hi << "] days since 1970 is not a range of dates (beyond +/-" << kMaxDateDays << " days)";
        throw EmadiagError(os.str());
    }
    if (target < 2) throw EmadiagError("date_ticks: target " + std::to_string(target) + " must be at least 2");
    const double wanted_step = (hi - lo) / (target - 1);
    std::vector<DateTick> ticks;
    if (hi - lo < kMinDateTickSpanDays) {
        // Less than a few days: times of day, every 1, 2, 5, 10, 15 or 30 minutes or 1, 2, 3, 6, 12 or 24 hours.
        long long step_min = 1440;
        for (const long long m : {1LL, 2LL, 5LL, 10LL, 15LL, 30LL, 60LL, 120LL, 180LL, 360LL, 720LL, 1440LL}) {
            if (static_cast<double>(m) >= wanted_step * kMinutesPerDay) {
                step_min = m;
                break;
            }
        }
        const auto first = static_cast<long long>(std::ceil(lo * kMinutesPerDay / static_cast<double>(step_min) - 1e-9));
        for (long long k = first;; ++k) {
            const long long minutes = k * step_min;  // since 1970-01-01T00:00
            const double days = static_cast<double>(minutes) / kMinutesPerDay;
            if (days > hi + 1e-12) break;
            const long long per_day = static_cast<long long>(kMinutesPerDay);
            const std::int64_t day = minutes >= 0 ? minutes / per_day : -((-minutes + per_day - 1) / per_day);
            const long long minute = minutes - day * per_day;
            char hm[48];
            std::snprintf(hm, sizeof hm, " %02lld:%02lld", minute / 60, minute % 60);
            ticks.push_back({days, date_label(day, 3) + hm});
        }
        return ticks;
    }
    const auto first_day = static_cast<std::int64_t>(std::ceil(lo));
    const auto last_day = static_cast<std::int64_t>(std::floor(hi));
    if (wanted_step < 0.5 * kDaysPerMonth) {
        std::int64_t step = 14;
        for (const std::int64_t s : {1, 2, 5, 7, 14}) {
            if (static_cast<double>(s) >= wanted_step) {
                step = s;
                break;
            }
        }
        // Whole days; multiples of 7 from a Monday (1970-01-05) for weekly steps.
        const std::int64_t anchor = step % 7 == 0 ? 4 : 0;
        std::int64_t d = first_day + (((anchor - first_day) % step) + step) % step;
        for (; d <= last_day; d += step) ticks.push_back({static_cast<double>(d), date_label(d, 3)});
    } else if (wanted_step < 8 * kDaysPerMonth) {
        int months = 6;
        for (const int m : {1, 2, 3, 6}) {
            if (m * kDaysPerMonth >= wanted_step) {
                months = m;
                break;
            }
        }
        Civil c = civil_from_days(first_day);
        std::int64_t y = c.year;
        int m = c.month;
        if (c.day != 1) ++m;
        while ((m - 1) % months != 0) ++m;
        for (;;) {
            while (m > 12) {
                m -= 12;
                ++y;
            }
            const std::int64_t d = days_from_civil(y, m, 1);
            if (d > last_day) break;
            ticks.push_back({static_cast<double>(d), date_label(d, 2)});
            m += months;
        }
    } else {
        const auto years = static_cast<std::int64_t>(std::max(1.0, nice_number(wanted_step / kDaysPerYear, true)));
        const Civil c = civil_from_days(first_day);
        std::int64_t y = c.year + ((c.month == 1 && c.day == 1) ? 0 : 1);
        y += ((-y) % years + years) % years;
        for (;; y += years) {
            const std::int64_t d = days_from_civil(y, 1, 1);
            if (d > last_day) break;
            ticks.push_back({static_cast<double>(d), date_label(d, 1)});
        }
    }
    return ticks;
}

SvgPlot::SvgPlot(std::string title, Axis x_axis, Axis y_axis)
    : title_(std::move(title)), x_axis_(std::move(x_axis)), y_axis_(std::move(y_axis)) {}

SvgPlot& SvgPlot::set_title(std::string title) {
    title_ = std::move(title);
    return *this;
}
SvgPlot& SvgPlot::set_x_axis(Axis axis) {
    x_axis_ = std::move(axis);
    return *this;
}
SvgPlot& SvgPlot::set_y_axis(Axis axis) {
    y_axis_ = std::move(axis);
    return *this;
}
SvgPlot& SvgPlot::set_size(double width, double height) {
    if (!std::isfinite(width) || !std::isfinite(height) || width < kMinPlotWidth || height < kMinPlotHeight) {
        std::ostringstream os;
        os << "plot size " << width << " x " << height << " is below the smallest, " << kMinPlotWidth << " x " << kMinPlotHeight;
        throw EmadiagError(os.str());
    }
    width_ = width;
    height_ = height;
    return *this;
}
SvgPlot& SvgPlot::set_id(std::string id) {
    if (id.empty() || id.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_") != std::string::npos ||
        !std::isalpha(static_cast<unsigned char>(id[0]))) {
        throw EmadiagError("plot id \"" + id + "\": must start with a letter and hold only letters, digits, '-' and '_'");
    }
    id_ = std::move(id);
    return *this;
}
SvgPlot& SvgPlot::set_standalone(bool standalone) {
    standalone_ = standalone;
    return *this;
}

SvgPlot& SvgPlot::add_points(PointSeries s) {
    check_same_size(s.x.size(), s.y, "point series", s.name, "y");
    if (!s.y_error.empty()) check_same_size(s.x.size(), s.y_error, "point series", s.name, "y_error");
    check_finite(s.x, "point series", s.name, "x");
    check_finite(s.y, "point series", s.name, "y");
    check_finite(s.y_error, "point series", s.name, "y_error");
    for (std::size_t i = 0; i < s.y_error.size(); ++i) {
        if (s.y_error[i] < 0) {
            std::ostringstream os;
            os << "plot point series \"" << s.name << "\": y_error[" << i << "] = " << s.y_error[i] << " is negative";
            throw EmadiagError(os.str());
        }
    }
    points_.push_back(std::move(s));
    return *this;
}

SvgPlot& SvgPlot::add_line(LineSeries s) {
    check_same_size(s.x.size(), s.y, "line", s.name, "y");
    check_finite(s.x, "line", s.name, "x");
    check_finite(s.y, "line", s.name, "y");
    lines_.push_back(std::move(s));
    return *this;
}

SvgPlot& SvgPlot::add_band(Band b) {
    check_same_size(b.x.size(), b.lower, "band", b.name, "lower");
    check_same_size(b.x.size(), b.upper, "band", b.name, "upper");
    check_finite(b.x, "band", b.name, "x");
    check_finite(b.lower, "band", b.name, "lower");
    check_finite(b.upper, "band", b.name, "upper");
    for (std::size_t i = 0; i < b.x.size(); ++i) {
        if (b.lower[i] > b.upper[i]) {
            std::ostringstream os;
            os << "plot band \"" << b.name << "\": lower[" << i << "] = " << b.lower[i] << " is above upper[" << i << "] = " << b.upper[i];
            throw EmadiagError(os.str());
        }
    }
    if (!(b.opacity >= 0 && b.opacity <= 1)) {
        std::ostringstream os;
        os << "plot band \"" << b.name << "\": opacity " << b.opacity << " is not within [0, 1]";
        throw EmadiagError(os.str());
    }
    bands_.push_back(std::move(b));
    return *this;
}

SvgPlot& SvgPlot::add_hline(HLine h) {
    check_finite({h.y}, "horizontal line", h.name, "y");
    hlines_.push_back(std::move(h));
    return *this;
}

SvgPlot& SvgPlot::add_vline(VLine v) {
    check_finite({v.x}, "vertical line", v.name, "x");
    vlines_.push_back(std::move(v));
    return *this;
}

bool SvgPlot::empty() const {
    const bool no_points = std::all_of(points_.begin(), points_.end(), [](const PointSeries& s) { return s.x.empty(); });
    const bool no_lines = std::all_of(lines_.begin(), lines_.end(), [](const LineSeries& s) { return s.x.empty(); });
    const bool no_bands = std::all_of(bands_.begin(), bands_.end(), [](const Band& b) { return b.x.empty(); });
    return no_points && no_lines && no_bands;
}

std::string SvgPlot::render() const {
    // Data ranges: everything that is drawn.
    Range xr, yr;
    for (const auto& s : points_) {
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            xr.add(s.x[i]);
            const double e = s.y_error.empty() ? 0.0 : s.y_error[i];
            yr.add(s.y[i] - e);
            yr.add(s.y[i] + e);
        }
    }
    for (const auto& s : lines_) {
        for (const double v : s.x) xr.add(v);
        for (const double v : s.y) yr.add(v);
    }
    for (const auto& b : bands_) {
        for (const double v : b.x) xr.add(v);
        for (const double v : b.lower) yr.add(v);
        for (const double v : b.upper) yr.add(v);
    }
    for (const auto& h : hlines_) yr.add(h.y);
    for (const auto& v : vlines_) xr.add(v.x);
    if (!xr.valid() && x_axis_.format == AxisFormat::Date) {
        xr.add(0);
        xr.add(1);
    }
    // Plain variables, not structured bindings: the lambdas below capture them (clang 14, the fuzz
    // and sanitizer compiler, cannot capture a structured binding).
    const std::pair<double, double> x_range = axis_range(x_axis_, xr, "x");
    const std::pair<double, double> y_range = axis_range(y_axis_, yr, "y");
    const double x_lo = x_range.first, x_hi = x_range.second;
    const double y_lo = y_range.first, y_hi = y_range.second;

    // Legend entries, in drawing order of kinds.
    std::vector<LegendEntry> legend;
    for (const auto& s : points_)
        if (!s.name.empty()) legend.push_back({LegendEntry::Point, s.name, s.color});
    for (const auto& s : lines_)
        if (!s.name.empty()) legend.push_back({LegendEntry::Line, s.name, s.color, s.dashed});
    for (const auto& b : bands_)
        if (!b.name.empty()) legend.push_back({LegendEntry::Area, b.name, b.color, false, b.opacity});
    for (const auto& h : hlines_)
        if (!h.name.empty()) legend.push_back({LegendEntry::HRule, h.name, h.color, h.dashed});
    for (const auto& v : vlines_)
        if (!v.name.empty()) legend.push_back({LegendEntry::VRule, v.name, v.color, v.dashed});
    // Lay the legend out in rows across the plot width.
    const double legend_width = width_ - kMarginLeft - kMarginRight;
    std::vector<std::pair<double, int>> legend_pos;  // x offset, row
    {
        double x = 0;
        int row = 0;
        for (const auto& e : legend) {
            const double w = kLegendSymbolWidth + kCharWidth * static_cast<double>(e.name.size()) + kLegendEntryGap;
            if (x > 0 && x + w > legend_width) {
                x = 0;
                ++row;
            }
            legend_pos.emplace_back(x, row);
            x += w;
        }
    }
    const int legend_rows = legend.empty() ? 0 : legend_pos.back().second + 1;
    const double top = kTitleHeight + legend_rows * kLegendRowHeight + (legend_rows ? kLegendGap : 0);
    const double plot_w = width_ - kMarginLeft - kMarginRight;
    const double plot_h = height_ - top - kMarginBottom;
    if (plot_h < kMinPlotHeight / 3) {
        throw EmadiagError("plot \"" + title_ + "\": " + std::to_string(legend.size()) + " legend entries leave no room for the plot at height " +
                           fmt(height_) + "; make it taller");
    }
    const auto px = [&](double x) { return kMarginLeft + (x - x_lo) / (x_hi - x_lo) * plot_w; };
    const auto py = [&](double y) { return top + plot_h - (y - y_lo) / (y_hi - y_lo) * plot_h; };
    const std::string clip = id_ + "-clip";

    std::ostringstream o;
    o << "<svg";
    if (standalone_) o << " xmlns=\"http://www.w3.org/2000/svg\"";
    o << " viewBox=\"0 0 " << fmt(width_) << ' ' << fmt(height_) << "\" width=\"" << fmt(width_) << "\" height=\"" << fmt(height_)
      << "\" role=\"img\" aria-label=\"" << xml_escape(title_) << "\" font-family=\"sans-serif\" font-size=\"11\">\n";
    o << "<title>" << xml_escape(title_) << "</title>\n";
    o << "<defs><clipPath id=\"" << clip << "\"><rect x=\"" << fmt(kMarginLeft) << "\" y=\"" << fmt(top) << "\" width=\"" << fmt(plot_w)
      << "\" height=\"" << fmt(plot_h) << "\"/></clipPath></defs>\n";
    o << "<rect x=\"0\" y=\"0\" width=\"" << fmt(width_) << "\" height=\"" << fmt(height_) << "\" fill=\"#ffffff\"/>\n";

    // Grid and tick labels.
    o << "<g class=\"grid\" stroke=\"#e3e3e3\" stroke-width=\"1\">\n";
    std::vector<std::pair<double, std::string>> xt, yt;
    if (x_axis_.format == AxisFormat::Date) {
        for (const auto& t : date_ticks(x_lo, x_hi)) xt.emplace_back(t.days, t.label);
    } else {
        const auto ticks = nice_ticks(x_lo, x_hi);
        const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : x_hi - x_lo;
        for (const double t : ticks) xt.emplace_back(t, format_tick(t, step));
    }
    if (y_axis_.format == AxisFormat::Date) {
        for (const auto& t : date_ticks(y_lo, y_hi)) yt.emplace_back(t.days, t.label);
    } else {
        const auto ticks = nice_ticks(y_lo, y_hi);
        const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : y_hi - y_lo;
        for (const double t : ticks) yt.emplace_back(t, format_tick(t, step));
    }
    for (const auto& [v, label] : xt)
        o << "<line x1=\"" << fmt(px(v)) << "\" y1=\"" << fmt(top) << "\" x2=\"" << fmt(px(v)) << "\" y2=\"" << fmt(top + plot_h) << "\"/>\n";
    for (const auto& [v, label] : yt)
        o << "<line x1=\"" << fmt(kMarginLeft) << "\" y1=\"" << fmt(py(v)) << "\" x2=\"" << fmt(kMarginLeft + plot_w) << "\" y2=\""
          << fmt(py(v)) << "\"/>\n";
    o << "</g>\n<g class=\"ticks\" fill=\"#333333\">\n";
    for (const auto& [v, label] : xt)
        o << "<text x=\"" << fmt(px(v)) << "\" y=\"" << fmt(top + plot_h + 15) << "\" text-anchor=\"middle\">" << xml_escape(label)
          << "</text>\n";
    for (const auto& [v, label] : yt)
        o << "<text x=\"" << fmt(kMarginLeft - 5) << "\" y=\"" << fmt(py(v) + 4) << "\" text-anchor=\"end\">" << xml_escape(label)
          << "</text>\n";
    o << "</g>\n";

    // Data, clipped to the plotting area.
    o << "<g clip-path=\"url(#" << clip << ")\">\n";
    for (const auto& b : bands_) {
        if (b.x.empty()) continue;
        o << "<path class=\"band\" fill=\"" << xml_escape(b.color) << "\" fill-opacity=\"" << fmt(b.opacity) << "\" stroke=\"none\" d=\"";
        for (std::size_t i = 0; i < b.x.size(); ++i) o << (i ? " L" : "M") << fmt(px(b.x[i])) << ',' << fmt(py(b.upper[i]));
        for (std::size_t i = b.x.size(); i-- > 0;) o << " L" << fmt(px(b.x[i])) << ',' << fmt(py(b.lower[i]));
        o << " Z\"/>\n";
    }
    for (const auto& h : hlines_) {
        o << "<line class=\"hline\" x1=\"" << fmt(kMarginLeft) << "\" y1=\"" << fmt(py(h.y)) << "\" x2=\"" << fmt(kMarginLeft + plot_w)
          << "\" y2=\"" << fmt(py(h.y)) << "\" stroke=\"" << xml_escape(h.color) << "\" stroke-width=\"1.5\""
          << (h.dashed ? " stroke-dasharray=\"6 4\"" : "") << "/>\n";
    }
    for (const auto& v : vlines_) {
        o << "<line class=\"vline\" x1=\"" << fmt(px(v.x)) << "\" y1=\"" << fmt(top) << "\" x2=\"" << fmt(px(v.x)) << "\" y2=\""
          << fmt(top + plot_h) << "\" stroke=\"" << xml_escape(v.color) << "\" stroke-width=\"1.2\""
          << (v.dashed ? " stroke-dasharray=\"3 3\"" : "") << "/>\n";
    }
    for (const auto& s : lines_) {
        if (s.x.empty()) continue;
        o << "<polyline class=\"line\" fill=\"none\" stroke=\"" << xml_escape(s.color) << "\" stroke-width=\"1.8\""
          << (s.dashed ? " stroke-dasharray=\"6 3\"" : "") << " points=\"";
        for (std::size_t i = 0; i < s.x.size(); ++i) o << (i ? " " : "") << fmt(px(s.x[i])) << ',' << fmt(py(s.y[i]));
        o << "\"/>\n";
    }
    for (const auto& s : points_) {
        if (s.x.empty()) continue;
        o << "<g class=\"points\" fill=\"" << xml_escape(s.color) << "\" stroke=\"" << xml_escape(s.color) << "\" stroke-width=\"1.2\">\n";
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            const double cx = px(s.x[i]);
            if (!s.y_error.empty() && s.y_error[i] > 0) {
                const double y1 = py(s.y[i] - s.y_error[i]), y2 = py(s.y[i] + s.y_error[i]);
                o << "<path class=\"errorbar\" fill=\"none\" d=\"M" << fmt(cx) << ',' << fmt(y1) << " L" << fmt(cx) << ',' << fmt(y2) << " M"
                  << fmt(cx - kErrorCapHalfWidth) << ',' << fmt(y1) << " L" << fmt(cx + kErrorCapHalfWidth) << ',' << fmt(y1) << " M"
                  << fmt(cx - kErrorCapHalfWidth) << ',' << fmt(y2) << " L" << fmt(cx + kErrorCapHalfWidth) << ',' << fmt(y2) << "\"/>\n";
            }
            o << "<circle cx=\"" << fmt(cx) << "\" cy=\"" << fmt(py(s.y[i])) << "\" r=\"" << fmt(kPointRadius) << "\"/>\n";
        }
        o << "</g>\n";
    }
    o << "</g>\n";
    // Labels of the vertical lines, at their top inside the plot, one below the other.
    int vline_label_row = 0;
    for (const auto& v : vlines_) {
        if (v.name.empty() || v.x < x_lo || v.x > x_hi) continue;
        const double label_y = top + 12 + kLegendRowHeight * vline_label_row++;
        const bool right_half = px(v.x) > kMarginLeft + plot_w / 2;
        o << "<text class=\"vline-label\" x=\"" << fmt(px(v.x) + (right_half ? -4 : 4)) << "\" y=\"" << fmt(label_y) << "\" text-anchor=\""
          << (right_half ? "end" : "start") << "\" fill=\"" << xml_escape(v.color) << "\">" << xml_escape(v.name) << "</text>\n";
    }

    // Frame, axis labels, title.
    o << "<rect class=\"frame\" x=\"" << fmt(kMarginLeft) << "\" y=\"" << fmt(top) << "\" width=\"" << fmt(plot_w) << "\" height=\""
      << fmt(plot_h) << "\" fill=\"none\" stroke=\"#555555\" stroke-width=\"1\"/>\n";
    o << "<text class=\"xlabel\" x=\"" << fmt(kMarginLeft + plot_w / 2) << "\" y=\"" << fmt(height_ - 10) << "\" text-anchor=\"middle\">"
      << xml_escape(x_axis_.label) << "</text>\n";
    o << "<text class=\"ylabel\" x=\"14\" y=\"" << fmt(top + plot_h / 2) << "\" text-anchor=\"middle\" transform=\"rotate(-90 14 "
      << fmt(top + plot_h / 2) << ")\">" << xml_escape(y_axis_.label) << "</text>\n";
    o << "<text class=\"title\" x=\"" << fmt(width_ / 2) << "\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">"
      << xml_escape(title_) << "</text>\n";
    if (empty()) {
        o << "<text class=\"nodata\" x=\"" << fmt(kMarginLeft + plot_w / 2) << "\" y=\"" << fmt(top + plot_h / 3)
          << "\" text-anchor=\"middle\" fill=\"#888888\">no data</text>\n";
    }

    // Legend.
    if (!legend.empty()) {
        o << "<g class=\"legend\">\n";
        for (std::size_t i = 0; i < legend.size(); ++i) {
            const auto& e = legend[i];
            const double x = kMarginLeft + legend_pos[i].first;
            const double y = kTitleHeight + legend_pos[i].second * kLegendRowHeight + kLegendRowHeight / 2;
            const std::string c = xml_escape(e.color);
            switch (e.kind) {
                case LegendEntry::Point:
                    o << "<circle cx=\"" << fmt(x + 9) << "\" cy=\"" << fmt(y) << "\" r=\"" << fmt(kPointRadius) << "\" fill=\"" << c << "\"/>"
                      << "<line x1=\"" << fmt(x + 9) << "\" y1=\"" << fmt(y - 6) << "\" x2=\"" << fmt(x + 9) << "\" y2=\"" << fmt(y + 6)
                      << "\" stroke=\"" << c << "\"/>\n";
                    break;
                case LegendEntry::Line:
                case LegendEntry::HRule:
                    o << "<line x1=\"" << fmt(x) << "\" y1=\"" << fmt(y) << "\" x2=\"" << fmt(x + 18) << "\" y2=\"" << fmt(y) << "\" stroke=\"" << c
                      << "\" stroke-width=\"1.8\"" << (e.dashed ? " stroke-dasharray=\"4 2\"" : "") << "/>\n";
                    break;
                case LegendEntry::Area:
                    o << "<rect x=\"" << fmt(x) << "\" y=\"" << fmt(y - 5) << "\" width=\"18\" height=\"10\" fill=\"" << c << "\" fill-opacity=\""
                      << fmt(std::max(e.opacity, 0.3)) << "\"/>\n";
                    break;
                case LegendEntry::VRule:
                    o << "<line x1=\"" << fmt(x + 9) << "\" y1=\"" << fmt(y - 6) << "\" x2=\"" << fmt(x + 9) << "\" y2=\"" << fmt(y + 6)
                      << "\" stroke=\"" << c << "\" stroke-width=\"1.2\"" << (e.dashed ? " stroke-dasharray=\"3 3\"" : "") << "/>\n";
                    break;
            }
            o << "<text x=\"" << fmt(x + kLegendSymbolWidth) << "\" y=\"" << fmt(y + 4) << "\">" << xml_escape(e.name) << "</text>\n";
        }
        o << "</g>\n";
    }
    o << "</svg>\n";
    return o.str();
}

}  // namespace emadiag::report
