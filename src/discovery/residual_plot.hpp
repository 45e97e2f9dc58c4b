#pragma once
// A self-contained SVG plot of a residual against one variable (issue 10 part 4, `discover --plot`):
// the points, their binned means, the +/- 2 sigma band of the noise floor, axes with ticks and
// labels. Text is XML-escaped; the drawing scales through its viewBox.
#include <string>
#include <vector>

namespace emadiag::discovery {

struct ResidualPlot {
    std::string title;
    std::string x_label, y_label;
    std::vector<double> x, y;
    double floor = 0;  ///< noise floor (1 sigma) of y; 0 draws no band
    int bins = 10;     ///< binned means drawn as a line (equal counts)
};

/// The SVG document. Throws EmadiagError when x and y differ in length or are empty.
[[nodiscard]] std::string residual_svg(const ResidualPlot& plot);
/// Escapes &, <, >, " and ' for XML text and attributes.
[[nodiscard]] std::string xml_escape(const std::string& s);

}  // namespace emadiag::discovery
