#include "report/svg_plot.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <charconv>
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
/// Coordinates below this magnitude are formatted with std::to_chars (they fit its buffer).
constexpr double kToCharsMax = 1e15;

/// A coordinate with two decimals; "-0.00" is written "0.00" so the output does not depend on the sign of zero.
std::string fmt(double v) {
    char buf[64];
    std::string s;
    if (std::abs(v) < kToCharsMax) {
        // The bytes of printf's "%.2f" (std::to_chars formats as printf does in the C locale), several
        // times faster: a long history's page holds some 100 000 coordinates.
        const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 2);
        s.assign(buf, r.ptr);
    } else {
        std::snprintf(buf, sizeof buf, "%.2f", v);  // huge or not finite: as before (truncated to the buffer)
        s = buf;
    }
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

/// Adds everything that is drawn to the x and y data ranges.
void add_data_ranges(const std::vector<PointSeries>& points, const std::vector<LineSeries>& lines, const std::vector<Band>& bands,
                     const std::vector<HLine>& hlines, const std::vector<VLine>& vlines, Range& xr, Range& yr) {
    for (const auto& s : points) {
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            xr.add(s.x[i]);
            const double e = s.y_error.empty() ? 0.0 : s.y_error[i];
            yr.add(s.y[i] - e);
            yr.add(s.y[i] + e);
        }
    }
    for (const auto& s : lines) {
        for (const double v : s.x) xr.add(v);
        for (const double v : s.y) yr.add(v);
    }
    for (const auto& b : bands) {
        for (const double v : b.x) xr.add(v);
        for (const double v : b.lower) yr.add(v);
        for (const double v : b.upper) yr.add(v);
    }
    for (const auto& h : hlines) yr.add(h.y);
    for (const auto& v : vlines) xr.add(v.x);
}

/// The legend's entries, in drawing order of kinds: every named series and reference line.
std::vector<LegendEntry> legend_entries(const std::vector<PointSeries>& points, const std::vector<LineSeries>& lines,
                                        const std::vector<Band>& bands, const std::vector<HLine>& hlines, const std::vector<VLine>& vlines) {
    std::vector<LegendEntry> legend;
    for (const auto& s : points)
        if (!s.name.empty()) legend.push_back({LegendEntry::Point, s.name, s.color});
    for (const auto& s : lines)
        if (!s.name.empty()) legend.push_back({LegendEntry::Line, s.name, s.color, s.dashed});
    for (const auto& b : bands)
        if (!b.name.empty()) legend.push_back({LegendEntry::Area, b.name, b.color, false, b.opacity});
    for (const auto& h : hlines)
        if (!h.name.empty()) legend.push_back({LegendEntry::HRule, h.name, h.color, h.dashed});
    for (const auto& v : vlines)
        if (!v.name.empty()) legend.push_back({LegendEntry::VRule, v.name, v.color, v.dashed});
    return legend;
}

/// The legend: each entry's symbol and name at its place (x offset, row) across the plot's top.
void write_legend(std::ostringstream& o, const std::vector<LegendEntry>& legend, const std::vector<std::pair<double, int>>& legend_pos) {
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

/// One series of points with their error bars.
template <class Px, class Py>
void write_points(std::ostringstream& o, const PointSeries& s, const Px& px, const Py& py) {
    if (s.x.empty()) return;
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
    add_data_ranges(points_, lines_, bands_, hlines_, vlines_, xr, yr);
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
    const std::vector<LegendEntry> legend = legend_entries(points_, lines_, bands_, hlines_, vlines_);
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
    for (const auto& s : points_) write_points(o, s, px, py);
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
    if (!legend.empty()) write_legend(o, legend, legend_pos);
    o << "</svg>\n";
    return o.str();
}

}  // namespace emadiag::report
