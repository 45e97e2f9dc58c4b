#pragma once
// Turns a simulator result into a Run (the simulator knows nothing of Runs).
#include "core/run.hpp"

#include "emadiag/sim/simulator.hpp"

namespace emadiag {

/// The Run of a simulation: datasheet constants (not the plant's true inertia), the true health
/// parameters as true_* keys and every non-default effect as effect_<name>.
[[nodiscard]] Run make_run(const sim::SimConfig& config, const sim::SimResult& result);

}  // namespace emadiag
