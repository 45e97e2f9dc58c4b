#include "estimation/breakaway.hpp"

#include "core/emadiag_error.hpp"
#include "core/residual_torque.hpp"
#include "estimation/physics_friction_law.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

namespace emadiag {
namespace {

constexpr double kNoiseWindowStartS = 0.005;  // skip the start-up of the first hold
constexpr double kTimeEpsS = 1e-9;
constexpr double kInitialRampFitS = 0.01;     // stuck for sure: the first 10 ms of a ramp
constexpr double kGridStepFraction = 0.02;    // trajectory grid step, fraction of a period
constexpr double kCleanSigmaSpeedRadS = 1e-9; // weights for the exact (noise-free) fit
constexpr double kCleanSigmaThetaRad = 1e-12;
constexpr double kMinCurrentForSweepA = 1e-6;
constexpr double kHingeFitS = 0.02;
constexpr int kChatterFitIterations = 8;
constexpr double kUniformSdFactor = 0.28867513459481287;  // 1/sqrt(12)

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

struct ProfileResult {
    double t_b = 0, se = 0, g0 = 0;
    bool ok = false;
};

ProfileResult profile_breakaway(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi,
                                double g1_nm_s, double sigma_w, double sigma_th, bool scale_by_fit) {
    ProfileResult pr;
    if (b < a + 2 || !(t_hi > t_lo)) return pr;
    const double step = kGridStepFraction * run.constants.sample_period_s;
    std::vector<double> ts, sse;
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_i = 0;
    TrajectoryFit best_fit;
    for (double t = t_lo; t <= t_hi + kTimeEpsS; t += step) {
        const auto f = fit_trajectory(run, a, b, t, g1_nm_s, sigma_w, sigma_th);
        ts.push_back(t);
        sse.push_back(f.sse);
        if (f.sse < best) {
            best = f.sse;
            best_i = ts.size() - 1;
            best_fit = f;
        }
    }
    if (!std::isfinite(best)) return pr;
    const double dof = static_cast<double>(best_fit.rows) - 3.0;
    const double s2 = scale_by_fit && dof > 0 ? std::max(1.0, best / dof) : 1.0;
    std::size_t lo = best_i, hi = best_i;
    while (lo > 0 && (sse[lo - 1] - best) / s2 <= 1.0) --lo;
    while (hi + 1 < sse.size() && (sse[hi + 1] - best) / s2 <= 1.0) ++hi;
    pr.t_b = ts[best_i];
    pr.se = std::max(0.5 * (ts[hi] - ts[lo]), step);
    pr.g0 = best_fit.g0_nm;
    pr.ok = true;
    return pr;
}

/// Standard error of a mean of correlated values: the spread of means of batches of kBatchSamples.
double batch_means_se(const std::vector<double>& v) {
    constexpr std::size_t kBatchSamples = 10;
    constexpr std::size_t kMinBatches = 3;
    if (v.size() < kBatchSamples * kMinBatches) {
        const Stats st = stats(v);
        return st.n > 1 ? st.sd / std::sqrt(static_cast<double>(st.n)) * std::sqrt(static_cast<double>(kBatchSamples)) : 0.0;
    }
    std::vector<double> means;
    for (std::size_t i = 0; i + kBatchSamples <= v.size(); i += kBatchSamples) {
        double m = 0;
        for (std::size_t k = i; k < i + kBatchSamples; ++k) m += v[k];
        means.push_back(m / static_cast<double>(kBatchSamples));
    }
    const Stats st = stats(means);
    return st.sd / std::sqrt(static_cast<double>(st.n));
}

/// The constant position-mode current demand of the hold that ends at `ramp_start_s`, from the
/// controller law of section 3 step 2 with the shaft stuck (w = 0):
/// I_ref = K_w K_theta (theta_cmd_m - theta_m), averaged over the last kHoldAverageS of the hold
/// (on clean data over the final stretch with zero speed only). Mean and standard error.
Stats hold_demand(const Run& run, double ramp_start_s, bool clean) {
    constexpr double kHoldAverageS = 0.04;
    const double period = run.constants.sample_period_s;
    std::vector<double> v;
    for (const auto& x : run.samples) {
        if (x.t_s > ramp_start_s + kTimeEpsS) break;
        if (x.t_s - period < ramp_start_s - kHoldAverageS - kTimeEpsS) continue;
        if (clean && x.speed_rad_s != 0.0) { v.clear(); continue; }  // only the final stuck stretch
        const double cmd_m = run.constants.tau * x.command_deg * (std::numbers::pi / 180.0);
        v.push_back(kSpeedLoopGainAsPerRad * kPositionLoopGainPerS * (cmd_m - x.theta_m_rad));
    }
    Stats st = stats(v);
    st.sd = st.n > 1 ? st.sd / std::sqrt(static_cast<double>(st.n)) : 0.0;  // now the se of the mean
    return st;
}

/// Expected sample-mean current of the chatter around a demand I_ref that ramps at `ramp_a_s`
/// (away from zero) or holds (0): the 2-cycle centre c decays towards zero at R c / L and jumps
/// by u when it leaves the band I_ref +/- u/2, so the time average over the band is a
/// logarithmic mean (with the ramp, of the band shifted by ramp L / R). Zero inside +/- u/2.
double chatter_mean_current_a(double i_ref_a, double ramp_a_s) {
    const double mag = std::abs(i_ref_a);
    const double u = (kDriveSupplyV - kStatorResistanceOhm * mag) * kCurrentLoopStepS / kStatorInductanceH;
    if (mag <= 0.5 * u) return 0.0;
    const double shift = std::abs(ramp_a_s) * kStatorInductanceH / kStatorResistanceOhm;
    const double lo = mag - 0.5 * u + shift, hi = mag + 0.5 * u + shift;
    const double logmean = (hi - lo) / std::log(hi / lo);
    return (i_ref_a > 0 ? 1.0 : -1.0) * (logmean - shift);
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

std::size_t first_sample_starting_at(const Run& run, double t_s, std::size_t from) {
    const double period = run.constants.sample_period_s;
    for (std::size_t k = from; k < run.samples.size(); ++k) {
        if (run.samples[k].t_s - period >= t_s - kTimeEpsS) return k;
    }
    return run.samples.size();
}

}  // namespace

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

