#include "discovery/discovery.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/candidate_effect.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/physics_estimator.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery {
namespace {

HealthValue health_from(const HealthEstimate& est, const char* name, double datasheet_value) {
    HealthValue h;
    h.name = name;
    const ParameterEstimate* p = est.find(name);
    if (p != nullptr && p->value) {
        h.value = *p->value;
        h.std_error = p->std_error;
        h.source = "estimated";
        h.note = p->note;
    } else {
        h.value = datasheet_value;
        h.source = "datasheet";
        h.note = p != nullptr && !p->note.empty() ? p->note : "not estimated from this run";
    }
    return h;
}

/// Range a health estimate must lie in to start the model (FDJ, FSJ: >= 0; eta_O in (0, 1]).
constexpr double kMinHealthFdjNm = 0.0;
constexpr double kMaxHealthFdjNm = 10.0;
constexpr double kMinHealthEtaO = 0.3;
constexpr double kMaxHealthEtaO = 1.0;

/// Relative step of the sensitivity of the model's T_R to a health parameter.
constexpr double kSensitivityStepRel = 0.02;
/// Smallest step (N m for FDJ, 1 for eta_O): a health value of 0 still gets a derivative.
constexpr double kSensitivityStepMin = 1e-3;

/// d T_R,model / d parameter per sample, by a forward difference of two re-simulations.
std::vector<double> sensitivity(const Run& run, const sim::EmaParams& p, const RunSignals& model,
                                const std::string& name) {
    const double v = get_parameter(p, name);
    double h = std::max(kSensitivityStepRel * std::abs(v), kSensitivityStepMin);
    if (name == "eta_o" && v + h > 1.0) h = -h;
    sim::EmaParams q = p;
    set_parameter(q, name, v + h);
    const RunSignals moved = run_signals(resimulate(run, q));
    std::vector<double> col(model.size());
    for (std::size_t k = 0; k < col.size(); ++k) col[k] = (moved.residual_torque_nm[k] - model.residual_torque_nm[k]) / h;
    return col;
}

HealthValue* find_health(std::vector<HealthValue>& v, const char* name) {
    for (auto& h : v) {
        if (h.name == name) return &h;
    }
    return nullptr;
}

}  // namespace

std::vector<std::string> DiscoveryReport::added_effects() const {
    std::vector<std::string> v;
    for (const auto& s : steps) {
        if (s.added) v.push_back(effect_name(s.added->kind));
    }
    return v;
}

std::optional<double> DiscoveryReport::term_value(const std::string& sim_name) const {
    const std::string field = effect_field(sim_name);
    for (const auto& t : model.terms) {
        if (t.effect == field) return t.value;
    }
    return std::nullopt;
}

nlohmann::json DiscoveryReport::to_json() const {
    nlohmann::json j;
    j["schema"] = "emadiag-discover";
    j["version"] = kModelJsonVersion;
    j["run"] = {{"case", load_case}, {"sequence", sequence}, {"samples", samples}};
    j["added_effects"] = added_effects();
    j["baseline_health"] = nlohmann::json::object();
    for (const auto& h : baseline_health) {
        j["baseline_health"][h.name] = {{"value", h.value}, {"std_error", h.std_error}, {"source", h.source}, {"note", h.note}};
    }
    j["steps"] = nlohmann::json::array();
    for (const auto& s : steps) {
        nlohmann::json js;
        js["screening_samples"] = s.screen.samples;
        js["screening_windows"] = s.screen.windows;
        js["base_residual_rms_Nm"] = s.screen.base_rms_nm;
        js["ranking"] = nlohmann::json::array();
        for (const auto& c : s.screen.ranking) {
            js["ranking"].push_back({{"effect", effect_name(c.shape.kind)},
                                     {"signature", signature_text(c.shape.kind)},
                                     {"shape", shape_text(c.shape)},
                                     {"amplitude", c.amplitude},
                                     {"amplitude_se", c.amplitude_se},
                                     {"delta_bic", c.delta_bic},
                                     {"explained_rms_Nm", c.explained_rms_nm},
                                     {"peak_torque_Nm", c.peak_torque_nm},
                                     {"rss_ratio", c.rss_ratio},
                                     {"passes_criterion", c.accepted},
                                     {"reason", c.reason}});
        }
        js["added"] = s.added ? nlohmann::json(effect_name(s.added->kind)) : nlohmann::json(nullptr);
        if (!s.rejected_by_fit.empty()) js["rejected_by_fit"] = s.rejected_by_fit;
        js["fitted"] = nlohmann::json::array();
        for (const auto& f : s.fitted) js["fitted"].push_back({{"name", f.name}, {"value", f.value}, {"std_error", f.std_error}});
        js["simulations"] = s.simulations;
        js["fit_delta_bic"] = s.fit_delta_bic;
        if (s.added) js["error_after"] = discovery::to_json(s.error_after);
        j["steps"].push_back(js);
    }
    j["model"] = model.to_json();
    const auto ratio = [](double a, double b) { return b > 0 ? nlohmann::json(a / b) : nlohmann::json(nullptr); };
    j["ratio_before_after"] = {
        {"current_rms", ratio(model.error_before.current_rms_a, model.error_after.current_rms_a)},
        {"residual_torque_rms", ratio(model.error_before.residual_torque_rms_nm, model.error_after.residual_torque_rms_nm)},
        {"residual_torque_window_rms",
         ratio(model.error_before.residual_torque_window_rms_nm, model.error_after.residual_torque_window_rms_nm)}};
    j["notes"] = notes;
    return j;
}

