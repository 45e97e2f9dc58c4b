#pragma once
// The maintenance report as ONE self-contained HTML file (docs/report-html.md): inline CSS, an inline
// SVG plot per trend (svg_plot.hpp), no script, no external resource (a Content-Security-Policy of
// default-src 'none' makes the browser refuse any), every stored string escaped. The markup is also
// well-formed XML, so it can be checked with any XML parser.
#include "report/history_summary.hpp"
#include "report/report_document.hpp"
#include "report/svg_plot.hpp"

#include <map>
#include <optional>
#include <string>
#include <utility>

namespace emadiag::report {

/// Size of each trend plot in the report.
inline constexpr double kTrendPlotWidth = 560;
inline constexpr double kTrendPlotHeight = 340;

/// The trend plot of one parameter: its points with 95 % bars (kZ95 se), the fit with its band, the
/// limit, the crossing and the last session; `id` makes its element ids unique in the page.
/// `x_range`, when given, fixes the time axis (the report gives all plots of a section the same one,
/// so that a parameter without data still shows the section's period). Throws EmadiagError naming the
/// parameter and the point on a non-finite number.
[[nodiscard]] SvgPlot trend_plot(const ReportParameter& p, TimeAxis axis, const std::string& id,
                                 std::optional<std::pair<double, double>> x_range = std::nullopt);

/// How render_html shows a long history (history_summary.hpp).
struct HtmlOptions {
    HistoryLimits history;
    /// Where every session of a summarised section is, by the section's anchor (section_anchor): a link
    /// relative to the page (the fleet site's CSV beside it). A summarised section without one names
    /// the command that lists them (emadiag export).
    std::map<std::string, std::string> full_history_href;
};

/// The id of the section's element in the page: "position-N" or "serial-N" (N = index + 1).
[[nodiscard]] std::string section_anchor(const ReportSection& section, std::size_t index);

/// The whole HTML document. Throws EmadiagError naming the section and parameter of a bad number.
[[nodiscard]] std::string render_html(const ReportDocument& document, const HtmlOptions& options = {});

/// Text for HTML text and attribute values (the same escaping as xml_escape).
[[nodiscard]] std::string html_escape(const std::string& text);

}  // namespace emadiag::report