    double ramp_start_s = kBrkFirstHoldS;
    double exact_ramp_start_s = kBrkFirstHoldS;  // clean data: the ramp start of the sequence
    for (int d : {+1, -1}) {
        const std::string dname = d > 0 ? "positive" : "negative";
        BreakawayEvent ev;
        ev.direction = d;
        ev.ramp_first = first_sample_starting_at(run, ramp_start_s, 0);
        const std::size_t init_end = first_sample_starting_at(run, ramp_start_s + kInitialRampFitS, ev.ramp_first);
        if (init_end >= n) {
            out.problems.push_back("no " + dname + " ramp: the run ends before t = " +
                                   std::to_string(ramp_start_s + kInitialRampFitS) + " s");
            break;
        }
        // Ramp line from the first, surely stuck, part of the ramp (slope known: section 5).
        auto intercept_over = [&](std::size_t a, std::size_t b) {
            std::vector<double> v;
            for (std::size_t k = a; k <= b && k < n; ++k) v.push_back(s[k].current_a - d * kBrkRampAPerS * (s[k].t_s - 0.5 * period));
            return stats(v);
        };
        const Stats init = intercept_over(ev.ramp_first, init_end);
        // Ramp end: the position hold takes over and the current leaves the ramp line.
        std::size_t e = n;
        for (std::size_t k = init_end; k < n; ++k) {
            const double line = init.mean + d * kBrkRampAPerS * (s[k].t_s - 0.5 * period);
            if (d * (s[k].current_a - line) < -kRampEndDropA) { e = k; break; }
        }
        ev.ramp_end_sample = e;
        // Load slope for g1 (J dw/dt rises with the ramp and falls with the load).
        std::vector<double> lt, lf;
        const std::size_t a_traj = std::max(ev.ramp_first,
                                            first_sample_starting_at(run, (e < n ? s[e].t_s : s[n - 1].t_s) - kTrajectoryWindowS, 0));
        for (std::size_t k = a_traj; k < e; ++k) {
            lt.push_back(s[k].t_s - 0.5 * period);
            lf.push_back(s[k].hinge_moment_nm / c.tau);
        }
        const Line fr_line = fit_line(lt, lf);
        const double fr_now = fr_line.at(lt.empty() ? 0.0 : lt.back());
        const double c_mid = fr_now * d > 0 ? prior.c_opp_mid : prior.c_aid_mid;
        const double d_abs_fr = (fr_now >= 0 ? 1.0 : -1.0) * fr_line.b;
        const double g1 = d * c.k_t_nm_per_a * kBrkRampAPerS - fr_line.b - d * c_mid * d_abs_fr;
        const std::size_t b_traj = e >= 1 ? e - 1 : 0;

        // 2. Breakaway time.
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
            if (pr.ok && d * pr.g0 > 0) {
                ev.t_breakaway_s = pr.t_b;
                ev.t_breakaway_se_s = pr.se;
                ev.slip_accel_torque_nm = pr.g0;
            } else {
                ev.t_breakaway_s = 0.5 * (lo + hi_t);
                ev.t_breakaway_se_s = period * kUniformSdFactor;
            }
        } else {
            if (e >= n || b_traj < a_traj + 4) {
                out.problems.push_back("no " + dname + " ramp end found: the shaft never moved " +
                                       std::to_string(kBrkMoveRad) + " rad");
                break;
            }
            const double lo = s[a_traj].t_s - period;
            const double hi_t = s[b_traj].t_s - period;
            const auto pr = profile_breakaway(run, a_traj, b_traj, lo, hi_t, g1, sigma_w, sigma_th, true);
            if (!pr.ok) {
                out.problems.push_back("the " + dname + " slip trajectory could not be fitted");
                break;
            }
            ev.method = "trajectory-fit";
            ev.t_breakaway_s = pr.t_b;
            ev.t_breakaway_se_s = pr.se;
            ev.slip_accel_torque_nm = pr.g0;
        }
        std::size_t kb = ev.ramp_first;
        while (kb + 1 < n && s[kb].t_s < ev.t_breakaway_s) ++kb;
        ev.breakaway_sample = kb;

