#include "discovery/residual_plot.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace emadiag::discovery {
namespace {

constexpr double kWidth = 720, kHeight = 440;
constexpr double kLeft = 80, kRight = 20, kTop = 40, kBottom = 60;
constexpr int kTicks = 6;

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os.precision(digits);
    os << v;
    return os.str();
}

/// "Nice" tick step for a range (1, 2 or 5 times a power of ten).
double tick_step(double range) {
    if (!(range > 0)) return 1.0;
    const double raw = range / kTicks;
    const double p = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0}) {
        if (raw <= m * p) return m * p;
    }
    return 10 * p;
}

}  // namespace

std::string xml_escape(const std::string& s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&apos;"; break;
            default: out += c;
        }
    }
    return out;
}

std::string residual_svg(const ResidualPlot& p) {
    if (p.x.size() != p.y.size() || p.x.empty()) {
        throw EmadiagError("residual plot: " + std::to_string(p.x.size()) + " x values and " + std::to_string(p.y.size()) +
                           " y values (need the same number, at least one)");
    }
    auto [xmin_it, xmax_it] = std::minmax_element(p.x.begin(), p.x.end());
    auto [ymin_it, ymax_it] = std::minmax_element(p.y.begin(), p.y.end());
    double x0 = *xmin_it, x1 = *xmax_it, y0 = std::min(*ymin_it, -2 * p.floor), y1 = std::max(*ymax_it, 2 * p.floor);
    if (x1 == x0) { x0 -= 1; x1 += 1; }
    if (y1 == y0) { y0 -= 1; y1 += 1; }
    const double pad_y = 0.05 * (y1 - y0);
    y0 -= pad_y;
    y1 += pad_y;
    const double pw = kWidth - kLeft - kRight, ph = kHeight - kTop - kBottom;
    auto sx = [&](double v) { return kLeft + (v - x0) / (x1 - x0) * pw; };
    auto sy = [&](double v) { return kTop + (y1 - v) / (y1 - y0) * ph; };
    std::ostringstream os;
    os << "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " << kWidth << ' ' << kHeight
       << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    os << "<rect x=\"0\" y=\"0\" width=\"" << kWidth << "\" height=\"" << kHeight << "\" fill=\"white\"/>\n";
    os << "<text x=\"" << kWidth / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">" << xml_escape(p.title)
       << "</text>\n";
    // Noise band +/- 2 sigma and the zero line.
    if (p.floor > 0) {
        os << "<rect x=\"" << kLeft << "\" y=\"" << sy(2 * p.floor) << "\" width=\"" << pw << "\" height=\""
           << sy(-2 * p.floor) - sy(2 * p.floor) << "\" fill=\"#dde8f5\"><title>noise floor +/- 2 sigma ("
           << xml_escape(num(p.floor)) << ")</title></rect>\n";
    }
    if (y0 < 0 && y1 > 0) {
        os << "<line x1=\"" << kLeft << "\" y1=\"" << sy(0) << "\" x2=\"" << kLeft + pw << "\" y2=\"" << sy(0)
           << "\" stroke=\"#999\" stroke-dasharray=\"4 3\"/>\n";
    }
    // Axes and ticks.
    os << "<g stroke=\"black\" fill=\"none\"><rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << pw
       << "\" height=\"" << ph << "\"/></g>\n";
    const double dx = tick_step(x1 - x0), dy = tick_step(y1 - y0);
    for (double v = std::ceil(x0 / dx) * dx; v <= x1 + 1e-9 * dx; v += dx) {
        os << "<line x1=\"" << sx(v) << "\" y1=\"" << kTop + ph << "\" x2=\"" << sx(v) << "\" y2=\"" << kTop + ph + 5
           << "\" stroke=\"black\"/><text x=\"" << sx(v) << "\" y=\"" << kTop + ph + 18 << "\" text-anchor=\"middle\">"
           << xml_escape(num(std::abs(v) < 1e-12 * dx ? 0.0 : v)) << "</text>\n";
    }
    for (double v = std::ceil(y0 / dy) * dy; v <= y1 + 1e-9 * dy; v += dy) {
        os << "<line x1=\"" << kLeft - 5 << "\" y1=\"" << sy(v) << "\" x2=\"" << kLeft << "\" y2=\"" << sy(v)
           << "\" stroke=\"black\"/><text x=\"" << kLeft - 8 << "\" y=\"" << sy(v) + 4 << "\" text-anchor=\"end\">"
           << xml_escape(num(std::abs(v) < 1e-12 * dy ? 0.0 : v, 3)) << "</text>\n";
    }
    os << "<text x=\"" << kLeft + pw / 2 << "\" y=\"" << kHeight - 15 << "\" text-anchor=\"middle\">"
       << xml_escape(p.x_label) << "</text>\n";
    os << "<text transform=\"translate(18 " << kTop + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
       << xml_escape(p.y_label) << "</text>\n";
    // Points.
    os << "<g fill=\"#1f5fa8\" fill-opacity=\"0.45\">\n";
    for (std::size_t i = 0; i < p.x.size(); ++i) {
        if (!std::isfinite(p.x[i]) || !std::isfinite(p.y[i])) continue;
        os << "<circle cx=\"" << num(sx(p.x[i]), 6) << "\" cy=\"" << num(sy(p.y[i]), 6) << "\" r=\"2\"/>\n";
    }
    os << "</g>\n";
    // Binned means.
    const std::size_t n = p.x.size();
    if (p.bins > 0 && n >= static_cast<std::size_t>(2 * p.bins)) {
        std::vector<std::size_t> order(n);
        std::iota(order.begin(), order.end(), 0);
        std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p.x[a] < p.x[b]; });
        os << "<polyline fill=\"none\" stroke=\"#c0392b\" stroke-width=\"2\" points=\"";
        for (int b = 0; b < p.bins; ++b) {
            const std::size_t lo = n * static_cast<std::size_t>(b) / static_cast<std::size_t>(p.bins);
            const std::size_t hi = n * static_cast<std::size_t>(b + 1) / static_cast<std::size_t>(p.bins);
            double mx = 0, my = 0;
            for (std::size_t i = lo; i < hi; ++i) {
                mx += p.x[order[i]];
                my += p.y[order[i]];
            }
            mx /= static_cast<double>(hi - lo);
            my /= static_cast<double>(hi - lo);
            os << num(sx(mx), 6) << ',' << num(sy(my), 6) << ' ';
        }
        os << "\"><title>binned means</title></polyline>\n";
    }
    os << "</svg>\n";
    return os.str();
}

}  // namespace emadiag::discovery
