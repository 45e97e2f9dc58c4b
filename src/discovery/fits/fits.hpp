#pragma once
// The fits discovery's stages share (src/discovery/README.md): by re-simulation on the torque
// residual (fit_terms, fit_library) and on the trajectory (refit_on_trajectory), and how a fit is
// taken into the model (record_health, adopt_trajectory_fit).
#include "discovery/stages/context.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag::discovery::pipeline {

/// Fits `extra` (terms as data) added to `base` by re-simulation, with the health parameters.
[[nodiscard]] FitResult fit_terms(const Context& ctx, const sim::EmaParams& base, const std::vector<sim::Term>& extra,
                                  int max_iterations = kMaxFitIterations);

/// A library effect fitted by re-simulation from its screening estimate (amplitude and shape), with
/// the health parameters, and the criterion's terms: the delta BIC with its scanned shape
/// parameters and the peak torque it adds.
struct LibraryFit {
    FitResult fit;
    EffectShape shape;
    double bic = 0, peak = 0;
    std::string amp_text;
};
[[nodiscard]] LibraryFit fit_library(const Context& ctx, const CandidateEvidence& win);

/// The largest |sum of the terms' signatures| over the compared samples (N m of T_R).
[[nodiscard]] double peak_of(const Context& ctx, const std::vector<sim::Term>& terms);

/// The health values of a fit (FDJ, eta_O and eta_A by eq. 4, FSJ) into the model's health.
void record_health(std::vector<HealthValue>& health, const FitResult& fit);
/// The term coefficients' standard errors from a fit, onto the model's terms.
void record_term_errors(sim::EmaParams& q, const FitResult& fit);
/// A fit on the trajectory taken into the model: its parameters, the health, the effects' values and
/// the terms' coefficients with their standard errors, the sensor terms as refitted.
void adopt_trajectory_fit(Context& ctx, const FitResult& fit);

/// The own parameters of the model `q`: the health, the fitted values of the effects added (but
/// `skip`) and the coefficients of q's terms.
[[nodiscard]] std::vector<FitParameter> own_parameters(const Context& ctx, const sim::EmaParams& q,
                                                       std::optional<EffectKind> skip = std::nullopt);

/// The own parameters of the model `from` (health, the effects' values, the terms' coefficients)
/// refitted on the trajectory: the values from the trajectory, each standard error at least the
/// torque fit's (the trajectory's Jacobian understates them: the simulator's current chatter makes
/// its cost rough at small steps; see the low-speed stage's profile).
struct TrajectoryRefit {
    FitResult fit;
    double cost = 0;
};
[[nodiscard]] TrajectoryRefit refit_on_trajectory(const Context& ctx, const sim::EmaParams& from);

}  // namespace emadiag::discovery::pipeline
