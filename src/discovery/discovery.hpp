#pragma once
// Closing the loop with measured data (docs/discovery.md): the residual between a run and the
// datasheet model with the run's estimated health, traced to an effect the model lacks, that
// effect added and fitted by re-simulation, and the error before and after.
//   1. Baseline: datasheet + estimate_physics(run) (FDJ, eta where identifiable, FSJ on BRK runs;
//      the datasheet value otherwise, said in the health note). Re-simulated, noise none.
//   2. Screening of the candidate library (candidate_effect.hpp) on the model-consistent residual
//      with the BIC and an effect-size floor (effect_screen.hpp).
//   3. The winner's coefficients are fitted with FDJ (and eta_O) by re-simulation
//      (resimulation.hpp); the fit must confirm it (the same BIC on the re-simulated cost, peak
//      torque >= kMinEffectPeakNm); screening repeats with it in the base, up to max_effects.
// Only the Run's samples, constants, case and sequence are read: never true_* / effect_* metadata.
#include "core/run.hpp"
#include "discovery/augmented_model.hpp"
#include "discovery/effect_screen.hpp"
#include "discovery/resimulation.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace emadiag::discovery {

/// At most this many effects are added (the criterion usually stops earlier).
inline constexpr int kMaxEffects = 3;

struct DiscoveryOptions {
    int max_effects = kMaxEffects;
};

/// One round: the screening, and the effect it added (if any) with the error after it.
struct DiscoveryStep {
    ScreenResult screen;
    std::optional<EffectShape> added;
    std::vector<FittedValue> fitted;  ///< values and standard errors of the re-simulation fit
    std::string rejected_by_fit;      ///< why the winner was not added after its fit (empty if added)
    double fit_delta_bic = 0;         ///< the criterion on the re-simulated cost, without vs with the effect
    int simulations = 0;
    ErrorMetrics error_after;
};

struct DiscoveryReport {
    std::string load_case, sequence;
    std::size_t samples = 0;
    std::vector<HealthValue> baseline_health;  ///< step 1: estimated or datasheet
    AugmentedModel model;                      ///< health refit with the added effects
    std::vector<DiscoveryStep> steps;
    std::vector<std::string> notes;

    /// Names of the added effects, in order ("viscous", ...).
    [[nodiscard]] std::vector<std::string> added_effects() const;
    /// The model's value of a term by sim::Effects name ("viscous"); nullopt when not in the model.
    [[nodiscard]] std::optional<double> term_value(const std::string& sim_name) const;
    [[nodiscard]] nlohmann::json to_json() const;
};

/// Throws EmadiagError on a run that cannot be analysed (NaN, too few samples or screening
/// samples, unknown case/sequence), naming the field, the value and the limit.
[[nodiscard]] DiscoveryReport discover(const Run& run, const DiscoveryOptions& options = {});

}  // namespace emadiag::discovery
