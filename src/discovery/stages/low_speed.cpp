// Stage 5, low speed (docs/discovery.md "Low-speed friction by the trajectory"): a Stribeck friction
// the torque residual is too noisy to see, screened on the trajectory (linearised), estimated on the
// profile over w_s and confirmed by a fit on the trajectory; or the torque rounds' Stribeck friction
// estimated again on the trajectory.
#include "discovery/stages/stages.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/fits/linearisation.hpp"
#include "discovery/screening/screen_windows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace emadiag::discovery::pipeline {
namespace {

/// Low-speed friction stage (docs/discovery.md "Low-speed friction by the trajectory"). The Stribeck
/// column at each scanned speed is re-simulated at this amplitude (N m; the trajectory's response is
/// linear in it well beyond the amplitudes that matter).
constexpr double kLowSpeedProbeNm = 0.02;
/// Scanned speeds re-simulated at their own amplitude to choose the start of the fit (one batch), and
/// the refinement of the scan around the best of them (kLowSpeedFineSteps points per scan step, over
/// +/- three quarters of a step).
constexpr std::size_t kLowSpeedProfilePoints = 8;
constexpr int kLowSpeedFineSteps = 4;
/// Profile points within this many scan steps of the best enter the estimate of w_s and its error.
constexpr double kLowSpeedProfileSpan = 1.5;

struct LowSpeedResult {
    LowSpeedStage stage;
    FitResult fit;  ///< the fit with the Stribeck friction (when stage.added)
};

/// The linearised screen over the scanned speeds (st.ranking, best delta BIC first); false, with the
/// verdict, when no speed passes or the trajectory's excess over the floor is too small for the fits.
bool screen_stribeck(LowSpeedStage& st, const TrajectoryLinearisation& lin, const std::vector<EffectShape>& grid,
                     const std::vector<FitParameter>& model_parameters) {
    st.simulations += lin.simulations;
    const auto n_rows = lin.e.size();
    st.rows = static_cast<std::size_t>(n_rows);
    const auto nh = static_cast<Eigen::Index>(model_parameters.size());
    const Eigen::VectorXd& e0 = lin.e0;
    const double rss0 = lin.rss0;
    const double dn = static_cast<double>(n_rows);
    const double ln_g = std::log(static_cast<double>(std::max<std::size_t>(1, grid.size())));
    st.base_cost = rss0 / dn;
    for (std::size_t i = 0; i < grid.size(); ++i) {
        const Eigen::VectorXd x = lin.projected(i);
        const double sxx = x.squaredNorm();
        if (!(sxx > 0)) continue;
        const double sxy = x.dot(e0);
        const double rss1 = std::max(rss0 - sxy * sxy / sxx, std::numeric_limits<double>::min());
        LowSpeedEvidence ev;
        ev.stribeck_speed_rad_s = grid[i].shape1;
        ev.amplitude_nm = sxy / sxx;
        ev.amplitude_se_nm = std::sqrt(rss1 / std::max(1.0, dn - static_cast<double>(nh) - 1.0) / sxx);
        ev.delta_bic = dn * std::log(rss0 / rss1) - 2.0 * std::log(dn) - 2.0 * ln_g;
        ev.sign_ok = ev.amplitude_nm > 0;
        st.ranking.push_back(ev);
    }
    std::stable_sort(st.ranking.begin(), st.ranking.end(), [](const LowSpeedEvidence& a, const LowSpeedEvidence& b) {
        if (a.sign_ok != b.sign_ok) return a.sign_ok;
        return a.delta_bic > b.delta_bic;
    });
    if (st.ranking.empty() || !st.ranking.front().sign_ok || !(st.ranking.front().delta_bic > kMinDeltaBic) ||
        st.ranking.front().amplitude_nm < kMinEffectPeakNm) {
        st.verdict = st.ranking.empty() ? "no usable Stribeck column"
                     : !st.ranking.front().sign_ok
                         ? "no Stribeck speed with a positive amplitude"
                         : "no Stribeck friction in the trajectory (best: w_s = " + fmt3(st.ranking.front().stribeck_speed_rad_s) +
                               " rad/s, amplitude " + fmt3(st.ranking.front().amplitude_nm) + " N m, delta BIC " +
                               fmt3(st.ranking.front().delta_bic) + ")";
        return false;
    }
    // The fits below cost about a hundred re-simulations: they run only when the linearised screen
    // says the trajectory is significantly above its floor after the model's own parameters (z of the
    // chi-square > kStructureMinZ) and the best speed explains at least half of that excess.
    {
        const LowSpeedEvidence& b = st.ranking.front();
        const double rss1 = rss0 * std::exp(-(b.delta_bic + 2.0 * std::log(dn) + 2.0 * ln_g) / dn);
        const double z = (rss0 - dn) / std::sqrt(2.0 * dn);
        const double share = rss0 > dn ? (rss0 - rss1) / (rss0 - dn) : 0.0;
        if (!(z > kStructureMinZ) || share < kLowSpeedScreenMinExplained) {
            st.verdict = "no Stribeck friction in the trajectory: after the model's own parameters the trajectory is " +
                         fmt3(st.base_cost) + " x its floor in chi-square (z = " + fmt3(z) + "), and the best speed (w_s = " +
                         fmt3(b.stribeck_speed_rad_s) + " rad/s) explains " + fmt3(100.0 * share) + " % of the excess";
            return false;
        }
    }
    st.screen_passes = true;
    return true;
}

/// The trajectory sees mainly the impulse, amplitude x w_s: a long, curved valley over w_s on which
/// the re-simulated cost is rough at small steps (the simulator's current chatter), so a
/// Levenberg-Marquardt fit from the linearised best stops where it starts, with standard errors that
/// do not cover the truth. The start is chosen on the profile over w_s instead, in two batches: the
/// best scanned speeds re-simulated at their own amplitude, then a grid four times finer around the
/// best of them at the same impulse; each point corrected by one linear step in the model's
/// parameters and the amplitude; a parabola through the best three in ln w_s gives the start.
struct ProfilePoint {
    double w_s = 0, amplitude = 0;
    std::size_t column = 0;  ///< the scanned speed whose column linearises the point
    sim::EmaParams params;
    double rss = std::numeric_limits<double>::infinity();
    Eigen::VectorXd beta;
};

/// The scanned speed whose column linearises speed `w`.
std::size_t nearest_column(const std::vector<EffectShape>& grid, double w) {
    std::size_t best_i = 0;
    for (std::size_t i = 1; i < grid.size(); ++i) {
        if (std::abs(std::log(grid[i].shape1 / w)) < std::abs(std::log(grid[best_i].shape1 / w))) best_i = i;
    }
    return best_i;
}

/// Re-simulates the profile points (one batch), each corrected by one linear step in the model's
/// parameters and the amplitude.
void evaluate_profile(const Context& ctx, const sim::EmaParams& p, const TrajectoryLinearisation& lin, LowSpeedStage& st,
                      std::vector<ProfilePoint>& pts) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const auto n_rows = lin.e.size();
    const auto nh = lin.hcols.cols();
    const Eigen::MatrixXd& hcols = lin.hcols;
    std::vector<sim::EmaParams> params;
    for (auto& pt : pts) {
        pt.params = p;
        set_parameter(pt.params, FitParameter::effect(FittedEffect::StribeckAmplitude), pt.amplitude);
        set_parameter(pt.params, FitParameter::effect(FittedEffect::StribeckSpeed), pt.w_s);
        pt.params.fsj_nm = std::max(fsj_base_nm, pt.params.fdj_nm);
        params.push_back(pt.params);
    }
    const std::vector<Run> prs = resimulate_many(run, params);
    st.simulations += static_cast<int>(prs.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
        const std::vector<double> r = trajectory_rows(s, run_signals(prs[i]), floor);
        const Eigen::Map<const Eigen::VectorXd> ri(r.data(), n_rows);
        Eigen::MatrixXd a(n_rows, nh + 1);
        a.leftCols(nh) = hcols;
        a.col(nh) = lin.probes[pts[i].column];
        pts[i].beta = a.colPivHouseholderQr().solve(ri);
        pts[i].rss = (ri - a * pts[i].beta).squaredNorm();
    }
}

