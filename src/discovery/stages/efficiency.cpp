// Stage 3, efficiency or friction (docs/discovery.md "Efficiency or friction"): an eta_O off the
// datasheet against a friction the model lacks that follows the load on this run.
#include "discovery/stages/stages.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/screening/screen_windows.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace emadiag::discovery::pipeline {
namespace {

/// eta_O this many standard errors off the datasheet value is a departure an unmodelled friction
/// could explain (EfficiencyAlternative).
constexpr double kEfficiencyMinZ = 5.0;
/// Seed of the efficiency stage's screening (its cross-validation and resampling).
constexpr std::uint64_t kEfficiencyScreenSeed = 7;
}  // namespace

void efficiency_stage(Context& ctx) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const DiscoveryOptions& options = ctx.options;
    const std::vector<char>& mask = ctx.mask;
    const NoiseFloor& floor = ctx.floor;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const bool eta_free = ctx.eta_free;
    const std::vector<EffectShape>& accepted = ctx.accepted;
    const std::vector<std::vector<double>>& term_columns = ctx.term_columns;
    const std::vector<TermFamily>& library = ctx.library;
    const TrajectoryError& traj_now = ctx.traj_now;
    sim::EmaParams& p = ctx.params;
    DiscoveryReport& rep = ctx.rep;
    std::vector<HealthValue>& health = ctx.health();
    std::vector<FitParameter>& health_parameters = ctx.health_parameters;
    // Efficiency or friction: an eta_O off the datasheet may be a friction the model lacks that follows
    // the load on this run. Settled before the sensor stage: the angle residual such a friction leaves
    // (about a drift) is not a sensor's.
    auto& ea = rep.efficiency;
    const double eta_ds = sim::EmaParams::datasheet().eta_o;
    const HealthValue* eta_h = find_health(health, kParamEtaO);
    if (!options.open_world) {
        ea.skipped = "closed world";
    } else if (!eta_free) {
        ea.skipped = "eta_O is not estimated on this run";
    } else if (!(std::abs(p.eta_o - eta_ds) > kEfficiencyMinZ * eta_h->std_error)) {
        ea.skipped = "eta_O is within " + fmt3(kEfficiencyMinZ) + " standard errors of the datasheet value";
    } else {
        ea.ran = true;
        ea.eta_o = p.eta_o;
        ea.eta_o_se = eta_h->std_error;
        ea.eta_o_datasheet = eta_ds;
        ea.cost_model = traj_now.cost;
        sim::EmaParams p_ds = p;
        p_ds.eta_o = eta_ds;
        p_ds.eta_a = sim::eta_a_from_eta_o(eta_ds, p_ds.tau);
        const RunSignals ds_sim = run_signals(resimulate(run, p_ds));
        ScreenInput in;
        in.mask = mask;
        in.residual_nm.resize(s.size());
        for (std::size_t k = 0; k < s.size(); ++k) in.residual_nm[k] = s.residual_torque_nm[k] - ds_sim.residual_torque_nm[k];
        for (auto& col : sensitivities(run, p_ds, ds_sim, {FitParameter::fdj()})) in.base_columns.push_back(std::move(col));
        for (const auto& a : accepted) in.base_columns.push_back(signature(s, a));
        for (const auto& c : term_columns) in.base_columns.push_back(c);
        // Friction-like families only: what eta_O stands for opposes the motion.
        std::vector<TermFamily> friction;
        for (const auto& f : library) {
            if (f.opposes_motion) friction.push_back(f);
        }
        const GenericScreen screen = friction.empty() ? GenericScreen{} : screen_generated(s, in, friction, kEfficiencyScreenSeed);
        const GenericEvidence* best = !screen.ranking.empty() && screen.ranking.front().accepted ? &screen.ranking.front() : nullptr;
        if (best == nullptr) {
            ea.verdict = "eta_O " + fmt3(p.eta_o) + " is the explanation: with eta_O at the datasheet value " + fmt3(eta_ds) +
                         " no friction-like term explains the torque residual" +
                         (screen.ranking.empty() ? std::string() : " (best: " + screen.ranking.front().family + ", " +
                                                                       screen.ranking.front().reason + ")");
        } else {
            sim::EmaParams start = p_ds;
            start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
            std::vector<FitParameter> names = {FitParameter::fdj()};
            for (const auto& t : refine_period(s, in, *best, kEfficiencyScreenSeed)) {
                names.push_back(FitParameter::term(start.terms.size()));
                start.terms.push_back(t);
            }
            try {
                const FitResult fit = fit_by_resimulation(run, s, start, names, mask, fsj_base_nm, kFitWindowSamples, &p_ds,
                                                          kHypothesisFitIterations);
                const sim::Term& t = fit.params.terms.back();
                const PhysicsName n = physics_name(t);
                ea.key = n.key;
                ea.text = n.text;
                for (auto it = fit.params.terms.end() - static_cast<std::ptrdiff_t>(names.size() - 1); it != fit.params.terms.end(); ++it) {
                    ea.change += (ea.change.empty() ? "" : ", ") + it->text();
                    ea.terms.push_back(*it);
                }
                ea.cost_alternative = trajectory_error(s, fit.signals, floor).cost;
                const double lo = std::min(ea.cost_model, ea.cost_alternative), hi = std::max(ea.cost_model, ea.cost_alternative);
                ea.equivalent = not_told_apart(lo, hi, kHypothesisRatio);
                ea.favoured = !ea.equivalent && ea.cost_alternative < ea.cost_model;
                if (ea.favoured) {
                    // The model takes the friction with eta_O at the datasheet value.
                    adopt_trajectory_fit(ctx, fit);
                    HealthValue* eta = find_health(health, kParamEtaO);
                    eta->value = eta_ds;
                    eta->std_error = 0;
                    eta->source = "datasheet";
                    eta->note = "the trajectory favours " + n.text + " over an efficiency change";
                    HealthValue* eta_a_value = find_health(health, kParamEtaA);
                    eta_a_value->value = p.eta_a;
                    eta_a_value->std_error = 0;
                    eta_a_value->source = "datasheet";
                    for (std::size_t i = p.terms.size() - (names.size() - 1); i < p.terms.size(); ++i) {
                        const PhysicsName tn = physics_name(p.terms[i]);
                        rep.model.term_keys.push_back(tn.key);
                        rep.model.term_texts.push_back(tn.text);
                    }
                    // The stages after this one keep eta_O at the datasheet value.
                    std::erase(health_parameters, FitParameter::eta_o());
                }
                const std::string costs = "trajectory cost " + fmt3(ea.cost_model) + " with eta_O " + fmt3(ea.eta_o) + ", " +
                                          fmt3(ea.cost_alternative) + " with eta_O " + fmt3(eta_ds) + " and " + ea.change;
                ea.verdict = ea.equivalent ? "equivalent on this run: eta_O " + fmt3(ea.eta_o) + " (off the datasheet " +
                                                 fmt3(eta_ds) + ") or " + n.text + " at the datasheet eta_O (" + costs +
                                                 "); a run at another load (case A, a load rig) tells them apart"
                             : ea.favoured ? "the trajectory favours " + n.text + " at the datasheet eta_O over eta_O " +
                                                 fmt3(ea.eta_o) + " (" + costs + ")"
                                           : "eta_O " + fmt3(ea.eta_o) + " is the explanation: the trajectory rejects " + n.text +
                                                 " at the datasheet eta_O (" + costs + ")";
            } catch (const std::exception& e) {
                ea.verdict = "the alternative " + best->family + " could not be simulated: " + e.what();
            }
        }
    }
}

}  // namespace emadiag::discovery::pipeline
