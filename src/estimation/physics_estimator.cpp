#include "estimation/physics_estimator.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/breakaway.hpp"
#include "estimation/dataset.hpp"
#include "estimation/physics_friction_law.hpp"
#include "estimation/physics_wrls.hpp"
#include "estimation/run_checks.hpp"

#include <algorithm>
#include <optional>
#include <cmath>
#include <vector>
#include <string>

namespace emadiag {
namespace {

ParameterEstimate not_estimated(const char* name, const std::string& method, const std::string& note) {
    ParameterEstimate p;
    p.name = name;
    p.identifiable = false;
    p.method = method;
    p.note = note;
    return p;
}

ParameterEstimate estimated(const char* name, double value, double se, const std::string& method,
                            const std::string& note = {}) {
    ParameterEstimate p;
    p.name = name;
    p.value = value;
    p.std_error = se;
    p.method = method;
    p.note = note;
    return p;
}

/// Inverse-variance mean of values with standard errors (both directions of a BRK run).
std::pair<double, double> combine(const std::vector<std::pair<double, double>>& v) {
    double sw = 0, swx = 0;
    for (const auto& [x, se] : v) {
        const double w = se > 0 ? 1.0 / (se * se) : 0.0;
        sw += w;
        swx += w * x;
    }
    if (sw == 0) {  // all exact: plain mean, zero se
        double m = 0;
        for (const auto& [x, se] : v) m += x;
        return {m / static_cast<double>(v.size()), 0.0};
    }
    return {swx / sw, std::sqrt(1.0 / sw)};
}

HealthEstimate estimate_dyn(const Run& run) {
    HealthEstimate h;
    h.estimator = EstimatorMethod::Physics;
    const auto windows = slip_windows(run);
    const WrlsResult r = fit_friction_wrls(windows, run.constants.tau);
    h.parameters.push_back(estimated(kParamFdj, r.fdj_nm, r.fdj_se_nm, "physics-wrls",
                                     r.eta_identifiable ? "" : "eta fixed at the section-8 prior middle; its spread is in the uncertainty"));
    h.parameters.push_back(not_estimated(kParamFsj, "physics-wrls",
                                         "not identifiable: a " + sim::to_string(run.sequence) +
                                             " run never ramps the torque slowly from rest; use a BRK run"));
    if (r.eta_identifiable) {
        h.parameters.push_back(estimated(kParamEtaO, r.eta_o, r.eta_o_se, "physics-wrls"));
        h.parameters.push_back(estimated(kParamEtaA, r.eta_a, r.eta_a_se, "eq4"));
    } else {
        h.parameters.push_back(not_estimated(kParamEtaO, "physics-wrls", r.why_not_identifiable));
        h.parameters.push_back(not_estimated(kParamEtaA, "eq4", r.why_not_identifiable));
    }
    h.diagnostics = {{"slip_windows", static_cast<double>(r.windows)},
                     {"slip_samples", static_cast<double>(r.samples)},
                     {"condition_number", r.condition_number},
                     {"fr_spread_Nm", r.fr_spread_nm},
                     {"residual_scale_Nm", r.residual_scale_nm},
                     {"hac_floor_applied", r.hac_fallback ? 1.0 : 0.0},
                     {"fdj_recon_se_Nm", r.fdj_recon_se_nm},
                     {"eta_o_recon_se", r.eta_o_recon_se},
                     {"recon_weighted_windows", static_cast<double>(r.recon_weighted_windows)}};
    return h;
}

/// Posterior weight of a stick-slip start above which a noisy BRK event says FSJ is only bounded.
constexpr double kStickSlipLikely = 0.5;

HealthEstimate estimate_brk(const Run& run) {
    HealthEstimate h;
    h.estimator = EstimatorMethod::Physics;
    const BreakawayAnalysis a = analyse_breakaways(run);
    if (a.events.empty()) {
        std::string why;
        for (const auto& p : a.problems) why += (why.empty() ? "" : "; ") + p;
        throw EmadiagError("BRK run: no breakaway event found (" + why + ")");
    }
    const auto prior = load_coefficient_prior(run.constants.tau);
    // Each event measures S_d = FSJ + c(d)|F_R| and D_d = FDJ + c(d)|F_R|; c at the prior middle,
    // and its uniform spread (the eta confound) goes into the se.
    double fr_sum = 0;
    std::vector<double> shift;  // -c(d)|F_R| per event
    for (const auto& ev : a.events) {
        const double fr = ev.load_torque_nm;
        shift.push_back(-(fr * ev.direction > 0 ? prior.c_opp_mid : prior.c_aid_mid) * std::abs(fr));
        fr_sum += std::abs(fr);
    }
    const double confound_nm = prior.c_half_width * fr_sum / static_cast<double>(a.events.size());
    // Clean data: inverse-variance mean of the events. Noisy data: both directions see the same
    // friction, so its posterior is the product of the events' posteriors (shifted by -c|F_R|)
    // with the section-8 band as a soft prior. Those densities are skewed (one-sided near a
    // zero-acceleration start, with a uniform stick-slip segment), so the product carries more
    // than an inverse-variance mean of two summaries.
    auto combine_events = [&](const char* param, auto value_of, auto posterior_of) -> std::optional<std::pair<double, double>> {
        const bool noisy = std::all_of(a.events.begin(), a.events.end(), [&](const auto& ev) { return !posterior_of(ev).empty(); });
        if (noisy) {
            std::vector<std::vector<MixtureComponent>> mixes;
            for (std::size_t i = 0; i < a.events.size(); ++i) {
                auto mix = posterior_of(a.events[i]);
                for (auto& m : mix) m.mean += shift[i];
                mixes.push_back(std::move(mix));
            }
            const PosteriorSummary post = product_posterior(mixes, health_range(param), confound_nm);
            return std::pair{post.mean, post.se95};
        }
        std::vector<std::pair<double, double>> looks;
        for (std::size_t i = 0; i < a.events.size(); ++i) {
            if (const auto v = value_of(a.events[i])) looks.emplace_back(v->first + shift[i], v->second);
        }
        if (looks.empty()) return std::nullopt;
        return combine(looks);  // the confound is added below
    };
    const auto fsj_c = combine_events(
        kParamFsj, [](const BreakawayEvent& ev) { return std::optional{std::pair{ev.threshold_nm, ev.threshold_se_nm}}; },
        [](const BreakawayEvent& ev) -> const std::vector<MixtureComponent>& { return ev.threshold_posterior; });
    const auto fdj_c = combine_events(
        kParamFdj,
        [](const BreakawayEvent& ev) {
            return ev.dynamic_friction_nm ? std::optional{std::pair{*ev.dynamic_friction_nm, ev.dynamic_friction_se_nm}}
                                          : std::nullopt;
        },
        [](const BreakawayEvent& ev) -> const std::vector<MixtureComponent>& { return ev.dynamic_posterior; });
    auto fsj = fsj_c, fdj = fdj_c;
    if (a.clean) {
        // Clean data measure S = FSJ + c|F_R| and D = FDJ + c|F_R| almost exactly (c the same both
        // ways by eq. (4), to a few 1e-6 N m), so c is confined to the values that keep FSJ, FDJ and
        // eta inside the section-8 band; at the band's edges that narrows the confound. A unit
        // outside the band (no such c) keeps the whole prior range of c.
        const double fr = fr_sum / static_cast<double>(a.events.size());
        const double c_mid = 0.5 * (prior.c_opp_mid + prior.c_aid_mid);
        double c_lo = c_mid - prior.c_half_width, c_hi = c_mid + prior.c_half_width;
        if (fr > 0) {
            auto confine = [&](const std::optional<std::pair<double, double>>& v, const char* param) {
                if (!v) return;
                const HealthRange band = health_range(param);
                const double measured = v->first + c_mid * fr;
                c_lo = std::max(c_lo, (measured - band.hi) / fr);
                c_hi = std::min(c_hi, (measured - band.lo) / fr);
            };
            const double lo0 = c_lo, hi0 = c_hi;
            confine(fsj_c, kParamFsj);
            confine(fdj_c, kParamFdj);
            if (c_lo > c_hi) { c_lo = lo0; c_hi = hi0; }
        }
        const double c_hat = 0.5 * (c_lo + c_hi), half_nm = 0.5 * (c_hi - c_lo) * fr;
        auto apply = [&](std::optional<std::pair<double, double>>& v) {
            if (v) *v = {v->first - (c_hat - c_mid) * fr, uniform_plus_gaussian_se(half_nm, v->second)};
        };
        apply(fsj);
        apply(fdj);
    }
    const std::string dirs = a.events.size() == 2 ? "both directions" : "one direction only";
    h.parameters.push_back(fdj ? estimated(kParamFdj, fdj->first, fdj->second,
                                           a.clean ? "physics-breakaway-slip" : "physics-breakaway-trajectory", dirs)
                               : not_estimated(kParamFdj, "physics-breakaway",
                                               "not identifiable: too few fully slipping samples after breakaway"));
    // Noisy data whose every event most likely started by stick-slip: the data bound FSJ to about
    // [FDJ, FDJ + k_t u] rather than measure it (docs/fsj-identifiability.md); say so.
    const bool hidden = !a.clean && std::all_of(a.events.begin(), a.events.end(), [](const BreakawayEvent& ev) {
        return ev.stick_slip_weight >= kStickSlipLikely;
    });
    h.parameters.push_back(estimated(kParamFsj, fsj->first, fsj->second, "physics-breakaway",
                                     dirs + (a.clean ? ", exact speed" : ", trajectory fit") +
                                         (hidden ? "; breakaway likely hidden by stick-slip on the current chatter "
                                                   "(FSJ - FDJ below about 0.02 N m): FSJ is bounded, not measured"
                                                 : "")));
    const std::string eta_note = "not identifiable: a BRK run slips too briefly to separate eta from FDJ/FSJ";
    h.parameters.push_back(not_estimated(kParamEtaO, "physics-breakaway", eta_note));
    h.parameters.push_back(not_estimated(kParamEtaA, "eq4", eta_note));
    h.diagnostics.emplace_back("breakaway_events", static_cast<double>(a.events.size()));
    h.diagnostics.emplace_back("clean_data", a.clean ? 1.0 : 0.0);
    for (const auto& ev : a.events) {
        const std::string p = ev.direction > 0 ? "up_" : "down_";
        h.diagnostics.emplace_back(p + "t_breakaway_s", ev.t_breakaway_s);
        h.diagnostics.emplace_back(p + "t_breakaway_se_s", ev.t_breakaway_se_s);
        h.diagnostics.emplace_back(p + "ramp_current_A", ev.ramp_current_a);
        h.diagnostics.emplace_back(p + "threshold_Nm", ev.threshold_nm);
        h.diagnostics.emplace_back(p + "load_torque_Nm", ev.load_torque_nm);
        h.diagnostics.emplace_back(p + "slip_accel_torque_Nm", ev.slip_accel_torque_nm);
        h.diagnostics.emplace_back(p + "move_end_s", ev.t_move_end_s);
        h.diagnostics.emplace_back(p + "stick_slip_weight", ev.stick_slip_weight);
    }
    return h;
}

}  // namespace

HealthEstimate estimate_physics(const CheckedRun& checked) {
    const Run& run = checked.run();
    if (run.sequence == sim::Sequence::Brk) return estimate_brk(run);
    return estimate_dyn(run);
}

}  // namespace emadiag