/// The profile over w_s: the best scanned speeds, then a grid finer around the best of them (st.profile).
std::pair<std::vector<ProfilePoint>, std::vector<ProfilePoint>> stribeck_profile(const Context& ctx, const sim::EmaParams& p,
                                                                                 const TrajectoryLinearisation& lin,
                                                                                 const std::vector<EffectShape>& grid, LowSpeedStage& st) {
    const auto nh = lin.hcols.cols();
    const double dn = static_cast<double>(lin.e.size());
    std::vector<ProfilePoint> coarse;
    for (const auto& ev : st.ranking) {
        if (coarse.size() >= kLowSpeedProfilePoints || !ev.sign_ok) break;
        ProfilePoint pt;
        pt.w_s = ev.stribeck_speed_rad_s;
        pt.amplitude = ev.amplitude_nm;
        pt.column = nearest_column(grid, pt.w_s);
        coarse.push_back(pt);
    }
    evaluate_profile(ctx, p, lin, st, coarse);
    const ProfilePoint c_best = *std::min_element(coarse.begin(), coarse.end(), [](const ProfilePoint& x, const ProfilePoint& y) {
        return x.rss < y.rss;
    });
    const double grid_ratio = grid.size() >= 2 ? grid[1].shape1 / grid[0].shape1 : 1.25;
    const double fine_ratio = std::pow(grid_ratio, 1.0 / kLowSpeedFineSteps);
    const double impulse = (c_best.amplitude + c_best.beta(nh)) * c_best.w_s;
    std::vector<ProfilePoint> fine;
    for (int k = -kLowSpeedFineSteps + 1; k < kLowSpeedFineSteps; ++k) {
        ProfilePoint pt;
        pt.w_s = c_best.w_s * std::pow(fine_ratio, k);
        pt.amplitude = std::max(impulse / pt.w_s, kLowSpeedProbeNm * 0.01);
        pt.column = nearest_column(grid, pt.w_s);
        fine.push_back(pt);
    }
    evaluate_profile(ctx, p, lin, st, fine);
    for (const auto* set : {&coarse, &fine}) {
        for (const auto& pt : *set) st.profile.push_back({pt.w_s, pt.amplitude + pt.beta(nh), pt.rss / dn});
    }
    std::sort(st.profile.begin(), st.profile.end());
    return {std::move(coarse), std::move(fine)};
}

