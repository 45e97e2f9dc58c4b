#pragma once
// A technician-readable summary of one run: speed reversals, peak current, surface-angle range
// and the residual-torque plateaus while moving fast in each direction.
#include "core/run.hpp"

#include <optional>
#include <string>

namespace emadiag {

/// Speed threshold of the T_R plateaus (ema-reference.md section 7 reference figures).
inline constexpr double kPlateauSpeedRadS = 700.0;

struct RunSummary {
    /// First negative-to-positive (or positive-to-negative) change of sampled mean speed: the last
    /// sample time on the old side and the first on the new side.
    std::optional<std::pair<double, double>> reversal_s;
    double peak_current_a = 0;     ///< max |I|
    double min_surface_deg = 0;
    double max_surface_deg = 0;
    std::optional<double> tr_plateau_down_nm;  ///< median T_R while speed < -kPlateauSpeedRadS
    std::optional<double> tr_plateau_up_nm;    ///< median T_R while speed > +kPlateauSpeedRadS
    std::size_t samples = 0;
};

[[nodiscard]] RunSummary summarise(const Run& run);
[[nodiscard]] std::string format_summary(const RunSummary& s);

}  // namespace emadiag
