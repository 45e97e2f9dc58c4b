#pragma once
// Across load cases (issue 10 part 5; docs/discovery.md "Across load cases").
//
// One run cannot always tell an efficiency below the datasheet from a friction the model lacks that
// follows the load on that run: in case B the aerodynamic hinge moment grows with the deflection, so
// eta_O 0.83 and a friction ~ sgn(w) |theta_u| at the datasheet eta_O fit the same trajectory (the
// single run's "efficiency or friction" stage reports them as equivalent). Runs of the same actuator
// at other loads break the tie: the ground case A has almost no load (an efficiency change does
// nothing there, a friction growing with the deflection does everything), the load rig of A-ext
// ramps the load with time, whatever the deflection.
//
// So, when the runs span two load cases or more and a run's efficiency stage ran, each hypothesis
// is one physical statement about the actuator, held by every run at once:
//   - the efficiency: one eta_O (eq. 4 gives eta_A) for all runs;
//   - each friction family a run's efficiency stage found, friction ~ sgn(w) |F_R| and friction ~
//     sgn(w) |theta_u|: one coefficient for all runs, at the datasheet eta_O (a run's own term of
//     these shapes is taken out of its model first: each hypothesis is judged alone).
// Per run, the hypothesis's parameter is fitted by re-simulation on the run's torque residual (where
// the run identifies it) with the run's own FDJ; the pooled value (weighted mean) is then imposed on
// every run, FDJ refitted, and the re-simulated trajectory costs (1 = the noise floor) averaged over
// the runs. The lowest mean cost names the effect; two within not_told_apart are both reported. The
// chi-square of the per-run values is reported with each (one actuator has one value).
#include "core/run.hpp"
#include "discovery/discovery.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::discovery {

/// One statement about the actuator tested on every run.
struct LoadHypothesis {
    std::string key, text;               ///< "efficiency" or a physics_names.hpp key
    std::string parameter;               ///< "eta_O" or the term's basis
    std::vector<double> values, std_errors;  ///< fitted per run (NaN where the run does not identify it)
    double pooled = 0, pooled_se = 0, chi2 = 0;
    std::size_t dof = 0;
    bool consistent = true;              ///< chi2 within its 99.9 % point
    std::vector<double> costs;           ///< per run, at the pooled value, FDJ refitted
    double mean_cost = 0;
};

struct AcrossLoads {
    bool ran = false;
    std::string skipped;                 ///< why it did not run
    std::vector<std::string> labels, load_cases;
    std::vector<LoadHypothesis> hypotheses;  ///< best mean cost first
    bool equivalent = false;             ///< the best two are not told apart (not_told_apart on the mean costs)
    std::string key, text, verdict;
    std::vector<sim::Term> terms;        ///< the finding when it is a friction term (pooled coefficient)

    [[nodiscard]] nlohmann::json to_json() const;
};

/// The stage over the analysed runs (with their reports, in the same order).
[[nodiscard]] AcrossLoads across_loads(const std::vector<const Run*>& runs, const std::vector<std::string>& labels,
                                       const std::vector<DiscoveryReport>& reports);

}  // namespace emadiag::discovery