/// The Stribeck friction's estimate from the profile: w_s and the amplitude, with their log-scale errors.
struct ProfileEstimate {
    double w_hat = 0, a_hat = 0;
    double x_se = 0, ln_a_se = 0;  ///< standard errors of ln w_s and ln A
};

ProfileEstimate estimate_from_profile(const std::vector<ProfilePoint>& coarse, const std::vector<ProfilePoint>& fine,
                                      const std::vector<EffectShape>& grid, const LowSpeedStage& st, Eigen::Index nh, double dn) {
    const double grid_ratio = grid.size() >= 2 ? grid[1].shape1 / grid[0].shape1 : 1.25;
    // The estimate and its uncertainty from the profile, not from a local Jacobian: x = ln w_s, a
    // quadratic in x least-squares fitted to the profile points within kLowSpeedProfileSpan scan steps
    // of the best; its vertex is the estimate; the variance of the vertex from the scatter of the
    // points about the quadratic (the simulator's chatter makes the cost rough from point to point)
    // plus the sensor noise's share 1 / (N c) (a change of 1 in chi-square). The amplitude follows
    // the valley: ln A linear in x over the same points, at the vertex.
    const ProfilePoint* f_best = &fine[0];
    for (const auto& pt : fine) {
        if (pt.rss < f_best->rss) f_best = &pt;
    }
    std::vector<const ProfilePoint*> near;
    for (const auto* set : {&coarse, &fine}) {
        for (const auto& pt : *set) {
            if (std::abs(std::log(pt.w_s / f_best->w_s)) <= kLowSpeedProfileSpan * std::log(grid_ratio) + 1e-9 &&
                pt.amplitude + pt.beta(nh) > 0) {
                near.push_back(&pt);
            }
        }
    }
    const double x0 = std::log(f_best->w_s);
    double x_hat = 0, x_se = 0, ln_a_hat = std::log(f_best->amplitude + f_best->beta(nh)), ln_a_se = 0;
    {
        const auto np = static_cast<Eigen::Index>(near.size());
        Eigen::MatrixXd xq(np, 3);
        Eigen::VectorXd yc(np), ya(np);
        double x_min = 0, x_max = 0;
        for (Eigen::Index i = 0; i < np; ++i) {
            const double x = std::log(near[static_cast<std::size_t>(i)]->w_s) - x0;
            xq(i, 0) = 1.0;
            xq(i, 1) = x;
            xq(i, 2) = x * x;
            yc(i) = near[static_cast<std::size_t>(i)]->rss / dn;
            ya(i) = std::log(near[static_cast<std::size_t>(i)]->amplitude + near[static_cast<std::size_t>(i)]->beta(nh));
            x_min = std::min(x_min, x);
            x_max = std::max(x_max, x);
        }
        const Eigen::VectorXd cq = xq.colPivHouseholderQr().solve(yc);
        // The scatter's variance is estimated from a few points: scaled by (t / z)^2 at 95 % for its
        // degrees of freedom (Cornish-Fisher expansion of Student's t), so the interval keeps its cover.
        const double dof_q = static_cast<double>(std::max<Eigen::Index>(1, np - 3));
        constexpr double kZ95 = 1.959964;
        const double t95 = kZ95 + (std::pow(kZ95, 3) + kZ95) / (4.0 * dof_q) +
                           (5.0 * std::pow(kZ95, 5) + 16.0 * std::pow(kZ95, 3) + 3.0 * kZ95) / (96.0 * dof_q * dof_q);
        const Eigen::VectorXd rq = yc - xq * cq;
        const double scatter2 = np > 3 ? rq.squaredNorm() / dof_q * (t95 / kZ95) * (t95 / kZ95) : 0.0;
        const Eigen::Matrix3d cov = scatter2 * (xq.transpose() * xq).inverse();
        if (cq(2) > 0 && np > 3) {
            x_hat = std::clamp(-cq(1) / (2.0 * cq(2)), x_min, x_max);
            const Eigen::Vector3d g(0.0, -1.0 / (2.0 * cq(2)), cq(1) / (2.0 * cq(2) * cq(2)));
            x_se = std::sqrt(std::max(0.0, g.dot(cov * g)) + 1.0 / (dn * cq(2)));
        }
        // No curvature, or a vertex at the edge: w_s is known only to within the span of the points.
        if (!(cq(2) > 0) || np <= 3 || x_hat <= x_min || x_hat >= x_max) {
            x_hat = std::clamp(x_hat, x_min, x_max);
            x_se = std::max(x_se, 0.5 * (x_max - x_min));
        }
        x_se = std::min(x_se, 0.5 * (x_max - x_min) + std::log(grid_ratio));
        Eigen::MatrixXd xl(np, 2);
        xl.col(0) = xq.col(0);
        xl.col(1) = xq.col(1);
        const Eigen::VectorXd ca = xl.colPivHouseholderQr().solve(ya);
        const Eigen::VectorXd ra = ya - xl * ca;
        const double scatter_a = np > 2 ? ra.squaredNorm() / static_cast<double>(np - 2) : 0.0;
        ln_a_hat = ca(0) + ca(1) * x_hat;
        // The amplitude's own (linear) standard error at the best point, the scatter, and the valley.
        const double own = f_best->amplitude + f_best->beta(nh) > 0
                               ? st.ranking.front().amplitude_se_nm / (f_best->amplitude + f_best->beta(nh))
                               : 0.0;
        ln_a_se = std::sqrt(own * own + scatter_a + ca(1) * ca(1) * x_se * x_se);
    }
    const double w_hat = f_best->w_s * std::exp(x_hat);
    const double a_hat = std::exp(ln_a_hat);
    return {w_hat, a_hat, x_se, ln_a_se};
}

