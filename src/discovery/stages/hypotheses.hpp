#pragma once
// The hypotheses of a torque round (docs/discovery.md "Hypotheses"): explanations that leave the same
// signature in the torque residual as the one found, each fitted by re-simulation and told apart by
// the re-simulated trajectory; the best replaces the round's winner.
#include "discovery/stages/context.hpp"

#include <string>
#include <vector>

namespace emadiag::discovery::pipeline {

/// The winner's fit in one torque round; a better hypothesis replaces it.
struct RoundFit {
    FitResult fit;
    sim::EmaParams p_new;     ///< the fitted model
    RunSignals new_sim;       ///< the fit's re-simulation at p_new
    TrajectoryError traj_new;
    double fit_bic = 0, peak = 0;
    std::string amp_text;
};

/// Drops from `lib` the periodic shapes in the other angle with the periodicity of a taken periodic
/// term (within kPeriodRefineSpan): that term already is that effect.
void drop_same_periodicity(std::vector<TermFamily>& lib, const std::vector<sim::TermFactor>& taken, double tau);

/// The hypotheses of the round's winner (step, rf) fitted from the model before the round `p_prev` and
/// weighed on the trajectory: step.hypotheses and step.equivalent; when an alternative explains the
/// trajectory better it replaces the winner in `step` and `rf` (and the model's terms are cut back to
/// `model_terms_before`). `lib_best`: the library effect that passed the screening; `gen_rival`: the
/// generated terms that lead the generated library's ranking with a positive delta BIC.
void weigh_hypotheses(Context& ctx, DiscoveryStep& step, RoundFit& rf, const sim::EmaParams& p_prev, std::size_t model_terms_before,
                      const CandidateEvidence* lib_best, const GenericEvidence* gen_rival);

}  // namespace emadiag::discovery::pipeline
