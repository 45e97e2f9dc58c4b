#pragma once
// A run read from a rig's measurement file through a column map (issue 23 part 2). Every signal is
// in SI (its unit named), the labels are kept as text and are never signals, and the run says it is
// measured, from which file (SHA-256) through which map (SHA-256). The conversion to the project's
// run (core) is left to its caller.
#include "measured/units.hpp"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace emadiag::measured {

struct MeasuredSignal {
    std::string name;
    Quantity quantity = Quantity::dimensionless;
    std::vector<double> values;  ///< SI (si_unit(quantity)), one per row
    /// Standard deviation of the noise (SI), NaN when the map does not give it.
    double noise_si = std::numeric_limits<double>::quiet_NaN();
    /// For a derivative: sigma_out / sigma_in in the interior (1/s); NaN for other signals.
    double noise_gain_per_s = std::numeric_limits<double>::quiet_NaN();
    std::string origin;          ///< "column 'current' (A, scale 1, offset 0, sign +1)", "derivative of position ..."
};

/// Rows [begin, end) of one cycle; `key` is the cycle column's text, or "motion N".
struct Cycle {
    std::size_t begin = 0;
    std::size_t end = 0;
    std::string key;
    std::size_t first_line = 0;  ///< line of the file of row `begin` (1-based)
};

/// A label column, dictionary-encoded: the text of row r is values[row_value[r]].
struct LabelColumn {
    std::string name;
    std::vector<std::string> values;
    std::vector<std::uint32_t> row_value;
    [[nodiscard]] const std::string& at(std::size_t row) const { return values[row_value[row]]; }
};

struct MeasuredRun {
    bool measured = true;        ///< always: a run from a file of measurements, never a simulated one
    std::string source_path;
    std::string source_sha256;   ///< of the file's bytes
    std::string map_path;
    std::string map_sha256;
    std::string map_name;
    double nominal_period_s = 0.0;
    std::vector<double> time_s;  ///< strictly increasing
    std::vector<MeasuredSignal> signals;
    std::vector<Cycle> cycles;   ///< in order, not overlapping; rows outside every cycle are counted below
    std::size_t rows_outside_cycles = 0;
    std::vector<LabelColumn> labels;
    std::size_t comment_lines = 0;  ///< lines skipped for the comment prefix
    std::size_t blank_lines = 0;    ///< empty lines skipped

    [[nodiscard]] std::size_t rows() const { return time_s.size(); }
    /// The signal of that name, or nullptr.
    [[nodiscard]] const MeasuredSignal* signal(const std::string& name) const {
        for (const MeasuredSignal& s : signals) {
            if (s.name == name) return &s;
        }
        return nullptr;
    }
    [[nodiscard]] const LabelColumn* label(const std::string& name) const {
        for (const LabelColumn& l : labels) {
            if (l.name == name) return &l;
        }
        return nullptr;
    }
};

}  // namespace emadiag::measured
