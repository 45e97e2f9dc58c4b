#pragma once
// A small, general SVG plot: points with optional error bars, lines, shaded bands, horizontal and
// vertical reference lines, a legend and a title, on axes with "nice" ticks (numbers or calendar
// dates). Used for the trend plots of the HTML report (html_report.hpp) and meant for any x/y plot
// (e.g. residuals). Deterministic: the same plot gives the same bytes (coordinates printed with a
// fixed number of decimals, "C" formatting). Every text is XML-escaped. Non-finite values are
// rejected when added, naming the series and the index; a plot without data (points, lines, bands)
// renders its axes, its reference lines and a "no data" note.
#include <optional>
#include <string>
#include <vector>

namespace emadiag::report {

/// How the tick labels of an axis read.
enum class AxisFormat {
    Number,  ///< plain numbers, as many decimals as the tick step needs
    Date,    ///< values are days since 1970-01-01 (UTC); ticks fall on days, month starts or years
};

struct Axis {
    std::string label;
    AxisFormat format = AxisFormat::Number;
    /// Fixed range; empty: from the data (everything drawn) with kAutoRangePadding on each side.
    std::optional<double> min, max;
};

/// Colours are CSS colour strings (e.g. "#1f77b4"); they are escaped like any text.
struct PointSeries {
    std::string name;  ///< in the legend; empty: not in the legend
    std::vector<double> x, y;
    std::vector<double> y_error;  ///< half-width of each point's bar (e.g. 1.96 se); empty: no bars
    std::string color = "#1f5fa8";
};

struct LineSeries {
    std::string name;
    std::vector<double> x, y;  ///< drawn in the order given
    std::string color = "#d2691e";
    bool dashed = false;
};

/// A shaded area between lower and upper over x (e.g. a prediction band).
struct Band {
    std::string name;
    std::vector<double> x, lower, upper;
    std::string color = "#d2691e";
    double opacity = 0.18;
};

struct HLine {
    std::string name;
    double y = 0;
    std::string color = "#c0392b";
    bool dashed = true;
};

struct VLine {
    std::string name;  ///< also written next to the line, at its top
    double x = 0;
    std::string color = "#555555";
    bool dashed = true;
};

/// Fixed size of the drawing (the SVG viewBox), in SVG user units.
inline constexpr double kDefaultPlotWidth = 640;
inline constexpr double kDefaultPlotHeight = 360;
/// Smallest size accepted: room for the margins and the axis labels.
inline constexpr double kMinPlotWidth = 200;
inline constexpr double kMinPlotHeight = 150;
/// Fraction of the data range added on each side when the range comes from the data.
inline constexpr double kAutoRangePadding = 0.05;
/// About this many ticks per axis (Heckbert's nice numbers: steps of 1, 2 or 5 times a power of 10).
inline constexpr int kTargetTicks = 6;

/// One plot. add_* check their input and throw EmadiagError naming the series, the field and the index
/// of a bad value (NaN or infinite, mismatched lengths, a negative error bar, lower above upper).
class SvgPlot {
public:
    SvgPlot() = default;
    SvgPlot(std::string title, Axis x_axis, Axis y_axis);

    SvgPlot& set_title(std::string title);
    SvgPlot& set_x_axis(Axis axis);
    SvgPlot& set_y_axis(Axis axis);
    /// Throws EmadiagError when smaller than kMinPlotWidth x kMinPlotHeight or not finite.
    SvgPlot& set_size(double width, double height);
    /// Prefix of the element ids (the clip path) so that several plots in one HTML page do not
    /// collide; letters, digits, '-' and '_' only (EmadiagError otherwise).
    SvgPlot& set_id(std::string id);
    /// Writes xmlns so the SVG stands alone as a file; false for SVG inline in HTML5, which needs none.
    SvgPlot& set_standalone(bool standalone);

    SvgPlot& add_points(PointSeries s);
    SvgPlot& add_line(LineSeries s);
    SvgPlot& add_band(Band b);
    SvgPlot& add_hline(HLine h);
    SvgPlot& add_vline(VLine v);

    /// No points, lines or bands with a value (reference lines are not data).
    [[nodiscard]] bool empty() const;
    /// The SVG text.
    [[nodiscard]] std::string render() const;

private:
    std::string title_;
    Axis x_axis_, y_axis_;
    double width_ = kDefaultPlotWidth, height_ = kDefaultPlotHeight;
    std::string id_ = "plot";
    bool standalone_ = true;
    std::vector<PointSeries> points_;
    std::vector<LineSeries> lines_;
    std::vector<Band> bands_;
    std::vector<HLine> hlines_;
    std::vector<VLine> vlines_;
};

/// "&", "<", ">", '"' and "'" as character references; valid in XML and in HTML text and attributes.
[[nodiscard]] std::string xml_escape(const std::string& text);

/// Ticks between lo and hi (lo < hi, finite): multiples of a nice step (1, 2 or 5 x 10^k) chosen
/// for about `target` ticks, all within [lo, hi]. Throws EmadiagError on a bad range.
[[nodiscard]] std::vector<double> nice_ticks(double lo, double hi, int target = kTargetTicks);

/// A tick value as text with the decimals `step` needs ("0.085", "120", "2.5e-07").
[[nodiscard]] std::string format_tick(double value, double step);

/// Date ticks between lo and hi (days since 1970): times of day (spans under 3 days), whole days, month
/// starts every 1, 2, 3 or 6 months, or year starts, whichever gives about `target` ticks.
struct DateTick {
    double days = 0;
    std::string label;  ///< "2026-03-06 12:00", "2026-03-06", "2026-03" or "2026"
};
[[nodiscard]] std::vector<DateTick> date_ticks(double lo, double hi, int target = kTargetTicks);

}  // namespace emadiag::report
