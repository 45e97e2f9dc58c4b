#pragma once
// Cycles found by motion (docs/column-map.md, "Cycles"): the signal's speed is its central
// difference over the whole run; a row moves when |speed| > speed_threshold. A cycle starts at a
// moving row whose direction is the chosen one (any: either) when the previous moving row, if any,
// moved the other way, or ended at least min_rest_s before it (the run's start counts as a long
// rest). Each cycle runs to the row before the next start; the last one to the end of the run.
// Rows before the first start belong to no cycle.
#include "measured/column_map.hpp"
#include "measured/measured_run.hpp"

#include <vector>

namespace emadiag::measured {

/// The cycles of `x` (one value per row of `t_s`), keys "motion 1", "motion 2", ...
[[nodiscard]] std::vector<Cycle> detect_motion_cycles(const std::vector<double>& t_s, const std::vector<double>& x,
                                                      const CycleSpec& spec);

}  // namespace emadiag::measured
