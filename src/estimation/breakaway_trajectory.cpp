#include "estimation/breakaway_trajectory.hpp"

#include <algorithm>
#include <limits>
#include <numbers>

namespace emadiag::breakaway_detail {

Stats stats(const std::vector<double>& v) {
    Stats s;
    s.n = v.size();
    if (v.empty()) return s;
    for (double x : v) s.mean += x;
    s.mean /= static_cast<double>(v.size());
    double ss = 0;
    for (double x : v) ss += (x - s.mean) * (x - s.mean);
    s.sd = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0.0;
    return s;
}

Line fit_line(const std::vector<double>& t, const std::vector<double>& y) {
    Line l;
    l.n = t.size();
    if (t.empty()) return l;
    for (double x : t) l.t0 += x;
    l.t0 /= static_cast<double>(t.size());
    double ym = 0;
    for (double x : y) ym += x;
    ym /= static_cast<double>(y.size());
    double sxy = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
        l.sxx += (t[i] - l.t0) * (t[i] - l.t0);
        sxy += (t[i] - l.t0) * (y[i] - ym);
    }
    l.b = l.sxx > 0 ? sxy / l.sxx : 0.0;
    l.a = ym;
    double ss = 0;
    for (std::size_t i = 0; i < t.size(); ++i) ss += std::pow(y[i] - l.at(t[i]), 2);
    l.sigma = t.size() > 2 ? std::sqrt(ss / static_cast<double>(t.size() - 2)) : 0.0;
    return l;
}

