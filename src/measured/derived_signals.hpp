#pragma once
// Derived signals of a measured run (docs/column-map.md, "derived"): a difference or sum of two
// signals of one quantity, or a time derivative by the map's differentiator, per cycle or over the
// whole run, with the noise it carries (hypot of the operands', or the differentiator's gain times
// the source's).
#include "measured/column_map.hpp"
#include "measured/measured_run.hpp"

#include <string>

namespace emadiag::measured {

/// The signal `d` makes from `run`'s signals (its operands exist: the map was checked) and cycles.
/// Throws MeasuredError naming `map_path` for operands of two quantities, or a derivative of a
/// quantity the import does not differentiate.
[[nodiscard]] MeasuredSignal derive_signal(const MeasuredRun& run, const DerivedSpec& d, const std::string& map_path);

}  // namespace emadiag::measured