/// The model's own parameters fitted on the trajectory without and with the Stribeck friction at the
/// profile's estimate, and the verdict.
void fit_stribeck(const Context& ctx, LowSpeedResult& out, const ProfileEstimate& pe, const std::vector<FitParameter>& model_parameters,
                  const sim::EmaParams& p, double cost_now, std::size_t grid_size) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const std::vector<char>& mask = ctx.mask;
    const double fsj_base_nm = ctx.fsj_base_nm;
    LowSpeedStage& st = out.stage;
    const double ln_g = std::log(static_cast<double>(std::max<std::size_t>(1, grid_size)));
    const double w_hat = pe.w_hat, a_hat = pe.a_hat, x_se = pe.x_se, ln_a_se = pe.ln_a_se;
    sim::EmaParams start = p;
    start.fsj_nm = std::max(fsj_base_nm, start.fdj_nm);
    const FitResult health_fit = fit_by_resimulation(run, s, start, model_parameters, mask, fsj_base_nm, kFitWindowSamples,
                                                     nullptr, kMaxFitIterations, &floor);
    // The model's own parameters refitted on the trajectory with the Stribeck friction at the profile's
    // estimate (a smooth, well-conditioned fit).
    start = health_fit.params;
    set_parameter(start, FitParameter::effect(FittedEffect::StribeckAmplitude), a_hat);
    set_parameter(start, FitParameter::effect(FittedEffect::StribeckSpeed), w_hat);
    out.fit = fit_by_resimulation(run, s, start, model_parameters, mask, fsj_base_nm, kFitWindowSamples, nullptr,
                                  kMaxFitIterations, &floor);
    out.fit.values.push_back({FitParameter::effect(FittedEffect::StribeckAmplitude), a_hat, a_hat * ln_a_se});
    out.fit.values.push_back({FitParameter::effect(FittedEffect::StribeckSpeed), w_hat, w_hat * x_se});
    st.simulations += health_fit.simulations + out.fit.simulations;
    const double rows = static_cast<double>(out.fit.rows);
    st.cost_health_only = health_fit.cost_end / rows;
    st.cost_with = out.fit.cost_end / rows;
    st.fitted = out.fit.values;
    st.peak_nm = out.fit.params.effects.stribeck_amplitude_nm;
    st.fit_delta_bic = rows * std::log(health_fit.cost_end / std::max(out.fit.cost_end, std::numeric_limits<double>::min())) -
                       2.0 * std::log(rows) - 2.0 * ln_g;
    const double z_model = (health_fit.cost_end - rows) / std::sqrt(2.0 * rows);
    st.explained = z_model > kStructureMinZ ? (st.cost_health_only - st.cost_with) / (st.cost_health_only - 1.0) : 0.0;
    const std::string figures = "trajectory cost " + fmt3(cost_now) + " (the model's own parameters refitted alone " + fmt3(st.cost_health_only) +
                                ") -> " + fmt3(st.cost_with) + ", delta BIC " + fmt3(st.fit_delta_bic) + ", explains " +
                                fmt3(100.0 * st.explained) + " % of the excess over the floor, amplitude " +
                                fmt3(st.peak_nm) + " N m";
    if (!(st.fit_delta_bic > kMinDeltaBic)) {
        st.verdict = "not confirmed by the fit: " + figures;
    } else if (st.peak_nm < kMinEffectPeakNm) {
        st.verdict = "not added: amplitude below " + fmt3(kMinEffectPeakNm) + " N m: " + figures;
    } else if (st.cost_health_only < kStructureMinExcessTrajectory * kStructureMinExcessTrajectory) {
        // The structure report's own threshold (RMS 1.5 x the floor): what the model's own parameters
        // leave below it is within the spread of clean runs, and a friction fitted to it fits noise.
        st.verdict = "not added: the model's own parameters refitted on the trajectory leave it at " +
                     fmt3(st.cost_health_only) + " floors, below the structure threshold of " +
                     fmt3(kStructureMinExcessTrajectory * kStructureMinExcessTrajectory) + ": " + figures;
    } else if (st.explained < kLowSpeedMinExplained) {
        st.verdict = "not added: explains less than " + fmt3(100.0 * kLowSpeedMinExplained) +
                     " % of the trajectory's excess (structure of another kind): " + figures;
    } else if (!(st.cost_with < cost_now)) {
        st.verdict = "not added: the trajectory does not come closer: " + figures;
    } else {
        st.added = true;
        st.verdict = "added: " + figures;
    }
}