namespace {

struct TrajectoryFit {
    double sse = std::numeric_limits<double>::infinity();
    double g0_nm = 0, theta0_rad = 0;
    std::size_t rows = 0;
};

/// The slip trajectory of step 2 for one candidate t_b, over samples [a, b].
TrajectoryFit fit_trajectory(const Run& run, std::size_t a, std::size_t b, double t_b, double g1_nm_s,
                             double sigma_w, double sigma_th) {
    const double j = run.constants.j_kgm2;
    const double period = run.constants.sample_period_s;
    // Normal equations for (theta0, g0).
    double s00 = 0, s01 = 0, s11 = 0, r0 = 0, r1 = 0;
    const double ww = 1.0 / (sigma_w * sigma_w), wt = 1.0 / (sigma_th * sigma_th);
    std::vector<double> sp_c(b - a + 1), sp_y(b - a + 1), th_c(b - a + 1), th_y(b - a + 1);
    for (std::size_t k = a; k <= b; ++k) {
        const auto& s = run.samples[k];
        const double te = std::max(0.0, s.t_s - t_b);
        const double ts = std::max(0.0, s.t_s - period - t_b);
        // Theta(tau) = (g0 tau^2 / 2 + g1 tau^3 / 6) / J; period-mean speed = (Theta(te) - Theta(ts)) / T.
        const double cw = (te * te - ts * ts) / (2 * j * period);
        const double yw = s.speed_rad_s - g1_nm_s * (te * te * te - ts * ts * ts) / (6 * j * period);
        const double ct = te * te / (2 * j);
        const double yt = s.theta_m_rad - g1_nm_s * te * te * te / (6 * j);
        sp_c[k - a] = cw; sp_y[k - a] = yw; th_c[k - a] = ct; th_y[k - a] = yt;
        s11 += ww * cw * cw + wt * ct * ct;
        s00 += wt;
        s01 += wt * ct;
        r0 += wt * yt;
        r1 += ww * cw * yw + wt * ct * yt;
    }
    TrajectoryFit f;
    const double det = s00 * s11 - s01 * s01;
    if (!(det > 0)) return f;
    f.theta0_rad = (s11 * r0 - s01 * r1) / det;
    f.g0_nm = (s00 * r1 - s01 * r0) / det;
    double sse = 0;
    for (std::size_t i = 0; i < sp_c.size(); ++i) {
        sse += ww * std::pow(sp_y[i] - f.g0_nm * sp_c[i], 2);
        sse += wt * std::pow(th_y[i] - f.theta0_rad - f.g0_nm * th_c[i], 2);
    }
    f.sse = sse;
    f.rows = 2 * sp_c.size();
    return f;
}
constexpr std::size_t kPostMoveMaxSamples = 16;
constexpr double kPostMoveStepS = 2e-5;

/// SSE and rows of the post-move samples for a slip ending at t_end with speed w_end, angle
/// th_end and dynamic friction dyn_nm (magnitude).
std::pair<double, std::size_t> post_move_sse(const Run& run, const PostMove& pm, double t_end, double w_end,
                                             double th_end, double dyn_nm) {
    const auto& s = run.samples;
    const auto& c = run.constants;
    const double period = c.sample_period_s;
    double t = t_end, w = w_end, th = th_end, sse = 0;
    std::size_t rows = 0, stuck_samples = 0;
    bool stuck = false;
    for (std::size_t k = pm.first; k < s.size() && k < pm.first + kPostMoveMaxSamples && stuck_samples < 2; ++k) {
        const double t0 = s[k].t_s - period, t1 = s[k].t_s;
        const double cmd_m = c.tau * s[k].command_deg * (std::numbers::pi / 180.0);
        double sum_w = 0, sum_i = 0;
        while (t < t1 - kTimeEpsS) {
            const double h = std::min(kPostMoveStepS, t1 - t);
            const double i_dem = kSpeedLoopGainAsPerRad * (kPositionLoopGainPerS * (cmd_m - th) - w);
            if (!stuck) {
                const double sgn = w > 0 ? 1.0 : -1.0;
                const double w_new = w + h * (c.k_t_nm_per_a * i_dem - pm.load_nm - sgn * dyn_nm) / c.j_kgm2;
                stuck = w_new * w <= 0;
                w = stuck ? 0.0 : w_new;
                th += h * w;
            }
            if (t >= t0 - kTimeEpsS) {
                sum_w += h * w;
                sum_i += h * i_dem;
            }
            t += h;
        }
        sse += std::pow((s[k].speed_rad_s - sum_w / period) / pm.sigma_w, 2) +
               std::pow((s[k].theta_m_rad - th) / pm.sigma_th, 2);
        rows += 2;
        if (!stuck) {
            sse += std::pow((s[k].current_a - sum_i / period) / pm.sigma_i, 2);
            ++rows;
        } else {
            ++stuck_samples;
        }
    }
    return {sse, rows};
}

/// Noisy data: the slip trajectory for a candidate t_b with the sequence's own end condition,
/// theta(t_end) = theta0 + d kBrkMoveRad, which fixes g0; theta0 is the hold angle. SSE over the
/// speeds and angles of samples [a, b].
TrajectoryFit fit_trajectory_to_end(const Run& run, std::size_t a, std::size_t b, double t_b, double g1_nm_s,
                                    double theta0_rad, double t_end_s, int d, double sigma_w, double sigma_th,
                                    const PostMove& post, const std::function<double(double, double)>& dyn_at) {
    const double j = run.constants.j_kgm2;
    const double period = run.constants.sample_period_s;
    TrajectoryFit f;
    const double span = t_end_s - t_b;
    if (!(span > 0)) return f;
    f.g0_nm = (d * kBrkMoveRad * j - g1_nm_s * span * span * span / 6) / (span * span / 2);
    f.theta0_rad = theta0_rad;
    auto angle = [&](double tau_s) { return (f.g0_nm * tau_s * tau_s / 2 + g1_nm_s * tau_s * tau_s * tau_s / 6) / j; };
    double sse = 0;
    for (std::size_t k = a; k <= b; ++k) {
        const auto& x = run.samples[k];
        const double te = std::max(0.0, x.t_s - t_b), ts = std::max(0.0, x.t_s - period - t_b);
        sse += std::pow((x.speed_rad_s - (angle(te) - angle(ts)) / period) / sigma_w, 2);
        sse += std::pow((x.theta_m_rad - theta0_rad - angle(te)) / sigma_th, 2);
    }
    f.sse = sse;
    f.rows = 2 * (b - a + 1);
    if (post.ok) {
        const double w_end = (f.g0_nm * span + g1_nm_s * span * span / 2) / j;
        const auto [extra, rows] = post_move_sse(run, post, t_end_s, w_end, theta0_rad + angle(span), dyn_at(t_b, f.g0_nm));
        f.sse += extra;
        f.rows += rows;
    }
    return f;
}

template <class Fit>
GridProfile profile_grid(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi, Fit fit,
                         double fitted_params, bool scale_by_fit) {
    GridProfile gp;
    if (b < a + 2 || !(t_hi > t_lo)) return gp;
    const double step = kGridStepFraction * run.constants.sample_period_s;
    std::vector<double> ts, sse, g0s;
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_i = 0;
    TrajectoryFit best_fit;
    for (double t = t_lo; t <= t_hi + kTimeEpsS; t += step) {
        const TrajectoryFit f = fit(t);
        ts.push_back(t);
        sse.push_back(f.sse);
        g0s.push_back(f.g0_nm);
        if (f.sse < best) {
            best = f.sse;
            best_i = ts.size() - 1;
            best_fit = f;
        }
    }
    if (!std::isfinite(best)) return gp;
    const double dof = static_cast<double>(best_fit.rows) - fitted_params;
    const double s2 = scale_by_fit && dof > 0 ? std::max(1.0, best / dof) : 1.0;
    std::size_t lo = best_i, hi = best_i;
    while (lo > 0 && (sse[lo - 1] - best) / s2 <= 1.0) --lo;
    while (hi + 1 < sse.size() && (sse[hi + 1] - best) / s2 <= 1.0) ++hi;
    gp.best.t_b = ts[best_i];
    gp.best.se = std::max(0.5 * (ts[hi] - ts[lo]), step);
    gp.best.g0 = best_fit.g0_nm;
    gp.best.ok = true;
    gp.t_s = std::move(ts);
    gp.sse = std::move(sse);
    gp.g0 = std::move(g0s);
    gp.scale = s2;
    return gp;
}

}  // namespace

ProfileResult profile_breakaway(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi,
                                double g1_nm_s, double sigma_w, double sigma_th, bool scale_by_fit) {
    constexpr double kFittedParams = 3.0;
    return profile_grid(
               run, a, b, t_lo, t_hi,
               [&](double t) { return fit_trajectory(run, a, b, t, g1_nm_s, sigma_w, sigma_th); }, kFittedParams,
               scale_by_fit)
        .best;
}

EndProfile profile_to_end(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi, double g1_nm_s,
                          double theta0_rad, double t_end_s, int d, double sigma_w, double sigma_th, const PostMove& post,
                          const std::function<double(double, double)>& dyn_at) {
    constexpr double kFittedParams = 2.0;
    return profile_grid(
        run, a, b, t_lo, t_hi,
        [&](double t) {
            return fit_trajectory_to_end(run, a, b, t, g1_nm_s, theta0_rad, t_end_s, d, sigma_w, sigma_th, post, dyn_at);
        },
        kFittedParams, true);
}

}  // namespace emadiag::breakaway_detail
