#pragma once
// The shape every estimator shares (ARCHITECTURE.md "seams"): a function from a Run to estimates
// with uncertainties. The paper's network and the physics estimator sit side by side behind it.
#include "core/run.hpp"
#include "estimation/estimator_id.hpp"
#include "estimation/health_parameter.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag {

/// Two-sided 95 % normal quantile: a parameter's 95 % interval is value +/- kZ95 std_error.
inline constexpr double kZ95 = 1.959963984540054;

struct ParameterEstimate {
    std::string name;              ///< one of kParam*
    std::optional<double> value;   ///< empty when not identifiable or not estimated
    double std_error = 0;          ///< one standard error, same unit as value
    bool identifiable = true;      ///< false: the data cannot tell this parameter (say why in note)
    std::string method;            ///< "physics-wrls", "physics-breakaway", "network", "eq4", ...
    std::string note;              ///< e.g. "not identifiable: |F_R| spread 0.0 N m"
};

struct HealthEstimate {
    EstimatorMethod estimator = EstimatorMethod::Physics;  ///< printed "physics" or "network" (estimator_id.hpp)
    std::vector<ParameterEstimate> parameters;
    /// Free-form diagnostics (condition number, slipping samples used, ...), name -> value.
    std::vector<std::pair<std::string, double>> diagnostics;

    [[nodiscard]] const ParameterEstimate* find(const std::string& name) const {
        for (const auto& p : parameters) {
            if (p.name == name) return &p;
        }
        return nullptr;
    }
};

}  // namespace emadiag