/// Screens the Stribeck friction on the trajectory (linearised: one re-simulation per scanned speed,
/// with the columns of the model's own parameters `model_parameters`: FDJ, eta_O and the coefficients of
/// the effects and terms already added), and when a speed passes, fits it by re-simulation on the
/// trajectory together with the model's parameters, against those parameters alone: the question is
/// whether the model needs the Stribeck friction once everything it has is fitted to the trajectory.
LowSpeedResult low_speed_fit(const Context& ctx, const std::vector<FitParameter>& model_parameters, const sim::EmaParams& p,
                             const RunSignals& model_sim, double cost_now) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const double fsj_base_nm = ctx.fsj_base_nm;
    LowSpeedResult out;
    LowSpeedStage& st = out.stage;
    st.ran = true;
    st.cost_before = cost_now;
    const std::vector<EffectShape> grid = shape_grid(EffectKind::Stribeck, s);
    const TrajectoryLinearisation lin = linearise_over_shapes(run, s, floor, fsj_base_nm, model_parameters, p, model_sim, grid,
                                                              kLowSpeedProbeNm, [](sim::EmaParams& q, const EffectShape& shape) {
                                                                  q.effects.stribeck_amplitude_nm = kLowSpeedProbeNm;
                                                                  q.effects.stribeck_speed_rad_s = shape.shape1;
                                                              });
    if (!screen_stribeck(st, lin, grid, model_parameters)) return out;
    const auto [coarse, fine] = stribeck_profile(ctx, p, lin, grid, st);
    const ProfileEstimate pe = estimate_from_profile(coarse, fine, grid, st, static_cast<Eigen::Index>(model_parameters.size()),
                                                     static_cast<double>(lin.e.size()));
    fit_stribeck(ctx, out, pe, model_parameters, p, cost_now, grid.size());
    return out;
}

}  // namespace

