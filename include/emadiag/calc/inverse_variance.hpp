#pragma once
// The inverse-variance weighted mean of measurements of one quantity: each value weighted by
// 1 / std_error^2; the mean's standard error is 1 / sqrt(sum of weights). The one implementation
// for the station's summary tables (maintenance_db, session_measurements) and the trends
// (prognostics, build_series). Header-only, below every library, like include/emadiag/io/.
#include <cmath>

namespace emadiag::calc {

/// A standard error a measurement can be weighted by: positive and finite.
[[nodiscard]] inline bool is_weightable(double std_error) { return std_error > 0 && std::isfinite(std_error); }

struct InverseVarianceMean {
    double sum_w = 0, sum_wy = 0;
    /// Adds one measurement (std_error must be is_weightable). Sums in the order added.
    void add(double value, double std_error) {
        const double w = 1.0 / (std_error * std_error);
        sum_w += w;
        sum_wy += w * value;
    }
    [[nodiscard]] double mean() const { return sum_wy / sum_w; }
    [[nodiscard]] double std_error() const { return 1.0 / std::sqrt(sum_w); }
};

}  // namespace emadiag::calc
