#pragma once
// The one context discovery's stages read and write (src/discovery/README.md): the run and its
// signals, the noise floor and the comparison mask, the model being built and the report.
// discover() (discovery.cpp) makes it and runs the stages (stages.hpp) on it in order.
#include "discovery/screening/candidate_effect.hpp"
#include "discovery/discovery.hpp"
#include "discovery/screening/term_library.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace emadiag::discovery::pipeline {

struct Context {
    Context(const Run& r, const DiscoveryOptions& o)
        : run(r), options(o), checked(check_run(r)), signals(run_signals(checked)) {}

    const Run& run;
    const DiscoveryOptions& options;
    const CheckedRun checked;        ///< the run (or its window) checked once, where it enters the analysis
    const RunSignals signals;        ///< the run's measured signals
    std::vector<char> mask;          ///< the samples compared (comparison_mask with the baseline)
    NoiseFloor floor;                ///< the run's own noise floor
    double fsj_base_nm = 0;          ///< FSJ estimated or datasheet; the model keeps FSJ >= FDJ
    bool eta_free = false;           ///< eta_O is estimated on this run
    std::vector<FitParameter> health_parameters;  ///< the health parameters fitted with every effect
    std::vector<TermFamily> library;        ///< the generated term library (open world)

    // The model being built: its parameters, its re-simulation and its trajectory error.
    sim::EmaParams params;
    RunSignals model_sim;
    TrajectoryError traj_now;
    std::vector<EffectShape> accepted;              ///< library effects added
    std::vector<EffectKind> excluded;               ///< library effects the hypotheses set aside
    std::vector<std::vector<double>> term_columns;  ///< signatures of the added terms as data
    std::vector<std::string> taken_families;        ///< generated families whose terms were added
    std::vector<sim::TermFactor> taken_periods;     ///< period factors of the periodic terms added

    DiscoveryReport rep;
    [[nodiscard]] std::vector<HealthValue>& health() { return rep.model.health; }
    [[nodiscard]] const std::vector<HealthValue>& health() const { return rep.model.health; }
};

/// Relative step of the sensitivity of the model's T_R to a health parameter.
inline constexpr double kSensitivityStepRel = 0.02;
/// Smallest step (N m for FDJ, 1 for eta_O): a health value of 0 still gets a derivative.
inline constexpr double kSensitivityStepMin = 1e-3;
/// Iterations of the final refit on the trajectory: it starts next to its optimum (the torque fit's
/// values), and the time goal of one discover() (2 s of CPU) leaves room for about four batches of a
/// model with a periodic term (a sine per step and lane).
inline constexpr int kFinalRefitIterations = 4;
/// Levenberg-Marquardt iterations of an alternative hypothesis' fit (it starts at the mapped value).
inline constexpr int kHypothesisFitIterations = 6;
/// A re-estimate of a Stribeck friction the torque rounds found may raise the chi-square of the torque
/// window means (against their floor) by at most this (a 95 % change for one parameter is 3.84).
inline constexpr double kLowSpeedMaxTorqueChi2Rise = 4.0;
/// A Stribeck friction found by the trajectory must explain at least this share of the trajectory's
/// excess over its noise floor once the model's own parameters alone have been fitted on the trajectory: a column that
/// explains less is partly mimicking structure of another kind (left to the unexplained-structure report).
inline constexpr double kLowSpeedMinExplained = 0.8;
/// The linearised screen's share of that excess below which the fits are not tried.
inline constexpr double kLowSpeedScreenMinExplained = 0.5;

/// The readable name of a library effect ("viscous friction").
[[nodiscard]] std::string library_effect_text(EffectKind kind);
/// The health value named `name` (kParamFdj, ...) in `v`; nullptr when absent.
[[nodiscard]] HealthValue* find_health(std::vector<HealthValue>& v, const char* name);
[[nodiscard]] const HealthValue* find_health(const std::vector<HealthValue>& v, const char* name);
/// Whether the torque rounds added an effect or terms.
[[nodiscard]] bool steps_added(const DiscoveryReport& rep);
[[nodiscard]] sim::Term make_term(sim::TermTarget target, double coefficient, std::vector<sim::TermFactor> factors);

}  // namespace emadiag::discovery::pipeline
