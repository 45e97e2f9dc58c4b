// A fit taken into the model (record_health, adopt_trajectory_fit), and the model's own parameters
// refitted on the trajectory (refit_on_trajectory).
#include "discovery/fits/fits.hpp"

#include "estimation/health_estimate.hpp"
#include "estimation/physics_friction_law.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery::pipeline {

void record_health(std::vector<HealthValue>& health, const FitResult& fit) {
    for (const auto& f : fit.values) {
        if (f.parameter == FitParameter::fdj()) {
            auto* h = find_health(health, kParamFdj);
            h->value = f.value;
            h->std_error = f.std_error;
            h->source = "refit";
        } else if (f.parameter == FitParameter::eta_o()) {
            auto* h = find_health(health, kParamEtaO);
            h->value = f.value;
            h->std_error = f.std_error;
            h->source = "refit";
            constexpr double kSlopeStep = 1e-6;
            const double slope = eta_a_derivative_central(fit.params.eta_o, fit.params.tau, kSlopeStep);
            auto* eta_a_value = find_health(health, kParamEtaA);
            eta_a_value->value = fit.params.eta_a;
            eta_a_value->std_error = std::abs(slope) * f.std_error;
        }
    }
    find_health(health, kParamFsj)->value = fit.params.fsj_nm;
}

void record_term_errors(sim::EmaParams& q, const FitResult& fit) {
    for (const auto& f : fit.values) {
        if (f.parameter.kind() == FitParameter::Kind::Term) q.terms[f.parameter.term_index()].std_error = f.std_error;
    }
}

void adopt_trajectory_fit(Context& ctx, const FitResult& fit) {
    sim::EmaParams& p = ctx.params;
    DiscoveryReport& rep = ctx.rep;
    p = fit.params;
    record_health(ctx.health(), fit);
    record_term_errors(p, fit);
    for (const auto& f : fit.values) {
        if (f.parameter.kind() != FitParameter::Kind::Effect) continue;
        const std::string field = effect_field(effect_name(f.parameter.fitted_effect()));
        bool known = false;
        for (auto& t : rep.model.terms) {
            if (t.effect == field) {
                t.value = f.value;
                t.std_error = f.std_error;
                known = true;
            }
        }
        if (!known) rep.model.terms.push_back({field, f.value, f.std_error});
    }
    for (auto& f : rep.sensor_findings) {
        for (const auto& t : p.terms) {
            if (t.target == f.term.target && t.basis_text() == f.term.basis_text()) f.term = t;
        }
    }
    ctx.model_sim = fit.signals;
    ctx.traj_now = trajectory_error(ctx.signals, ctx.model_sim, ctx.floor);
}

std::vector<FitParameter> own_parameters(const Context& ctx, const sim::EmaParams& q, std::optional<EffectKind> skip) {
    std::vector<FitParameter> names = ctx.health_parameters;
    for (const auto& a : ctx.accepted) {
        if (skip && a.kind == *skip) continue;
        for (const FittedEffect n : fitted_sim_effects(a.kind)) names.push_back(FitParameter::effect(n));
    }
    for (std::size_t i = 0; i < q.terms.size(); ++i) names.push_back(FitParameter::term(i));
    return names;
}

TrajectoryRefit refit_on_trajectory(const Context& ctx, const sim::EmaParams& from) {
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const std::vector<HealthValue>& health = ctx.health();
    const std::vector<FitParameter> names = own_parameters(ctx, from);
    sim::EmaParams start = from;
    start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
    TrajectoryRefit r;
    r.fit = fit_by_resimulation(ctx.run, s, start, names, ctx.mask, fsj_base_nm, kFitWindowSamples, nullptr, kFinalRefitIterations, &floor);
    r.cost = trajectory_error(s, r.fit.signals, floor).cost;
    for (auto& v : r.fit.values) {
        double before = 0;
        if (v.parameter == FitParameter::fdj()) before = find_health(health, kParamFdj)->std_error;
        else if (v.parameter == FitParameter::eta_o()) before = find_health(health, kParamEtaO)->std_error;
        else if (v.parameter.kind() == FitParameter::Kind::Term) before = from.terms[v.parameter.term_index()].std_error;
        else {
            for (const auto& t : ctx.rep.model.terms) {
                if (t.effect == effect_field(effect_name(v.parameter.fitted_effect()))) before = t.std_error;
            }
        }
        v.std_error = std::max(v.std_error, before);
    }
    return r;
}

}  // namespace emadiag::discovery::pipeline
