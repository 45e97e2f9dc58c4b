#pragma once
// The augmented model as data (ARCHITECTURE.md: "JSON terms with coefficients, not code"), read by
// re-simulation through apply_model. Schema version 1 (docs/discovery.md "Model JSON"):
//   {"version": 1, "base": "EMA-REF-1 datasheet",
//    "health": {"FDJ_Nm": {"value", "std_error", "source"}, "FSJ_Nm": ..., "eta_O": ..., "eta_A": ...},
//    "terms": [{"effect": "viscous_nm_s_rad", "value", "std_error"},   (sim::Effects field names)
//              {"target": "torque", "basis": "sgn(w)*abs(theta_u)", "coefficient", "std_error",
//               "name": "friction_deflection", "physics": "friction growing with ..."}],  (terms as data)
//    "error_before": {...}, "error_after": {...},
//    "sim_params": {...}}   (EmaParams::to_json(): what `emadiag simulate --params` reads)
#include "discovery/model/resimulation.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::discovery {

inline constexpr int kModelJsonVersion = 1;
inline constexpr const char* kModelBase = "EMA-REF-1 datasheet";

struct HealthValue {
    std::string name;       ///< kParamFdj, kParamFsj, kParamEtaO, kParamEtaA
    double value = 0;
    double std_error = 0;   ///< 0 when taken from the datasheet
    std::string source;     ///< "estimated", "refit", "datasheet", "eq4"
    std::string note;
};

struct EffectTerm {
    std::string effect;     ///< sim::Effects field name, e.g. "viscous_nm_s_rad"
    double value = 0;
    double std_error = 0;   ///< 0 for a scanned (integer) shape parameter
};

struct AugmentedModel {
    std::vector<HealthValue> health;
    std::vector<EffectTerm> terms;
    /// physics_names.hpp key and text of each params.terms entry (terms as data), same order.
    std::vector<std::string> term_keys, term_texts;
    ErrorMetrics error_before, error_after;
    /// The simulator parameters of the model (constants of the run, health, effects).
    sim::EmaParams params = sim::EmaParams::datasheet();

    [[nodiscard]] nlohmann::json to_json() const;
};

[[nodiscard]] nlohmann::json to_json(const ErrorMetrics& e);

/// Sets the health parameters and effect terms of a model JSON on `params` (the other fields keep
/// their values). Entries of "terms" with a "basis" are terms as data (emadiag/sim/terms.hpp): they
/// replace params.terms. Throws EmadiagError listing every problem: wrong version, unknown effect field,
/// a missing or non-numeric value, a value outside the simulator's range.
void apply_model(const nlohmann::json& model, sim::EmaParams& params);

}  // namespace emadiag::discovery
