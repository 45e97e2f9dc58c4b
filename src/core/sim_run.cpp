#include "core/sim_run.hpp"

namespace emadiag {

Run make_run(const sim::SimConfig& config, const sim::SimResult& result) {
    Run run;
    const sim::EmaParams& p = config.params;
    run.constants = RunConstants{p.k_t_nm_per_a, p.j_kgm2, p.tau, sim::kSamplePeriodS};
    run.load_case = config.load_case;
    run.sequence = config.sequence;
    run.set_meta("source", "emadiag simulate");
    run.set_required_meta();
    run.set_meta("noise", sim::to_string(config.noise));
    run.set_meta("seed", std::to_string(config.seed));
    run.set_meta("true_FDJ_Nm", format_exact(p.fdj_nm));
    run.set_meta("true_FSJ_Nm", format_exact(p.fsj_nm));
    run.set_meta("true_eta_O", format_exact(p.eta_o));
    run.set_meta("true_eta_A", format_exact(p.eta_a));
    const sim::Effects defaults{};
    for (const auto& name : sim::Effects::names()) {
        const double v = p.effects.get(name);
        if (v != defaults.get(name)) run.set_meta("effect_" + name, format_exact(v));
    }
    for (std::size_t i = 0; i < p.terms.size(); ++i) run.set_meta("effect_term_" + std::to_string(i + 1), p.terms[i].text());
    run.samples = result.samples;
    return run;
}

}  // namespace emadiag
