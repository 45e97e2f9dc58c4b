#pragma once
// An augmented model (augmented_model.hpp, the JSON `emadiag discover` writes) used by the
// estimators (`emadiag estimate --model AUGMENTED.json`): the run is brought back to what the
// datasheet model describes by removing the model's effects and terms from it, and the physics
// estimator and the network then fit the datasheet friction law to that.
//  - sensor terms (current, speed, theta, hinge: measured = true + term(true signals)) are inverted
//    per sample by a fixed-point iteration (exact for offsets, converging for gains below 1);
//  - torque terms T_x (T_act = T_M - F_R - T_x, so eq. 7 gives T_R = T_F + T_x) are removed from
//    the current: I' = I - T_x / k_t, evaluated on the sample's (corrected) signals;
//  - sim::Effects are the same as terms (viscous c w, Stribeck, spall, ripple, current gain, hinge
//    offset); a true inertia replaces the run's J in eq. 7; backlash cannot be removed from the
//    samples and is an error.
// Terms are evaluated on the 2 kHz sample (period means), the simulator on every 1 us step: the
// same for smooth terms, an approximation within a period of a speed reversal for sgn(w) terms.
#include "core/run.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/terms.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::discovery {

/// True when `j` is a discovery model JSON (it has "version", "terms" and "health" or "base").
[[nodiscard]] bool is_discovery_model(const nlohmann::json& j);

struct ModelCorrection {
    std::vector<sim::Term> terms;  ///< the model's effects and terms, as terms over the signals
    double j_kgm2 = 0;             ///< the model's plant inertia; 0: the run's own
    [[nodiscard]] std::string text() const;  ///< "torque: 1e-4*w; current: 0.03*I" (for notes)
};

/// The model's effects and terms as removable terms. Throws EmadiagError for an effect the
/// samples cannot be corrected for (backlash), naming it.
[[nodiscard]] ModelCorrection model_correction(const sim::EmaParams& model);

/// The run with the correction removed (see above); same samples, constants and header otherwise.
[[nodiscard]] Run remove_model_effects(const Run& run, const ModelCorrection& correction);

}  // namespace emadiag::discovery
