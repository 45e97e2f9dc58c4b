// The fits by re-simulation on the torque residual: generated terms (fit_terms) and a library effect
// from its screening estimate (fit_library).
#include "discovery/fits/fits.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery::pipeline {

FitResult fit_terms(const Context& ctx, const sim::EmaParams& base, const std::vector<sim::Term>& extra, int max_iterations) {
    const double fsj_base_nm = ctx.fsj_base_nm;
    sim::EmaParams start = base;
    start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
    std::vector<FitParameter> names = ctx.health_parameters;
    for (const auto& t : extra) {
        names.push_back(FitParameter::term(start.terms.size()));
        start.terms.push_back(t);
    }
    return fit_by_resimulation(ctx.run, ctx.signals, start, names, ctx.mask, fsj_base_nm, kFitWindowSamples, &base, max_iterations);
}

LibraryFit fit_library(const Context& ctx, const CandidateEvidence& win) {
    const RunSignals& s = ctx.signals;
    const sim::EmaParams& p = ctx.params;
    const std::vector<char>& mask = ctx.mask;
    const std::vector<FitParameter>& health_parameters = ctx.health_parameters;
    const double fsj_base_nm = ctx.fsj_base_nm;
    LibraryFit out;
    sim::EmaParams start = p;
    start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
    // sim_effects gives the fitted effects first, in the order of fitted_sim_effects; the rest are
    // scanned, not fitted (ripple_periods).
    const std::vector<FittedEffect> fitted = fitted_sim_effects(win.shape.kind);
    const std::vector<std::pair<std::string, double>> effects = sim_effects(win.shape, win.amplitude, p.j_kgm2);
    for (std::size_t i = 0; i < effects.size(); ++i) {
        if (i < fitted.size()) set_parameter(start, FitParameter::effect(fitted[i]), effects[i].second);
        else start.effects.set(effects[i].first, effects[i].second);
    }
    std::vector<FitParameter> names = health_parameters;
    for (const FittedEffect n : fitted) names.push_back(FitParameter::effect(n));
    // Ripple changes sign within a window of samples: it is fitted per sample.
    out.fit = fit_by_resimulation(ctx.run, s, start, names, mask, fsj_base_nm,
                                  win.shape.kind == EffectKind::Ripple ? 1 : kFitWindowSamples, &p);
    const FittedValue& amp = out.fit.values[health_parameters.size()];
    const double rows = static_cast<double>(out.fit.rows);
    const double grid = static_cast<double>(std::max<std::size_t>(1, shape_grid(win.shape.kind, s).size()));
    out.bic = rows * std::log(out.fit.cost_reference / out.fit.cost_end) -
              (1.0 + scanned_parameters(win.shape.kind)) * std::log(rows) - 2.0 * std::log(grid);
    out.shape = win.shape;
    if (out.shape.kind == EffectKind::Stribeck) out.shape.shape1 = out.fit.params.effects.stribeck_speed_rad_s;
    if (out.shape.kind == EffectKind::Spall) {
        out.shape.shape1 = out.fit.params.effects.spall_center_deg;
        out.shape.shape2 = out.fit.params.effects.spall_width_deg;
    }
    const double a = signature_amplitude(out.shape.kind, amp.value, p.j_kgm2);
    const auto x = signature(s, out.shape);
    for (std::size_t k = 0; k < x.size(); ++k) {
        if (mask[k]) out.peak = std::max(out.peak, std::abs(a * x[k]));
    }
    out.amp_text = amp.name + " = " + std::to_string(amp.value) + " +/- " + std::to_string(amp.std_error);
    return out;
}

double peak_of(const Context& ctx, const std::vector<sim::Term>& terms) {
    const RunSignals& s = ctx.signals;
    std::vector<double> sum(s.size(), 0.0);
    for (const auto& t : terms) {
        const auto x = term_signature(s, t);
        for (std::size_t k = 0; k < x.size(); ++k) sum[k] += x[k];
    }
    double peak = 0;
    for (std::size_t k = 0; k < sum.size(); ++k) {
        if (ctx.mask[k]) peak = std::max(peak, std::abs(sum[k]));
    }
    return peak;
}

}  // namespace emadiag::discovery::pipeline
