// Stage 6, ripple: a motor torque ripple by the trajectory (cogging at rest and at reversals that the
// torque screening cannot confirm), screened like the low-speed friction, confirmed by the torque
// residual at the same period and fitted by re-simulation on the trajectory.
#include "discovery/stages/stages.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/fits/linearisation.hpp"
#include "discovery/screening/screen_windows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace emadiag::discovery::pipeline {
namespace {

/// Ripple by the trajectory: the amplitude (N m) of the probe re-simulated at each scanned period, and
/// the iterations of its fit on the trajectory.
constexpr double kRippleProbeNm = 0.01;
constexpr int kRippleFitIterations = 6;
/// The torque screening's amplitude of the same ripple period, in its standard errors, that confirms
/// the trajectory's.
constexpr double kRippleTorqueMinZ = 1.96;

/// The ripple at the trajectory's best period (`shape`, amplitude `best_amp` from the linearised
/// screen `lin` over `grid_size` periods) fitted on the trajectory with the model's own parameters `model_parameters`, against those
/// parameters alone; added to the model (a step of its own) when it is confirmed. Returns the verdict.
std::string fit_ripple(Context& ctx, const TrajectoryLinearisation& lin, const std::vector<FitParameter>& model_parameters,
                       const EffectShape& shape, double best_amp, std::size_t grid_size) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const std::vector<char>& mask = ctx.mask;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const sim::EmaParams& p = ctx.params;
    const RunSignals& model_sim = ctx.model_sim;
    const TrajectoryError& traj_now = ctx.traj_now;
    std::vector<EffectShape>& accepted = ctx.accepted;
    DiscoveryReport& rep = ctx.rep;
    const double dn = static_cast<double>(lin.e.size());
    const double ln_g = std::log(static_cast<double>(std::max<std::size_t>(1, grid_size)));
    std::string verdict;
    sim::EmaParams start = p;
    start.effects.ripple_amplitude_nm = std::max(best_amp, kMinEffectPeakNm);
    start.effects.ripple_periods_per_rev = shape.shape1;
    start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
    std::vector<FitParameter> names = model_parameters;
    names.push_back(FitParameter::effect(FittedEffect::RippleAmplitude));
    DiscoveryStep step;
    step.trajectory_before = traj_now.cost;
    try {
        const FitResult fit = fit_by_resimulation(run, s, start, names, mask, fsj_base_nm, kFitWindowSamples, nullptr,
                                                  kRippleFitIterations, &floor);
        const double cost = trajectory_error(s, fit.signals, floor).cost;
        const double amp = fit.params.effects.ripple_amplitude_nm;
        // Against the model's own parameters alone, fitted on the trajectory the same way (not
        // the linearised screen: the nonlinear refit alone removes part of the excess, which a
        // ripple would otherwise be credited with; a torque bump over the speed went 86.5 ->
        // 2.15 with a 1-per-rev "ripple" where the screen's own-parameters cost was 14.6): the
        // criterion with the amplitude and the scanned period, and the ripple must explain
        // kLowSpeedMinExplained of the excess that refit leaves.
        const TrajectoryRefit base = refit_on_trajectory(ctx, p);
        const double base_cost = base.cost;
        const double fit_bic = dn * std::log(base_cost / cost) - 2.0 * std::log(dn) - 2.0 * ln_g;
        // ... and must not contradict the torque residual: below a few revolutions per sample a
        // ripple shows in T_R, so the chi-square of the torque window means may rise by at most
        // kLowSpeedMaxTorqueChi2Rise over that refit (the same speed bump's 1-per-rev "ripple"
        // raised it by far more).
        const double rise = torque_window_chi2_rise(s, mask, floor, base.fit.signals, fit.signals);
        const bool kept = fit_bic > kMinDeltaBic && amp >= kMinEffectPeakNm && cost < traj_now.cost &&
                          cost - 1.0 < (1.0 - kLowSpeedMinExplained) * (base_cost - 1.0) && rise <= kLowSpeedMaxTorqueChi2Rise;
        verdict = "fitted on the trajectory: " + fmt3(amp) + " N m at " + fmt3(shape.shape1) + " per rev, cost " +
                  fmt3(traj_now.cost) + " -> " + fmt3(cost) + " (the model's own parameters refitted alone: " + fmt3(base_cost) +
                  "), delta BIC " + fmt3(fit_bic) + ", torque window chi-square " + (rise >= 0 ? "+" : "") + fmt3(rise) +
                  (kept ? "; added" : "; not confirmed");
        if (kept) {
            step.added = EffectShape{EffectKind::Ripple, shape.shape1, 0};
            step.name_key = effect_name(EffectKind::Ripple);
            step.name_text = library_effect_text(EffectKind::Ripple) + " (by the trajectory)";
            step.fitted = fit.values;
            step.fit_delta_bic = fit_bic;
            step.simulations = lin.simulations + fit.simulations;
            adopt_trajectory_fit(ctx, fit);
            accepted.push_back(*step.added);
            rep.model.terms.push_back({effect_field("ripple_periods"), shape.shape1, 0.0});
            step.trajectory_after = traj_now.cost;
            step.error_after = model_error(s, model_sim, mask);
            rep.model.error_after = step.error_after;
            rep.steps.push_back(std::move(step));
        }
    } catch (const std::exception& e) {
        verdict = std::string("the fit failed: ") + e.what();
    }
    return verdict;
}

