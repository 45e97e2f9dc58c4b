#include "estimation/breakaway.hpp"

#include "core/emadiag_error.hpp"
#include "core/residual_torque.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/physics_friction_law.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <tuple>
#include <functional>

namespace emadiag {
namespace {

constexpr double kNoiseWindowStartS = 0.005;  // skip the start-up of the first hold
constexpr double kTimeEpsS = 1e-9;
constexpr double kGridStepFraction = 0.02;    // trajectory grid step, fraction of a period
constexpr double kCleanSigmaSpeedRadS = 1e-9; // weights for the exact (noise-free) fit
constexpr double kCleanSigmaThetaRad = 1e-12;
constexpr double kMinCurrentForSweepA = 1e-6;
constexpr double kHingeFitS = 0.02;
constexpr std::size_t kMinRampSamples = 4;
constexpr double kSlipSpeedFraction = 0.3;
constexpr double kUniformSdFactor = 0.28867513459481287;  // 1/sqrt(12)
constexpr int kStickSlipPieces = 40;  // components standing for the uniform stick-slip segment
// Share of the chatter-beat shortfall taken as the sd of the slip onset's model error (step 6,
// noisy data). Tuned once on calibration_bench seed 11 (mean (err/se)^2 of BRK FDJ = 1.0 in
// case B, 1.1 in case A) and reported on seed 7.
constexpr double kOnsetModelShare = 0.1;

struct Stats {
    double mean = 0, sd = 0;
    std::size_t n = 0;
};
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

/// y = a + b (t - t0) by least squares.
struct Line {
    double a = 0, b = 0, t0 = 0, sigma = 0, sxx = 0;
    std::size_t n = 0;
    [[nodiscard]] double at(double t) const { return a + b * (t - t0); }
    [[nodiscard]] double se_at(double t) const {
        if (n < 3 || sxx <= 0) return sigma;
        return sigma * std::sqrt(1.0 / static_cast<double>(n) + (t - t0) * (t - t0) / sxx);
    }
};
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

/// Noisy data, after the move end: the position hold takes over (section 5) and brings the shaft
/// to rest. For a candidate slip this is fixed by its speed at the move end and its dynamic
/// friction, so the hold's first samples (speed, angle, and the current while the shaft still
/// moves: I = K_w (K_theta (theta_cmd - theta) - w), which reads the speed 2.5 times finer than the
/// speed channel) tell slips apart that the ramp alone cannot: a late, steep start ends faster than
/// an early, slow one. Left out: the current of a resting shaft (its chatter sawtooth is not
/// modelled) and the mean angle it rests at over the hold (that stopping distance is off by more
/// than its 8e-5 rad precision: with it, the calibration bench's BRK intervals covered 89-91 %).
struct PostMove {
    std::size_t first = 0;           ///< first sample wholly after the move end
    double sigma_w = 0, sigma_th = 0, sigma_i = 0, load_nm = 0;
    bool ok = false;
};
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

struct ProfileResult {
    double t_b = 0, se = 0, g0 = 0;
    bool ok = false;
};

/// Profile of a trajectory fit over a grid of breakaway times t_b in [t_lo, t_hi]: the best t_b, its
/// one-se half-width (where the SSE rises by one residual variance), and the whole profile.
/// `fit(t_b)` returns the TrajectoryFit at t_b; `fitted_params` is how many parameters it fits
/// besides t_b; `scale_by_fit` scales the SSE by max(1, SSE_min / dof).
struct GridProfile {
    ProfileResult best;
    std::vector<double> t_s, sse, g0;  ///< the profile (g0: the fitted J dw/dt just after t_b)
    double scale = 1;              ///< residual variance factor
};
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

ProfileResult profile_breakaway(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi,
                                double g1_nm_s, double sigma_w, double sigma_th, bool scale_by_fit) {
    constexpr double kFittedParams = 3.0;
    return profile_grid(
               run, a, b, t_lo, t_hi,
               [&](double t) { return fit_trajectory(run, a, b, t, g1_nm_s, sigma_w, sigma_th); }, kFittedParams,
               scale_by_fit)
        .best;
}

/// The hold that ends at `ramp_start_s`: its constant position-mode current demand, from the
/// controller law of section 3 step 2 with the shaft stuck (w = 0),
/// I_ref = K_w K_theta (theta_cmd_m - theta_m), and the angle the shaft is stuck at, averaged over
/// the last kHoldAverageS of the hold (on clean data over the final stretch with zero speed only).
/// Means, with the standard errors of the means in `sd`.
struct Hold {
    Stats demand_a, theta_rad;
};
Hold hold_before(const Run& run, double ramp_start_s, bool clean) {
    constexpr double kHoldAverageS = 0.04;
    const double period = run.constants.sample_period_s;
    std::vector<double> v, th;
    for (const auto& x : run.samples) {
        if (x.t_s > ramp_start_s + kTimeEpsS) break;
        if (x.t_s - period < ramp_start_s - kHoldAverageS - kTimeEpsS) continue;
        if (clean && x.speed_rad_s != 0.0) { v.clear(); th.clear(); continue; }  // the final stuck stretch
        const double cmd_m = run.constants.tau * x.command_deg * (std::numbers::pi / 180.0);
        v.push_back(kSpeedLoopGainAsPerRad * kPositionLoopGainPerS * (cmd_m - x.theta_m_rad));
        th.push_back(x.theta_m_rad);
    }
    Hold h{stats(v), stats(th)};
    for (Stats* st : {&h.demand_a, &h.theta_rad}) st->sd = st->n > 1 ? st->sd / std::sqrt(static_cast<double>(st->n)) : 0.0;
    return h;
}

/// Noisy data: when the ramp ended inside period e, from the mix of ramp and hold current in the
/// sample mean: I_e = f I_ramp + (1 - f) I_hold with I_hold the controller demand at the end of
/// the period (the current loop follows a new demand within microseconds).
double move_end_from_current(const Run& run, std::size_t e, double ramp_mean_current_a) {
    const auto& x = run.samples[e];
    const double period = run.constants.sample_period_s;
    const double cmd_m = run.constants.tau * x.command_deg * (std::numbers::pi / 180.0);
    const double hold_a = kSpeedLoopGainAsPerRad * (kPositionLoopGainPerS * (cmd_m - x.theta_m_rad) - x.speed_rad_s);
    const double den = ramp_mean_current_a - hold_a;
    const double f = den != 0 ? std::clamp((x.current_a - hold_a) / den, 0.0, 1.0) : 0.5;
    return x.t_s - period + f * period;
}

/// Clean data: when the angle first moved kBrkMoveRad from theta_start in direction d, between
/// samples k-1 and k, using the exact period-mean speed and a linear speed inside the period.
std::optional<double> move_end_time(const Run& run, std::size_t from, double theta_start, int d) {
    const auto& s = run.samples;
    const double period = run.constants.sample_period_s;
    for (std::size_t k = std::max<std::size_t>(from, 1); k < s.size(); ++k) {
        if (d * (s[k].theta_m_rad - theta_start) < kBrkMoveRad) continue;
        const double target = theta_start + d * kBrkMoveRad;
        const double wbar = s[k].speed_rad_s;
        const double acc = (s[k].speed_rad_s - s[k - 1].speed_rad_s) / period;
        // theta(x) = theta_{k-1} + (wbar - acc T / 2) x + acc x^2 / 2, x in [0, T]
        const double w0 = wbar - 0.5 * acc * period;
        double x = wbar != 0 ? (target - s[k - 1].theta_m_rad) / wbar : 0.5 * period;
        for (int it = 0; it < 5; ++it) {
            const double f = s[k - 1].theta_m_rad + w0 * x + 0.5 * acc * x * x - target;
            const double df = w0 + acc * x;
            if (df == 0) break;
            x -= f / df;
        }
        x = std::clamp(x, 0.0, period);
        return s[k].t_s - period + x;
    }
    return std::nullopt;
}

/// Profile of fit_trajectory_to_end over t_b in [t_lo, t_hi] (physical: d g0 >= 0): the best t_b,
/// its one-se half-width, and the whole profile for the posterior of step 5.
using EndProfile = GridProfile;
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

std::size_t first_sample_starting_at(const Run& run, double t_s, std::size_t from) {
    const double period = run.constants.sample_period_s;
    for (std::size_t k = from; k < run.samples.size(); ++k) {
        if (run.samples[k].t_s - period >= t_s - kTimeEpsS) return k;
    }
    return run.samples.size();
}

}  // namespace

double chatter_mean_current_a(double i_ref_a, double ramp_a_s) {
    const double mag = std::abs(i_ref_a);
    const double u = (kDriveSupplyV - kStatorResistanceOhm * mag) * kCurrentLoopStepS / kStatorInductanceH;
    if (mag <= 0.5 * u) return 0.0;
    const double shift = std::abs(ramp_a_s) * kStatorInductanceH / kStatorResistanceOhm;
    const double lo = mag - 0.5 * u + shift, hi = mag + 0.5 * u + shift;
    const double logmean = (hi - lo) / std::log(hi / lo);
    return (i_ref_a > 0 ? 1.0 : -1.0) * (logmean - shift);
}

std::pair<double, double> mixture_moments(const std::vector<MixtureComponent>& mix) {
    double w = 0, m1 = 0, m2 = 0;
    for (const auto& c : mix) {
        w += c.weight;
        m1 += c.weight * c.mean;
        m2 += c.weight * (c.mean * c.mean + c.sd * c.sd);
    }
    if (!(w > 0)) return {0.0, 0.0};
    const double mean = m1 / w;
    return {mean, std::sqrt(std::max(0.0, m2 / w - mean * mean))};
}

PosteriorSummary product_posterior(const std::vector<std::vector<MixtureComponent>>& mixes, const HealthRange& band,
                                   double uniform_half_width) {
    constexpr double kGridSpanSd = 6.0;
    constexpr int kGridPoints = 4000;
    constexpr double kMass = 0.95;
    constexpr double kNegligibleWeight = 1e-12;  // relative to a look's heaviest component
    PosteriorSummary out;
    // The grid spans the components that carry weight: a profile point far from the best t_b can
    // map to a wild value (g0 grows as the slip span shrinks) with a weight of exp(-1000).
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, finest = lo;
    for (const auto& mix : mixes) {
        double heaviest = 0;
        for (const auto& c : mix) heaviest = std::max(heaviest, c.weight);
        for (const auto& c : mix) {
            if (c.weight < kNegligibleWeight * heaviest) continue;
            lo = std::min(lo, c.mean - kGridSpanSd * c.sd);
            hi = std::max(hi, c.mean + kGridSpanSd * c.sd);
            finest = std::min(finest, c.sd);
        }
    }
    if (mixes.empty() || !(hi > lo) || !(finest > 0)) {
        if (!mixes.empty()) std::tie(out.mean, out.sd) = mixture_moments(mixes.front());
        out.se95 = out.sd;
        return out;
    }
    const double step = (hi - lo) / kGridPoints;
    const auto grid = [&](int k) { return lo + k * step; };
    std::vector<double> log_density(kGridPoints + 1, 0.0), p(kGridPoints + 1);
    for (const auto& mix : mixes) {
        std::fill(p.begin(), p.end(), 0.0);
        for (const auto& c : mix) {  // each component only over its own +/- kGridSpanSd
            const double f0 = std::floor((c.mean - kGridSpanSd * c.sd - lo) / step);
            const double f1 = std::ceil((c.mean + kGridSpanSd * c.sd - lo) / step);
            if (!(f1 >= 0.0 && f0 <= kGridPoints)) continue;  // off the grid (or not finite)
            const int k0 = static_cast<int>(std::max(0.0, f0));
            const int k1 = static_cast<int>(std::min(static_cast<double>(kGridPoints), f1));
            for (int k = k0; k <= k1; ++k) {
                const double z = (grid(k) - c.mean) / c.sd;
                p[static_cast<std::size_t>(k)] += c.weight / c.sd * std::exp(-0.5 * z * z);
            }
        }
        for (std::size_t k = 0; k < p.size(); ++k) {
            log_density[k] += p[k] > 0 ? std::log(p[k]) : -std::numeric_limits<double>::infinity();
        }
    }
    const double top = *std::max_element(log_density.begin(), log_density.end());
    if (!std::isfinite(top)) {  // the looks do not overlap at all: fall back to the first
        std::tie(out.mean, out.sd) = mixture_moments(mixes.front());
        out.se95 = out.sd;
        return out;
    }
    for (std::size_t k = 0; k < p.size(); ++k) p[k] = std::exp(log_density[k] - top);
    // The value is the measured quantity plus an independent uniform error of +/- h: the
    // density is the product's convolved with that box (a running mean over 2 h). The grid is
    // widened by h on both sides first.
    const int box = static_cast<int>(std::lround(uniform_half_width / step));
    std::vector<double> conv(p.size() + 2 * static_cast<std::size_t>(box), 0.0);
    if (box > 0) {
        std::vector<double> prefix(p.size() + 1, 0.0);
        for (std::size_t k = 0; k < p.size(); ++k) prefix[k + 1] = prefix[k] + p[k];
        for (std::size_t j = 0; j < conv.size(); ++j) {  // conv[j] stands at grid(j - box)
            const long c0 = static_cast<long>(j) - 2 * box, c1 = static_cast<long>(j);  // p indices [c0, c1]
            const long a0 = std::max(0L, c0), a1 = std::min(static_cast<long>(p.size()) - 1, c1);
            conv[j] = a1 >= a0 ? prefix[static_cast<std::size_t>(a1 + 1)] - prefix[static_cast<std::size_t>(a0)] : 0.0;
        }
    } else {
        conv = p;
    }
    p = std::move(conv);
    const double x0 = lo - box * step;
    const auto at = [&](std::size_t j) { return x0 + static_cast<double>(j) * step; };
    double w = 0, m1 = 0, m2 = 0;
    for (std::size_t j = 0; j < p.size(); ++j) {
        const double x = at(j);
        p[j] *= x >= band.lo && x <= band.hi ? 1.0 : kOutOfBandPrior;
        w += p[j];
        m1 += p[j] * x;
        m2 += p[j] * x * x;
    }
    out.mean = m1 / w;
    out.sd = std::sqrt(std::max(0.0, m2 / w - out.mean * out.mean));
    // Smallest half-width h with kMass of the posterior inside mean +/- h (bisection on h).
    auto mass_within = [&](double h) {
        double m = 0;
        for (std::size_t j = 0; j < p.size(); ++j) {
            if (std::abs(at(j) - out.mean) <= h) m += p[j];
        }
        return m / w;
    };
    double h_lo = 0, h_hi = hi - lo + 2 * box * step;
    for (int it = 0; it < 40; ++it) {
        const double h = 0.5 * (h_lo + h_hi);
        (mass_within(h) >= kMass ? h_hi : h_lo) = h;
    }
    out.se95 = std::max(h_hi, step) / kZ95;
    return out;
}

BreakawayAnalysis analyse_breakaways(const Run& run) {
    BreakawayAnalysis out;
    const auto& s = run.samples;
    const auto& c = run.constants;
    const double period = c.sample_period_s;
    const std::size_t n = s.size();

    // 1. Noise levels from the first hold.
    std::vector<double> hw, hth, hi, ht, hh;
    for (const auto& x : s) {
        if (x.t_s >= kNoiseWindowStartS && x.t_s <= kBrkFirstHoldS + kTimeEpsS) {
            hw.push_back(x.speed_rad_s);
            hth.push_back(x.theta_m_rad);
            hi.push_back(x.current_a);
            ht.push_back(x.t_s);
            hh.push_back(x.hinge_moment_nm);
        }
    }
    if (hw.size() < 3) {
        throw EmadiagError("BRK run too short: " + std::to_string(n) + " samples do not cover the first " +
                           std::to_string(kBrkFirstHoldS) + " s position hold (ema-reference.md section 5)");
    }
    out.clean = std::all_of(hw.begin(), hw.end(), [](double w) { return w == 0.0; });
    out.sigma_speed_rad_s = stats(hw).sd;
    out.sigma_theta_rad = stats(hth).sd;
    out.sigma_current_a = stats(hi).sd;
    out.sigma_hinge_nm = fit_line(ht, hh).sigma;
    const double sigma_w = out.clean ? kCleanSigmaSpeedRadS : std::max(out.sigma_speed_rad_s, kCleanSigmaSpeedRadS);
    const double sigma_th = out.clean ? kCleanSigmaThetaRad : std::max(out.sigma_theta_rad, kCleanSigmaThetaRad);
    const auto prior = load_coefficient_prior(c.tau);

    double ramp_start_s = kBrkFirstHoldS;  // the exact start of the ramp (section 5 and 7)
    for (int d : {+1, -1}) {
        const std::string dname = d > 0 ? "positive" : "negative";
        BreakawayEvent ev;
        ev.direction = d;
        ev.ramp_first = first_sample_starting_at(run, ramp_start_s, 0);
        if (ev.ramp_first + kMinRampSamples >= n) {
            out.problems.push_back("no " + dname + " ramp: the run ends before t = " +
                                   std::to_string(ramp_start_s) + " s + " + std::to_string(kMinRampSamples) +
                                   " samples");
            break;
        }
        // The hold before the ramp: the demand the ramp starts from and the angle it starts at.
        const Hold hold = hold_before(run, ramp_start_s, out.clean);
        auto ramp_demand = [&](double t) { return hold.demand_a.mean + d * kBrkRampAPerS * (t - ramp_start_s); };
        // Ramp end: the position hold takes over and the current leaves the ramp line.
        std::size_t e = n;
        for (std::size_t k = ev.ramp_first + 1; k < n; ++k) {
            const double line = chatter_mean_current_a(ramp_demand(s[k].t_s - 0.5 * period), kBrkRampAPerS);
            if (d * (s[k].current_a - line) < -kRampEndDropA) { e = k; break; }
        }
        ev.ramp_end_sample = e;
        if (e >= n || e < ev.ramp_first + kMinRampSamples) {
            out.problems.push_back("no " + dname + " ramp end found: the shaft never moved " +
                                   std::to_string(kBrkMoveRad) + " rad");
            break;
        }
        // When the shaft had moved kBrkMoveRad (the ramp end).
        std::optional<double> t_end;
        if (out.clean) t_end = move_end_time(run, ev.ramp_first, hold.theta_rad.mean, d);
        if (!t_end) {
            t_end = move_end_from_current(run, e, chatter_mean_current_a(ramp_demand(s[e].t_s - period), kBrkRampAPerS));
        }
        ev.t_move_end_s = *t_end;
        // Load slope for g1 (J dw/dt rises with the ramp and falls with the load).
        std::vector<double> lt, lf;
        const std::size_t a_traj = std::max(ev.ramp_first, first_sample_starting_at(run, *t_end - kTrajectoryWindowS, 0));
        for (std::size_t k = a_traj; k < e; ++k) {
            lt.push_back(s[k].t_s - 0.5 * period);
            lf.push_back(s[k].hinge_moment_nm / c.tau);
        }
        const Line fr_line = fit_line(lt, lf);
        const double fr_now = fr_line.at(lt.empty() ? 0.0 : lt.back());
        const double c_mid = fr_now * d > 0 ? prior.c_opp_mid : prior.c_aid_mid;
        const double d_abs_fr = (fr_now >= 0 ? 1.0 : -1.0) * fr_line.b;
        const double g1 = d * c.k_t_nm_per_a * kBrkRampAPerS - fr_line.b - d * c_mid * d_abs_fr;
        const std::size_t b_traj = e - 1;

        // 2. Breakaway time.
        EndProfile profile;                 // noisy data: the t_b profile
        bool profile_from_g0_zero = false;  // its first point is the start with zero acceleration
        if (out.clean) {
            std::size_t kb = n;
            for (std::size_t k = ev.ramp_first; k < e; ++k) {
                if (d * s[k].speed_rad_s > 0) { kb = k; break; }
            }
            if (kb == n) {
                out.problems.push_back("no " + dname + " breakaway: the speed never leaves zero during the ramp");
                break;
            }
            const double lo = s[kb].t_s - period, hi_t = s[kb].t_s;
            const auto pr = profile_breakaway(run, a_traj, std::min(b_traj, kb + 4), lo, hi_t, g1, sigma_w, sigma_th, false);
            ev.method = "exact-speed";
            // The chatter swings the instantaneous motor torque by k_t u; when the mean excess over
            // dynamic friction after breakaway, g0, is below half of it, the troughs fall below
            // dynamic friction and the shaft stick-slips on the current peaks at first. The smooth
            // trajectory then starts before the shaft really broke away (it fits the slowed start
            // with an earlier onset), so the data only bracket t_b to [fitted onset, end of the
            // first-motion period]: uniform over it.
            const double u_hi = (kDriveSupplyV - kStatorResistanceOhm * std::abs(ramp_demand(hi_t))) * kCurrentLoopStepS /
                                kStatorInductanceH;
            const bool stick_slip_start = pr.ok && d * pr.g0 > 0 && d * pr.g0 < 0.5 * c.k_t_nm_per_a * u_hi;
            if (stick_slip_start) {
                ev.t_breakaway_s = 0.5 * (pr.t_b + hi_t);
                ev.t_breakaway_se_s = std::hypot(pr.se, (hi_t - pr.t_b) * kUniformSdFactor);
                ev.slip_accel_torque_nm = pr.g0;
            } else if (pr.ok && d * pr.g0 > 0) {
                ev.t_breakaway_s = pr.t_b;
                ev.t_breakaway_se_s = pr.se;
                ev.slip_accel_torque_nm = pr.g0;
            } else {
                ev.t_breakaway_s = 0.5 * (lo + hi_t);
                ev.t_breakaway_se_s = period * kUniformSdFactor;
            }
        } else {
            // d g0 >= 0: the slip cannot start later than the onset with zero initial acceleration.
            const double dg1 = d * g1;
            const double span_max = dg1 > 0 ? std::cbrt(6 * kBrkMoveRad * c.j_kgm2 / dg1) : kTrajectoryWindowS;
            const double lo = std::max(s[a_traj].t_s - period, *t_end - span_max);
            const double hi_t = *t_end - period;
            PostMove post;
            post.first = e + 1;
            post.sigma_w = sigma_w;
            post.sigma_th = sigma_th;
            post.sigma_i = std::max(out.sigma_current_a, kMinCurrentForSweepA);
            post.load_nm = fr_now;
            post.ok = post.first < n;
            // D_d for a candidate: the mean torque at t_b less the initial excess g0 (step 6).
            const std::function<double(double, double)> dyn_for = [&](double t_b, double g0) {
                return d * (c.k_t_nm_per_a * chatter_mean_current_a(ramp_demand(t_b), kBrkRampAPerS) - fr_line.at(t_b)) - d * g0;
            };
            const auto ep = profile_to_end(run, a_traj, b_traj, lo, hi_t, g1, hold.theta_rad.mean, *t_end, d, sigma_w,
                                           sigma_th, post, dyn_for);
            if (!ep.best.ok) {
                out.problems.push_back("the " + dname + " slip trajectory could not be fitted");
                break;
            }
            ev.method = "trajectory-fit";
            ev.t_breakaway_s = ep.best.t_b;
            ev.t_breakaway_se_s = ep.best.se;
            ev.slip_accel_torque_nm = ep.best.g0;
            profile = ep;
            profile_from_g0_zero = dg1 > 0 && *t_end - span_max >= s[a_traj].t_s - period;
        }
        std::size_t kb = ev.ramp_first;
        while (kb + 1 < n && s[kb].t_s < ev.t_breakaway_s) ++kb;
        ev.breakaway_sample = kb;

        // 3. Ramp demand at t_b.
        ev.ramp_current_a = ramp_demand(ev.t_breakaway_s);
        ev.ramp_current_se_a = hold.demand_a.sd;

        // 4. Load at t_b.
        std::vector<double> ht2, hf2;
        for (std::size_t k = ev.ramp_first; k < kb; ++k) {
            if (s[k].t_s < ev.t_breakaway_s - kHingeFitS) continue;
            ht2.push_back(s[k].t_s - 0.5 * period);
            hf2.push_back(s[k].hinge_moment_nm / c.tau);
        }
        if (ht2.size() < 3) {
            ht2.clear(); hf2.clear();
            for (std::size_t k = ev.ramp_first; k <= kb; ++k) { ht2.push_back(s[k].t_s - 0.5 * period); hf2.push_back(s[k].hinge_moment_nm / c.tau); }
        }
        const Line hl = fit_line(ht2, hf2);
        ev.load_torque_nm = hl.at(ev.t_breakaway_s);
        ev.load_torque_se_nm = hl.se_at(ev.t_breakaway_s);

        // 5. Chatter (section 5 note) and the threshold.
        const double i_abs = std::abs(ev.ramp_current_a);
        const double u = (kDriveSupplyV - kStatorResistanceOhm * i_abs) * kCurrentLoopStepS / kStatorInductanceH;
        const double decay_a = i_abs + kBrkRampAPerS * kStatorInductanceH / kStatorResistanceOhm;
        const double sweep = std::min(u, kBrkRampAPerS * u * kStatorInductanceH /
                                             (kStatorResistanceOhm * std::max(decay_a, kMinCurrentForSweepA)));
        ev.chatter_offset_a = u - 0.5 * sweep;
        ev.chatter_se_a = sweep * kUniformSdFactor;
        ev.threshold_nm = d * (c.k_t_nm_per_a * (ev.ramp_current_a + d * ev.chatter_offset_a) - ev.load_torque_nm);
        ev.threshold_se_nm = std::sqrt(std::pow(c.k_t_nm_per_a * kBrkRampAPerS * ev.t_breakaway_se_s, 2) +
                                       std::pow(c.k_t_nm_per_a * ev.ramp_current_se_a, 2) +
                                       std::pow(c.k_t_nm_per_a * ev.chatter_se_a, 2) +
                                       std::pow(ev.load_torque_se_nm, 2));
        if (!profile.t_s.empty()) {
            // Noisy data: the posterior of S over the t_b profile (a flat prior in S, which is
            // linear in t_b), plus, when the profile starts at g0 = 0, the stick-slip segment
            // [S(g0 = 0) - k_t u, S(g0 = 0)] at the likelihood of that start: the torque then
            // only just overcame FDJ, and the shaft may have stick-slipped on the current peaks
            // from a breakaway up to one chatter step earlier, invisibly in noisy means.
            auto threshold_at = [&](double t_b) {
                return d * (c.k_t_nm_per_a * (ramp_demand(t_b) + d * ev.chatter_offset_a) - ev.load_torque_nm);
            };
            double best = std::numeric_limits<double>::infinity();
            for (double v : profile.sse) best = std::min(best, v);
            // Each profile point is a component; the other error terms (hold demand, chatter
            // sweep, load) blur every one of them alike.
            const double blur = std::sqrt(std::pow(c.k_t_nm_per_a * ev.ramp_current_se_a, 2) +
                                          std::pow(c.k_t_nm_per_a * ev.chatter_se_a, 2) +
                                          std::pow(ev.load_torque_se_nm, 2));
            auto& mix = ev.threshold_posterior;
            double w_sum = 0;
            for (std::size_t i = 0; i < profile.t_s.size(); ++i) {
                const double w = std::exp(-(profile.sse[i] - best) / (2 * profile.scale));
                mix.push_back({threshold_at(profile.t_s[i]), blur, w});
                w_sum += w;
            }
            if (profile_from_g0_zero) {
                const double step_nm = c.k_t_nm_per_a * kBrkRampAPerS * kGridStepFraction * period;
                const double width_nm = c.k_t_nm_per_a * u;
                const double w = std::exp(-(profile.sse.front() - best) / (2 * profile.scale)) * width_nm / step_nm;
                const double top = threshold_at(profile.t_s.front());
                const double piece = width_nm / kStickSlipPieces;
                const double sd = std::hypot(blur, piece * kUniformSdFactor);
                for (int k = 0; k < kStickSlipPieces; ++k) mix.push_back({top - (k + 0.5) * piece, sd, w / kStickSlipPieces});
                w_sum += w;
                ev.stick_slip_weight = w / w_sum;
            }
            for (auto& m : mix) m.weight /= w_sum;
            // The same posterior in the dynamic friction D_d = d (k_t I_mean(t_b) - F_R) - d g0:
            // after the breakaway the mean torque exceeds it by g0 (the stick-slip start at zero
            // excess). The chatter sweep does not enter: the mean current is the sample mean.
            const double blur_d = std::hypot(c.k_t_nm_per_a * ev.ramp_current_se_a, ev.load_torque_se_nm);
            auto dyn_at = [&](std::size_t i) {
                const double i_mean = chatter_mean_current_a(ramp_demand(profile.t_s[i]), kBrkRampAPerS);
                return d * (c.k_t_nm_per_a * i_mean - ev.load_torque_nm) - d * profile.g0[i];
            };
            // Model error: the slip model is smooth, but the chatter's beat swings the mean motor
            // torque by +/- k_t u / 2 over about 0.5 ms. While the mean excess g0 is below that, the
            // shaft moves in bursts on the beat's high parts and the smooth fit's onset (hence D)
            // is off by a share of the shortfall: sd kOnsetModelShare (k_t u / 2 - |g0|).
            const double half_chatter_nm = 0.5 * c.k_t_nm_per_a * u;
            auto sd_d = [&](double g0) {
                return std::hypot(blur_d, kOnsetModelShare * std::max(0.0, half_chatter_nm - std::abs(g0)));
            };
            auto& dmix = ev.dynamic_posterior;
            for (std::size_t i = 0; i < profile.t_s.size(); ++i) dmix.push_back({dyn_at(i), sd_d(profile.g0[i]), mix[i].weight});
            if (profile_from_g0_zero) dmix.push_back({dyn_at(0), sd_d(0.0), ev.stick_slip_weight});
            const auto [mean, sd] = mixture_moments(mix);
            // Report the posterior mean (the least-squares estimate) and the posterior sd: near a
            // zero-acceleration start the profile is one-sided and the stick-slip segment lies
            // wholly below it, so the maximum-likelihood point is biased high.
            ev.threshold_nm = mean;
            ev.threshold_se_nm = sd;
        }

        // 6. Clean data: dynamic friction over the fully slipping samples, from the first sample two
        // after one that already runs at kSlipSpeedFraction of the final ramp speed (past any
        // stick-slip), to the last full ramp sample but one (the telescoped mean needs w[last+1]).
        // Noisy data have it from the slip trajectory's posterior (dynamic_posterior) instead.
        if (out.clean && e >= kb + 4 + kMinSlipSamples) {
            const double w_final = d * s[e - 1].speed_rad_s;
            // The test looks at w[first - 2], which the telescoped mean does not use, so that
            // picking the start does not select the noise of the speeds it uses.
            std::size_t first = kb + 3;
            while (first + kMinSlipSamples + 1 < e && d * s[first - 2].speed_rad_s < kSlipSpeedFraction * w_final) ++first;
            const std::size_t last = e - 2;
            if (last + 1 >= first + kMinSlipSamples && w_final > 0) {
                const double cnt = static_cast<double>(last - first + 1);
                ev.dynamic_friction_nm = d * residual_torque_mean_nm(run, first, last);
                ev.slip_samples = last - first + 1;
                const double se_j = c.j_kgm2 * out.sigma_speed_rad_s / (period * cnt);
                const double se_i = c.k_t_nm_per_a * out.sigma_current_a / std::sqrt(cnt);
                const double se_h = out.sigma_hinge_nm / c.tau / std::sqrt(cnt);
                // The telescoped ends take w at a period boundary as the mean of the two period
                // means around it, exact for a smooth speed; but the chatter's beat modulates the
                // motor torque (the sample-mean current wanders about its trend), which bends the
                // speed between the means. Each end is off by about one period of that torque
                // deviation, J dw ~ k_t dI T, over the window of cnt periods.
                std::vector<double> ti, ii;
                for (std::size_t k = first; k <= last; ++k) { ti.push_back(s[k].t_s); ii.push_back(s[k].current_a); }
                const double wander_a = fit_line(ti, ii).sigma;
                const double se_model = c.k_t_nm_per_a * wander_a / cnt;  // both ends together, measured on 100 seeded runs
                ev.dynamic_friction_se_nm = std::sqrt(se_j * se_j + se_i * se_i + se_h * se_h + se_model * se_model);
            }
        }
        out.events.push_back(ev);
        // Section 7: the hold starts on the step after the move test, the next ramp after the hold.
        ramp_start_s = ev.t_move_end_s + kBrkHoldS;
    }
    return out;
}

}  // namespace emadiag