        // 3. Ramp demand at t_b: I_ref(t) = I_start + d ramp_rate (t - t_ramp_start).
        const bool exact_start = d > 0 || out.clean;  // the first ramp starts at a known time
        if (exact_start) {
            // The demand of the hold before the ramp (controller law) and the ramp start time of
            // the sequence (section 5 and 7; the second ramp's start from the exact move end).
            const Stats hold = hold_demand(run, exact_ramp_start_s, out.clean);
            ev.ramp_current_a = hold.mean + d * kBrkRampAPerS * (ev.t_breakaway_s - exact_ramp_start_s);
            ev.ramp_current_se_a = hold.sd;
        } else {
            // Noisy second ramp: fit I_ref(t) = b + d ramp t to the sample-mean currents of the
            // stuck ramp, each corrected for the chatter mean. The deviations are correlated (the
            // chatter aliases with the sampling), so the se uses batch means.
            const std::size_t stuck_last = kb >= 2 ? kb - 2 : ev.ramp_first;
            std::vector<std::size_t> use;
            for (std::size_t k = ev.ramp_first; k <= std::max(stuck_last, ev.ramp_first) && k < n; ++k) use.push_back(k);
            double b = 0;
            std::vector<double> v(use.size());
            for (int it = 0; it < kChatterFitIterations; ++it) {
                for (std::size_t m = 0; m < use.size(); ++m) {
                    const auto& x = s[use[m]];
                    const double i_ref = b + d * kBrkRampAPerS * (x.t_s - 0.5 * period);
                    v[m] = x.current_a - chatter_mean_current_a(i_ref, kBrkRampAPerS) + b;
                }
                b = stats(v).mean;
            }
            ev.ramp_current_a = b + d * kBrkRampAPerS * ev.t_breakaway_s;
            ev.ramp_current_se_a = batch_means_se(v);
        }

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

        // 6. Dynamic friction over the fully slipping samples.
        if (e < n && e >= 2 && kb + 2 + kMinSlipSamples <= e - 1) {
            const std::size_t first = kb + 2, last = e - 2;
            const double cnt = static_cast<double>(last - first + 1);
            ev.dynamic_friction_nm = d * residual_torque_mean_nm(run, first, last);
            ev.slip_samples = last - first + 1;
            const double se_j = c.j_kgm2 * out.sigma_speed_rad_s / (period * cnt);
            const double se_i = c.k_t_nm_per_a * out.sigma_current_a / std::sqrt(cnt);
            const double se_h = out.sigma_hinge_nm / c.tau / std::sqrt(cnt);
            ev.dynamic_friction_se_nm = std::sqrt(se_j * se_j + se_i * se_i + se_h * se_h);
        }
        out.events.push_back(ev);
        if (e >= n) break;
        ramp_start_s = s[e].t_s + kBrkHoldS;
        if (out.clean) {
            // Section 7: the hold starts on the step after the move test, the next ramp after the hold.
            const std::size_t before = ev.ramp_first > 0 ? ev.ramp_first - 1 : 0;
            const auto t_end = move_end_time(run, ev.ramp_first, s[before].theta_m_rad, d);
            if (!t_end) {
                out.problems.push_back("clean data: the " + dname + " ramp end (a move of " +
                                       std::to_string(kBrkMoveRad) + " rad) was not found");
                break;
            }
            exact_ramp_start_s = *t_end + kBrkHoldS;
            ramp_start_s = exact_ramp_start_s;
        }
    }
    return out;
}

}  // namespace emadiag