/// The trajectory linearised over the scanned ripple periods, the torque residual's evidence at the
/// best, and the verdict (fit_ripple when both agree).
std::string ripple_verdict(Context& ctx) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const std::vector<char>& mask = ctx.mask;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const sim::EmaParams& p = ctx.params;
    const RunSignals& model_sim = ctx.model_sim;
    const std::vector<EffectShape>& accepted = ctx.accepted;
    const std::vector<FitParameter>& health_parameters = ctx.health_parameters;
    const std::vector<std::vector<double>>& term_columns = ctx.term_columns;
    const std::vector<FitParameter> model_parameters = own_parameters(ctx, p);
    const std::vector<EffectShape> grid = shape_grid(EffectKind::Ripple, s);
    const TrajectoryLinearisation lin = linearise_over_shapes(run, s, floor, fsj_base_nm, model_parameters, p, model_sim, grid,
                                                              kRippleProbeNm, [](sim::EmaParams& q, const EffectShape& shape) {
                                                                  q.effects.ripple_amplitude_nm = kRippleProbeNm;
                                                                  q.effects.ripple_periods_per_rev = shape.shape1;
                                                              });
    const double dn = static_cast<double>(lin.e.size());
    const double ln_g = std::log(static_cast<double>(std::max<std::size_t>(1, grid.size())));
    const double z = (lin.rss0 - dn) / std::sqrt(2.0 * dn);
    std::size_t best = grid.size();
    double best_bic = -std::numeric_limits<double>::infinity(), best_amp = 0, best_rss = lin.rss0;
    for (std::size_t i = 0; i < grid.size(); ++i) {
        const Eigen::VectorXd x = lin.projected(i);
        const double sxx = x.squaredNorm();
        if (!(sxx > 0)) continue;
        const double sxy = x.dot(lin.e0);
        if (!(sxy > 0)) continue;  // the simulator's ripple has one phase: a positive amplitude
        const double rss1 = std::max(lin.rss0 - sxy * sxy / sxx, std::numeric_limits<double>::min());
        const double bic = dn * std::log(lin.rss0 / rss1) - 2.0 * std::log(dn) - 2.0 * ln_g;
        if (bic > best_bic) {
            best = i;
            best_bic = bic;
            best_amp = sxy / sxx;
            best_rss = rss1;
        }
    }
    const double share = lin.rss0 > dn ? (lin.rss0 - best_rss) / (lin.rss0 - dn) : 0.0;
    // The torque residual's own evidence: at the trajectory's period (the screening's least squares
    // on the current model's residual, with its base), a positive amplitude at least
    // kRippleTorqueMinZ standard errors from zero. Two independent lines of evidence must agree:
    // the trajectory alone let a
    // 1-per-rev ripple mimic a torque bump over the speed (cost 86.5 -> 2.15), where the torque
    // screening's best ripple was 12 per rev at 1.4 se; a real 6-per-rev ripple of 0.030 N m
    // showed 6 per rev at 3.9 se there, below the screening's criterion only.
    // The torque residual is asked at the trajectory's period, not for its own best period: at
    // speed a ripple cancels within each sample and the screening's scan can alias it (fresh seed
    // 179: a 6-per-rev ripple of 0.045 N m, the trajectory 100 % at 6 per rev, the screening's
    // best 9 per rev at 0.0458 +/- 0.0067 N m).
    std::optional<CandidateEvidence> torque_at;
    if (best < grid.size()) {
        ScreenInput rin;
        rin.mask = mask;
        rin.residual_nm.resize(s.size());
        for (std::size_t k = 0; k < s.size(); ++k) rin.residual_nm[k] = s.residual_torque_nm[k] - model_sim.residual_torque_nm[k];
        for (auto& col : sensitivities(run, p, model_sim, health_parameters)) rin.base_columns.push_back(std::move(col));
        for (const auto& a : accepted) rin.base_columns.push_back(signature(s, a));
        for (const auto& c : term_columns) rin.base_columns.push_back(c);
        torque_at = evidence_at(s, rin, grid[best]);
    }
    const CandidateEvidence* torque_ripple = torque_at ? &*torque_at : nullptr;
    std::string verdict;
    if (!(z > kStructureMinZ)) {
        verdict = "not needed: after the model's own parameters the trajectory is within its floor (z = " + fmt3(z) + ")";
    } else if (best == grid.size() || !(best_bic > kMinDeltaBic) || share < kLowSpeedScreenMinExplained) {
        verdict = best == grid.size() ? "no ripple period with a positive amplitude"
                                      : "no ripple in the trajectory (best: " + fmt3(grid[best].shape1) + " per rev, " + fmt3(best_amp) +
                                            " N m, delta BIC " + fmt3(best_bic) + ", " + fmt3(100.0 * share) + " % of the excess)";
    } else if (torque_ripple == nullptr || !(torque_ripple->amplitude > kRippleTorqueMinZ * torque_ripple->amplitude_se)) {
        verdict = "the trajectory's best is " + fmt3(grid[best].shape1) + " per rev (" + fmt3(100.0 * share) +
                  " % of the excess), but the torque residual does not agree (" +
                  (torque_ripple == nullptr ? std::string("its column at that period is inside the model's")
                                            : "at that period " + fmt3(torque_ripple->amplitude) + " +/- " +
                                                  fmt3(torque_ripple->amplitude_se) + " N m") +
                  "); left to the structure report";
    } else {
        verdict = fit_ripple(ctx, lin, model_parameters, grid[best], best_amp, grid.size());
    }
    return verdict;
}

}  // namespace