void low_speed_stage(Context& ctx) {
    const Run& run = ctx.run;
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const std::vector<char>& mask = ctx.mask;
    const sim::EmaParams& p = ctx.params;
    const RunSignals& model_sim = ctx.model_sim;
    const TrajectoryError& traj_now = ctx.traj_now;
    const std::vector<EffectKind>& excluded = ctx.excluded;
    std::vector<EffectShape>& accepted = ctx.accepted;
    DiscoveryReport& rep = ctx.rep;
    // Low-speed friction by the trajectory: a Stribeck friction the torque residual is too noisy to see.
    const bool stribeck_in = std::find_if(accepted.begin(), accepted.end(), [](const EffectShape& a) {
                                 return a.kind == EffectKind::Stribeck;
                             }) != accepted.end() ||
                             std::find(excluded.begin(), excluded.end(), EffectKind::Stribeck) != excluded.end();
    // A Stribeck friction the torque rounds found is estimated again on the trajectory, which
    // determines it far better (the torque fit leaves amplitude and w_s along their valley): the
    // stage runs on the model without it, and its estimate replaces the torque fit's when it brings
    // the trajectory closer than that fit.
    const bool stribeck_by_torque = std::find_if(accepted.begin(), accepted.end(), [](const EffectShape& a) {
                                        return a.kind == EffectKind::Stribeck;
                                    }) != accepted.end();
    if (stribeck_in && !stribeck_by_torque) {
        rep.low_speed.skipped = "Stribeck friction was set aside by the hypotheses";
    } else {
        // The model's own parameters, refitted on the trajectory with and without the Stribeck friction.
        sim::EmaParams p_base = p;
        RunSignals base_sim_ls = model_sim;
        if (stribeck_by_torque) {
            p_base.effects.stribeck_amplitude_nm = 0.0;
            base_sim_ls = run_signals(resimulate(run, p_base));
        }
        const std::vector<FitParameter> model_parameters = own_parameters(ctx, p, EffectKind::Stribeck);
        LowSpeedResult ls = low_speed_fit(ctx, model_parameters, p_base, base_sim_ls, trajectory_error(s, base_sim_ls, floor).cost);
        rep.low_speed = ls.stage;
        if (stribeck_by_torque) {
            rep.low_speed.refit_of_torque = true;
            if (ls.stage.added && !(ls.stage.cost_with < traj_now.cost)) {
                rep.low_speed.added = false;
                rep.low_speed.verdict = "the torque rounds' fit is kept: the trajectory's estimate does not bring the "
                                        "trajectory closer (" + fmt3(ls.stage.cost_with) + " against " + fmt3(traj_now.cost) + ")";
            } else if (ls.stage.added) {
                // ... nor may it spoil the torque evidence that found the friction: the chi-square of the
                // torque window means may rise by at most kLowSpeedMaxTorqueChi2Rise.
                const double rise = torque_window_chi2_rise(s, mask, floor, model_sim, ls.fit.signals);
                if (rise > kLowSpeedMaxTorqueChi2Rise) {
                    rep.low_speed.added = false;
                    rep.low_speed.verdict = "the torque rounds' fit is kept: the trajectory's estimate would raise the "
                                            "chi-square of the torque window means by " + fmt3(rise);
                }
            }
        }
        if (rep.low_speed.added) {
            adopt_trajectory_fit(ctx, ls.fit);
            if (!stribeck_by_torque) accepted.push_back({EffectKind::Stribeck, p.effects.stribeck_speed_rad_s, 0});
        }
    }
}

}  // namespace emadiag::discovery::pipeline
