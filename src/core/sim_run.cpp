#include "core/sim_run.hpp"

#include <cstdio>

namespace emadiag {
namespace {
std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}
}  // namespace

Run make_run(const sim::SimConfig& config, const sim::SimResult& result) {
    Run run;
    const sim::EmaParams& p = config.params;
    run.constants = RunConstants{p.k_t_nm_per_a, p.j_kgm2, p.tau, sim::kSamplePeriodS};
    run.load_case = sim::to_string(config.load_case);
    run.sequence = sim::to_string(config.sequence);
    run.set_meta("source", "emadiag simulate");
    run.set_meta("k_t_Nm_per_A", num(p.k_t_nm_per_a));
    run.set_meta("J_kgm2", num(p.j_kgm2));
    run.set_meta("tau", num(p.tau));
    run.set_meta("sample_period_s", num(sim::kSamplePeriodS));
    run.set_meta("case", run.load_case);
    run.set_meta("sequence", run.sequence);
    run.set_meta("noise", sim::to_string(config.noise));
    run.set_meta("seed", std::to_string(config.seed));
    run.set_meta("true_FDJ_Nm", num(p.fdj_nm));
    run.set_meta("true_FSJ_Nm", num(p.fsj_nm));
    run.set_meta("true_eta_O", num(p.eta_o));
    run.set_meta("true_eta_A", num(p.eta_a));
    const sim::Effects defaults{};
    for (const auto& name : sim::Effects::names()) {
        const double v = p.effects.get(name);
        if (v != defaults.get(name)) run.set_meta("effect_" + name, num(v));
    }
    run.samples.reserve(result.samples.size());
    for (const auto& s : result.samples) {
        run.samples.push_back(RunSample{s.t_s, s.current_a, s.speed_rad_s, s.theta_m_rad, s.hinge_moment_nm, s.command_deg});
    }
    return run;
}

}  // namespace emadiag
