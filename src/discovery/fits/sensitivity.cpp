// The model's T_R differentiated by a health parameter (discovery.hpp: sensitivity, sensitivities).
#include "discovery/stages/context.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery {

using pipeline::kSensitivityStepMin;
using pipeline::kSensitivityStepRel;

/// d T_R,model / d parameter per sample, by a forward difference of two re-simulations.
std::vector<double> sensitivity(const Run& run, const sim::EmaParams& p, const RunSignals& model,
                                const FitParameter& parameter) {
    return sensitivities(run, p, model, {parameter}).at(0);
}

std::vector<std::vector<double>> sensitivities(const Run& run, const sim::EmaParams& p, const RunSignals& model,
                                               const std::vector<FitParameter>& names) {
    std::vector<double> steps;
    std::vector<sim::EmaParams> moved_params;
    for (const FitParameter& name : names) {
        const double v = get_parameter(p, name);
        double h = std::max(kSensitivityStepRel * std::abs(v), kSensitivityStepMin);
        if (name == FitParameter::eta_o() && v + h > 1.0) h = -h;
        sim::EmaParams q = p;
        set_parameter(q, name, v + h);
        steps.push_back(h);
        moved_params.push_back(q);
    }
    const std::vector<Run> moved_runs = resimulate_many(run, moved_params);  // side by side in SIMD lanes
    std::vector<std::vector<double>> cols;
    for (std::size_t j = 0; j < names.size(); ++j) {
        const RunSignals moved = run_signals(moved_runs[j]);
        std::vector<double> col(model.size());
        for (std::size_t k = 0; k < col.size(); ++k) col[k] = (moved.residual_torque_nm[k] - model.residual_torque_nm[k]) / steps[j];
        cols.push_back(std::move(col));
    }
    return cols;
}

}  // namespace emadiag::discovery