DiscoveryReport discover(const Run& run, const DiscoveryOptions& options) {
    const RunSignals s = run_signals(run);
    DiscoveryReport rep;
    rep.load_case = run.load_case;
    rep.sequence = run.sequence;
    rep.samples = run.samples.size();

    // 1. Baseline: datasheet + the health the run identifies.
    const HealthEstimate est = estimate_physics(run);
    sim::EmaParams p = resim_config(run, sim::EmaParams::datasheet()).params;
    auto& health = rep.model.health;
    health.push_back(health_from(est, kParamFdj, p.fdj_nm));
    health.push_back(health_from(est, kParamFsj, p.fsj_nm));
    health.push_back(health_from(est, kParamEtaO, p.eta_o));
    HealthValue eta_a = health_from(est, kParamEtaA, p.eta_a);
    // An estimate outside the simulator's range (a large unmodelled effect can push it there) starts
    // the model at the nearest valid value; the note says so.
    auto start_value = [&](HealthValue& h, double lo, double hi) {
        if (h.value >= lo && h.value <= hi) return h.value;
        const double v = std::clamp(h.value, lo, hi);
        rep.notes.push_back(h.name + ": estimate " + std::to_string(h.value) + " is outside the simulator's range [" +
                            std::to_string(lo) + ", " + std::to_string(hi) + "]; the model starts from " +
                            std::to_string(v));
        h.value = v;
        return v;
    };
    p.fdj_nm = start_value(health[0], kMinHealthFdjNm, kMaxHealthFdjNm);
    p.fsj_nm = start_value(health[1], kMinHealthFdjNm, kMaxHealthFdjNm);
    const bool eta_free = health[2].source == "estimated";
    p.eta_o = start_value(health[2], kMinHealthEtaO, kMaxHealthEtaO);
    p.eta_a = sim::eta_a_from_eta_o(p.eta_o, p.tau);  // eq. (4), as the simulator uses it
    eta_a.value = p.eta_a;
    eta_a.source = eta_free ? "eq4" : "datasheet";
    health.push_back(eta_a);
    const double fsj_base_nm = p.fsj_nm;  // estimated or datasheet; the model keeps FSJ >= FDJ
    if (p.fsj_nm < p.fdj_nm) {
        rep.notes.push_back("FSJ (" + health[1].source + ") " + std::to_string(p.fsj_nm) +
                            " N m is below the estimated FDJ; the model uses FSJ = FDJ");
        p.fsj_nm = p.fdj_nm;
        health[1].value = p.fsj_nm;
    }
    for (const auto& h : health) {
        if (h.source == "datasheet") rep.notes.push_back(h.name + ": datasheet value (" + h.note + ")");
    }

    const RunSignals base_sim = run_signals(resimulate(run, p));
    rep.baseline_health = health;
    const std::vector<char> mask = comparison_mask(s, base_sim);
    const auto compared = static_cast<std::size_t>(std::count(mask.begin(), mask.end(), char{1}));
    if (compared < kMinScreenSamples) {
        throw EmadiagError("discovery: the " + run.sequence + " run has " + std::to_string(compared) +
                           " comparison samples (slipping in the run and the model); at least " +
                           std::to_string(kMinScreenSamples) +
                           " are needed (a BRK run barely moves: use a DYN or sweep run)");
    }
    rep.model.error_before = model_error(s, base_sim, mask);
    rep.model.error_after = rep.model.error_before;

    // 2 and 3: screen, add the winner, fit by re-simulation, repeat while the criterion says so.
    std::vector<std::string> health_names = {"fdj_nm"};
    if (eta_free) health_names.push_back("eta_o");
    std::vector<EffectShape> accepted;
    RunSignals model_sim = base_sim;
    for (int round = 0; round < options.max_effects; ++round) {
        DiscoveryStep step;
        ScreenInput in;
        in.mask = mask;
        in.residual_nm.resize(s.size());
        for (std::size_t k = 0; k < s.size(); ++k) in.residual_nm[k] = s.residual_torque_nm[k] - model_sim.residual_torque_nm[k];
        for (const auto& name : health_names) in.base_columns.push_back(sensitivity(run, p, model_sim, name));
        for (const auto& a : accepted) {
            in.base_columns.push_back(signature(s, a));
            in.exclude.push_back(a.kind);
        }
        step.screen = screen_effects(s, in);
        const auto& ranking = step.screen.ranking;
        if (ranking.empty() || !ranking.front().accepted) {
            rep.steps.push_back(std::move(step));
            break;
        }
        const CandidateEvidence& win = ranking.front();
        sim::EmaParams start = p;
        start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
        for (const auto& [name, value] : sim_effects(win.shape, win.amplitude, p.j_kgm2)) {
            if (name == "ripple_periods") start.effects.set(name, value);  // scanned, not fitted
            else set_parameter(start, name, value);
        }
        std::vector<std::string> names = health_names;
        for (const auto& n : fitted_sim_effects(win.shape.kind)) names.push_back(n);
        // Ripple changes sign within a window of samples: it is fitted per sample.
        const FitResult fit = fit_by_resimulation(run, s, start, names, mask, fsj_base_nm,
                                                  win.shape.kind == EffectKind::Ripple ? 1 : kFitWindowSamples, &p);
        step.fitted = fit.values;
        step.simulations = fit.simulations;
        // The fit must confirm the screening with the same criterion on the re-simulated cost (the
        // model without the effect against the fitted model): delta_BIC > kMinDeltaBic and a peak
        // torque of at least kMinEffectPeakNm. Otherwise the effect is not added.
        const FittedValue& amp = fit.values[health_names.size()];
        const double rows = static_cast<double>(fit.rows);
        const double grid = static_cast<double>(std::max<std::size_t>(1, shape_grid(win.shape.kind, s).size()));
        const double fit_bic = rows * std::log(fit.cost_reference / fit.cost_end) -
                               (1.0 + scanned_parameters(win.shape.kind)) * std::log(rows) - 2.0 * std::log(grid);
        EffectShape fitted_shape = win.shape;
        if (fitted_shape.kind == EffectKind::Stribeck) fitted_shape.shape1 = fit.params.effects.stribeck_speed_rad_s;
        if (fitted_shape.kind == EffectKind::Spall) {
            fitted_shape.shape1 = fit.params.effects.spall_center_deg;
            fitted_shape.shape2 = fit.params.effects.spall_width_deg;
        }
        const double a = signature_amplitude(fitted_shape.kind, amp.value, p.j_kgm2);
        double peak = 0;
        {
            const auto x = signature(s, fitted_shape);
            for (std::size_t k = 0; k < x.size(); ++k) {
                if (mask[k]) peak = std::max(peak, std::abs(x[k]));
            }
        }
        step.fit_delta_bic = fit_bic;
        if (!(fit_bic > kMinDeltaBic) || !(std::abs(a) * peak >= kMinEffectPeakNm)) {
            step.rejected_by_fit = effect_name(win.shape.kind) + ": the re-simulation fit gives " + amp.name + " = " +
                                   std::to_string(amp.value) + " +/- " + std::to_string(amp.std_error) +
                                   ", delta BIC " + std::to_string(fit_bic) + ", peak torque " +
                                   std::to_string(std::abs(a) * peak) + " N m; not confirmed";
            rep.notes.push_back(step.rejected_by_fit);
            rep.steps.push_back(std::move(step));
            break;
        }
        step.added = win.shape;
        p = fit.params;
        // The accepted shape with the fitted continuous shape parameters, for the next screening.
        EffectShape shape = win.shape;
        if (shape.kind == EffectKind::Stribeck) shape.shape1 = p.effects.stribeck_speed_rad_s;
        if (shape.kind == EffectKind::Spall) {
            shape.shape1 = p.effects.spall_center_deg;
            shape.shape2 = p.effects.spall_width_deg;
        }
        accepted.push_back(shape);
        for (const auto& f : fit.values) {
            if (f.name == "fdj_nm") {
                auto* h = find_health(health, kParamFdj);
                h->value = f.value;
                h->std_error = f.std_error;
                h->source = "refit";
            } else if (f.name == "eta_o") {
                auto* h = find_health(health, kParamEtaO);
                h->value = f.value;
                h->std_error = f.std_error;
                h->source = "refit";
                // eq. (4): se of eta_A from the slope d eta_A / d eta_O.
                constexpr double kSlopeStep = 1e-6;
                const double slope = (sim::eta_a_from_eta_o(p.eta_o + kSlopeStep, p.tau) -
                                      sim::eta_a_from_eta_o(p.eta_o - kSlopeStep, p.tau)) / (2 * kSlopeStep);
                auto* eta_a_value = find_health(health, kParamEtaA);
                eta_a_value->value = p.eta_a;
                eta_a_value->std_error = std::abs(slope) * f.std_error;
            } else {
                rep.model.terms.push_back({effect_field(f.name), f.value, f.std_error});
            }
        }
        if (shape.kind == EffectKind::Ripple) {
            rep.model.terms.push_back({effect_field("ripple_periods"), shape.shape1, 0.0});
        }
        find_health(health, kParamFsj)->value = p.fsj_nm;
        model_sim = run_signals(resimulate(run, p));
        step.error_after = model_error(s, model_sim, mask);
        rep.model.error_after = step.error_after;
        rep.steps.push_back(std::move(step));
    }
    rep.model.params = p;
    return rep;
}

}  // namespace emadiag::discovery