void ripple_stage(Context& ctx) {
    const sim::EmaParams& p = ctx.params;
    const std::vector<EffectShape>& accepted = ctx.accepted;
    const std::vector<EffectKind>& excluded = ctx.excluded;
    const TrajectoryError& traj_now = ctx.traj_now;
    DiscoveryReport& rep = ctx.rep;
    // A motor torque ripple by the trajectory: at speed the ripple cancels within each sample (the torque
    // screening sees its period mean, which vanishes), so a ripple the torque rounds cannot confirm shows
    // only where the motor turns slowly, at rest and at reversals, as cogging that holds the shaft off
    // its command. The trajectory sees that (seed 113: a ripple of 0.030 N m left the trajectory at 110
    // x its floor, the angle residual growing through the run, with the torque screening's delta BIC
    // -0.1). Screened like the low-speed friction, linearised over the scanned periods, and fitted by
    // re-simulation on the trajectory with the model's own parameters when a period passes.
    // Not on a model with a periodic term: what its fit leaves is periodic too, and a ripple column
    // mimics it (seed 113's periodic surface torque gained a spurious ripple); the torque rounds still
    // screen a ripple there.
    const bool periodic_in = std::any_of(p.terms.begin(), p.terms.end(), [](const sim::Term& t) { return period_factor(t) != nullptr; });
    if (periodic_in) rep.notes.push_back("ripple by the trajectory: not screened, the model has a periodic term");
    if (!periodic_in &&
        std::none_of(accepted.begin(), accepted.end(), [](const EffectShape& a) { return a.kind == EffectKind::Ripple; }) &&
        std::find(excluded.begin(), excluded.end(), EffectKind::Ripple) == excluded.end() && traj_now.cost > 1.0) {
        rep.notes.push_back("ripple by the trajectory: " + ripple_verdict(ctx));
    }
}

}  // namespace emadiag::discovery::pipeline
