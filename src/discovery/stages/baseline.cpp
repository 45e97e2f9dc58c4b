// Stage 1, baseline: the datasheet model with the health the run identifies (estimate_physics),
// re-simulated; the samples compared, the run's noise floor and the error before.
#include "discovery/stages/stages.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/physics_estimator.hpp"

#include <algorithm>
#include <string>

namespace emadiag::discovery::pipeline {
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

/// An estimate outside the simulator's range (a large unmodelled effect can push it there) starts
/// the model at the nearest valid value; the note says so.
double start_value(DiscoveryReport& rep, HealthValue& h, double lo, double hi) {
    if (h.value >= lo && h.value <= hi) return h.value;
    const double v = std::clamp(h.value, lo, hi);
    rep.notes.push_back(h.name + ": estimate " + std::to_string(h.value) + " is outside the simulator's range [" +
                        std::to_string(lo) + ", " + std::to_string(hi) + "]; the model starts from " +
                        std::to_string(v));
    h.value = v;
    return v;
}

}  // namespace

void baseline_stage(Context& ctx) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    DiscoveryReport& rep = ctx.rep;
    rep.load_case = run.load_case;
    rep.sequence = run.sequence;
    rep.samples = run.samples.size();
    rep.total_samples = rep.samples;
    rep.analysed_end_s = run.samples.empty() ? 0.0 : run.samples.back().t_s;

    const HealthEstimate est = estimate_physics(ctx.checked);
    sim::EmaParams& p = ctx.params;
    p = resim_config(run, sim::EmaParams::datasheet()).params;
    auto& health = rep.model.health;
    health.push_back(health_from(est, kParamFdj, p.fdj_nm));
    health.push_back(health_from(est, kParamFsj, p.fsj_nm));
    health.push_back(health_from(est, kParamEtaO, p.eta_o));
    HealthValue eta_a = health_from(est, kParamEtaA, p.eta_a);
    p.fdj_nm = start_value(rep, health[0], kMinHealthFdjNm, kMaxHealthFdjNm);
    p.fsj_nm = start_value(rep, health[1], kMinHealthFdjNm, kMaxHealthFdjNm);
    const bool eta_free = health[2].source == "estimated";
    ctx.eta_free = eta_free;
    p.eta_o = start_value(rep, health[2], kMinHealthEtaO, kMaxHealthEtaO);
    p.eta_a = sim::eta_a_from_eta_o(p.eta_o, p.tau);  // eq. (4), as the simulator uses it
    eta_a.value = p.eta_a;
    eta_a.source = eta_free ? "eq4" : "datasheet";
    health.push_back(eta_a);
    ctx.fsj_base_nm = p.fsj_nm;  // estimated or datasheet; the model keeps FSJ >= FDJ
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
    ctx.mask = comparison_mask(s, base_sim);
    const std::vector<char>& mask = ctx.mask;
    const auto compared = static_cast<std::size_t>(std::count(mask.begin(), mask.end(), char{1}));
    if (compared < kMinScreenSamples) {
        throw EmadiagError("discovery: the " + sim::to_string(run.sequence) + " run has " + std::to_string(compared) +
                           " comparison samples (slipping in the run and the model); at least " +
                           std::to_string(kMinScreenSamples) +
                           " are needed (a BRK run barely moves: use a DYN or sweep run; given with a DYN run of the same actuator, "
                           "a BRK run's breakaway thresholds are compared with the DYN run's model)");
    }
    rep.model.error_before = model_error(s, base_sim, mask);
    rep.model.error_after = rep.model.error_before;

    ctx.health_parameters = {FitParameter::fdj()};
    if (eta_free) ctx.health_parameters.push_back(FitParameter::eta_o());
    ctx.library = ctx.options.open_world ? generated_library(s) : std::vector<TermFamily>{};
    ctx.floor = noise_floor(s, base_sim, mask);
    rep.floor = ctx.floor;
    ctx.model_sim = base_sim;
    ctx.traj_now = trajectory_error(s, base_sim, ctx.floor);
    rep.trajectory_before = ctx.traj_now;
}

}  // namespace emadiag::discovery::pipeline
