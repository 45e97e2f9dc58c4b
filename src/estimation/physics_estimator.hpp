#pragma once
// The physics estimator (issue 4 part 4): the Borello friction model of the paper (eqs. 2 to 5)
// fitted to the residual torque T_R (eq. 7) of a run.
//  - DYN / sweep runs: weighted robust least squares on eq. (5) over the slipping samples gives
//    FDJ and eta_O; eq. (4) gives eta_A. An identifiability check (condition number of the
//    weighted normal matrix, spread of |F_R|) reports eta as not identifiable (value empty) when the
//    load is too small or too constant to tell it from FDJ (case A).
//  - BRK runs: FSJ from the two breakaway events (ema-reference.md section 5, with the current
//    chatter correction), and FDJ/eta where the slipping samples allow.
// Every estimate carries a standard error meant to give calibrated 95 % intervals (+/-1.96 se).
// Analysis never reads the true_* or effect_* metadata of a run.
#include "core/run.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/run_checks.hpp"

namespace emadiag {

/// Estimates FDJ, FSJ, eta_O and eta_A from a checked run (any sequence; estimation/run_checks.hpp).
/// Throws EmadiagError when there are too few slipping samples.
/// HealthEstimate::estimator is "physics"; parameters are always the four kParam* in order.
[[nodiscard]] emadiag::HealthEstimate estimate_physics(const emadiag::CheckedRun& run);

}  // namespace emadiag
