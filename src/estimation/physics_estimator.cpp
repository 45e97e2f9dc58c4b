#include "estimation/physics_estimator.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/breakaway.hpp"
#include "estimation/dataset.hpp"
#include "estimation/physics_friction_law.hpp"
#include "estimation/physics_wrls.hpp"
#include "estimation/run_checks.hpp"

#include <algorithm>
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
    h.estimator = "physics";
    const auto windows = slip_windows(run);
    const WrlsResult r = fit_friction_wrls(windows, run.constants.tau);
    h.parameters.push_back(estimated(kParamFdj, r.fdj_nm, r.fdj_se_nm, "physics-wrls",
                                     r.eta_identifiable ? "" : "eta fixed at the section-8 prior middle; its spread is in the uncertainty"));
    h.parameters.push_back(not_estimated(kParamFsj, "physics-wrls",
                                         "not identifiable: a " + run.sequence +
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
                     {"hac_floor_applied", r.hac_fallback ? 1.0 : 0.0}};
    return h;
}

HealthEstimate estimate_brk(const Run& run) {
    HealthEstimate h;
    h.estimator = "physics";
    const BreakawayAnalysis a = analyse_breakaways(run);
    if (a.events.empty()) {
        std::string why;
        for (const auto& p : a.problems) why += (why.empty() ? "" : "; ") + p;
        throw EmadiagError("BRK run: no breakaway event found (" + why + ")");
    }
    const auto prior = load_coefficient_prior(run.constants.tau);
    std::vector<std::pair<double, double>> fsj, fdj;
    double fr_fsj = 0, fr_fdj = 0;
    for (const auto& ev : a.events) {
        const double fr = ev.load_torque_nm;
        const double c = fr * ev.direction > 0 ? prior.c_opp_mid : prior.c_aid_mid;
        fsj.emplace_back(ev.threshold_nm - c * std::abs(fr), ev.threshold_se_nm);  // section 5
        fr_fsj += std::abs(fr);
        if (ev.dynamic_friction_nm) {
            fdj.emplace_back(*ev.dynamic_friction_nm - c * std::abs(fr), ev.dynamic_friction_se_nm);  // eq. (5)
            fr_fdj += std::abs(fr);
        }
    }
    auto [fsj_v, fsj_se] = combine(fsj);
    // Noisy data: both directions see the same FSJ, so its posterior is the product of the two
    // events' posteriors (each shifted by its c|F_R| at the prior middle) and the section-8 band
    // as a soft prior. Their densities are skewed (one-sided near a zero-acceleration start, with
    // a uniform stick-slip segment), so the product carries more than an inverse-variance mean of
    // two summaries.
    if (std::all_of(a.events.begin(), a.events.end(), [](const auto& ev) { return !ev.threshold_posterior.empty(); })) {
        std::vector<std::vector<MixtureComponent>> shifted;
        for (std::size_t i = 0; i < a.events.size(); ++i) {
            auto mix = a.events[i].threshold_posterior;
            const double shift = fsj[i].first - a.events[i].threshold_nm;  // -c |F_R|
            for (auto& m : mix) m.mean += shift;
            shifted.push_back(std::move(mix));
        }
        const PosteriorSummary post = product_posterior(shifted, health_range(kParamFsj));
        fsj_v = post.mean;
        fsj_se = post.se95;
    }
    fsj_se = uniform_plus_gaussian_se(prior.c_half_width * fr_fsj / static_cast<double>(fsj.size()), fsj_se);
    const std::string dirs = a.events.size() == 2 ? "both directions" : "one direction only";
    h.parameters.push_back(fdj.empty()
                               ? not_estimated(kParamFdj, "physics-breakaway",
                                               "not identifiable: too few fully slipping samples after breakaway")
                               : [&] {
                                     auto [v, se] = combine(fdj);
                                     se = uniform_plus_gaussian_se(
                                         prior.c_half_width * fr_fdj / static_cast<double>(fdj.size()), se);
                                     return estimated(kParamFdj, v, se, "physics-breakaway-slip",
                                                      std::to_string(fdj.size()) + " slip(s)");
                                 }());
    h.parameters.push_back(estimated(kParamFsj, fsj_v, fsj_se, "physics-breakaway",
                                     dirs + (a.clean ? ", exact speed" : ", trajectory fit")));
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

HealthEstimate estimate_physics(const Run& run) {
    check_run(run);
    if (run.sequence == "brk") return estimate_brk(run);
    return estimate_dyn(run);
}

}  // namespace emadiag
