#include "estimation/physics_wrls.hpp"

#include "core/emadiag_error.hpp"
#include "core/residual_torque.hpp"
#include "estimation/physics_friction_law.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace emadiag {
namespace {

constexpr double kMadToSigma = 1.4826;
constexpr double kMinScaleNm = 1e-12;
constexpr double kEtaMin = 0.05, kEtaMax = 0.9999;
constexpr double kConvergedStep = 1e-12;

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    const std::size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
    double m = v[mid];
    if (v.size() % 2 == 0) {
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid) - 1, v.end());
        m = 0.5 * (m + v[mid - 1]);
    }
    return m;
}

/// Symmetric 2x2 matrix.
struct Mat2 {
    double a00 = 0, a01 = 0, a11 = 0;
    void add(double w, double x0, double x1) {
        a00 += w * x0 * x0;
        a01 += w * x0 * x1;
        a11 += w * x1 * x1;
    }
    [[nodiscard]] Mat2 inverse() const {
        const double det = a00 * a11 - a01 * a01;
        return Mat2{a11 / det, -a01 / det, a00 / det};
    }
    /// B M B for symmetric B (this) and M, with full 2x2 arithmetic.
    [[nodiscard]] Mat2 sandwich(const Mat2& m) const {
        const double b[2][2] = {{a00, a01}, {a01, a11}};
        const double mm[2][2] = {{m.a00, m.a01}, {m.a01, m.a11}};
        double t[2][2] = {}, out[2][2] = {};
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) t[i][j] += b[i][k] * mm[k][j];
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) out[i][j] += t[i][k] * b[k][j];
        return Mat2{out[0][0], 0.5 * (out[0][1] + out[1][0]), out[1][1]};
    }
};

std::string fmt(double v) {
    std::ostringstream os;
    os.precision(4);
    os << v;
    return os.str();
}

double mad_scale(const std::vector<double>& r) {
    std::vector<double> a(r.size());
    const double m = median(r);
    for (std::size_t i = 0; i < r.size(); ++i) a[i] = std::abs(r[i] - m);
    return kMadToSigma * median(a);
}

}  // namespace

std::vector<SlipWindow> slip_windows(const Run& run) {
    const auto& s = run.samples;
    const auto& c = run.constants;
    const std::size_t n = s.size();
    const auto tr = residual_torque_nm(run);
    const double current_limit_a = (kTorqueLimitNm - kTorqueLimitMarginNm) / c.k_t_nm_per_a;
    auto dir = [&](std::size_t i) {
        const double w = s[i].speed_rad_s;
        return w >= kMinSlipSpeedRadS ? 1 : (w <= -kMinSlipSpeedRadS ? -1 : 0);
    };
    std::vector<int> slip(n, 0);
    for (std::size_t i = 1; i + 1 < n; ++i) {
        const int d = dir(i);
        if (d != 0 && dir(i - 1) == d && dir(i + 1) == d && std::abs(s[i].current_a) <= current_limit_a) slip[i] = d;
    }
    // Step 6 of the header: w4 - w2 at the end of period k, (wbar[k] + wbar[k+1] - wbar[k-1] -
    // wbar[k+2]) / 12; at the ends of the run the stencil is shifted inwards by one sample (the
    // curvature term changes little over a period).
    auto fourth_minus_second = [&](std::size_t k) {
        if (n < 4) return 0.0;
        const std::size_t b = std::clamp<std::size_t>(k, 1, n - 3);
        return (s[b].speed_rad_s + s[b + 1].speed_rad_s - s[b - 1].speed_rad_s - s[b + 2].speed_rad_s) / 12.0;
    };
    std::vector<SlipWindow> out;
    std::size_t segment = 0;
    std::size_t i = 0;
    while (i < n) {
        if (slip[i] == 0) { ++i; continue; }
        std::size_t j = i;
        while (j + 1 < n && slip[j + 1] == slip[i]) ++j;
        // stretch [i, j]; cut into consecutive windows of kWindowSamples (the remainder joins
        // the last one): consecutive windows telescope, so the speed noise of a whole stretch
        // falls as 1 / its length
        const std::size_t len = j - i + 1;
        if (len >= kWindowSamples) {
            const std::size_t count = len / kWindowSamples;
            for (std::size_t k = 0; k < count; ++k) {
                SlipWindow w;
                w.first = i + k * kWindowSamples;
                w.last = k + 1 == count ? j : w.first + kWindowSamples - 1;
                w.direction = slip[i];
                w.segment = segment;
                double ysum = 0, xo = 0, xa = 0;
                for (std::size_t m = w.first; m <= w.last; ++m) {
                    ysum += tr[m];
                    const double fr = s[m].hinge_moment_nm / c.tau;  // F_R = H / tau (section 2)
                    if (fr * w.direction > 0) xo += std::abs(fr); else xa += std::abs(fr);
                }
                const double cnt = static_cast<double>(w.last - w.first + 1);
                w.y_nm = w.direction * ysum / cnt;
                w.x_opp_nm = xo / cnt;
                w.x_aid_nm = xa / cnt;
                // y = d (mean(k_t I - F_R) - J (w_end - w_start) / span), span = t[last] - t[first - 1]
                // (first >= 1: a slipping sample has a neighbour on each side)
                const double span_s = s[w.last].t_s - s[w.first - 1].t_s;
                w.recon_error_nm = w.direction * c.j_kgm2 *
                                   (fourth_minus_second(w.last) - fourth_minus_second(w.first - 1)) / span_s;
                out.push_back(w);
            }
            ++segment;
        }
        i = j + 1;
    }
    return out;
}

namespace {

/// The covariance of (FDJ, eta_O) at the converged fit (fit_friction_wrls): the sandwich with the
/// Huber weights wt, residuals r and eta slopes g, and the reconstruction error's share (step 6b).
/// Also sets res.hac_fallback, res.recon_weighted_windows, res.fdj_recon_se_nm and res.eta_o_recon_se.
Mat2 sandwich_covariance(const std::vector<SlipWindow>& windows, int p, const std::vector<double>& r,
                         const std::vector<double>& wt, const std::vector<double>& g, double scale, WrlsResult& res) {
    const std::size_t n = windows.size();
    // Sandwich covariance, heteroscedasticity and lag-1 autocorrelation consistent within a
    // segment: consecutive windows share a boundary speed, so their residuals are
    // e_i = u_i + v_{i+1} - v_i, and on noise-free runs the boundary errors telescope away.
    Mat2 bread, meat;
    for (std::size_t i = 0; i < n; ++i) bread.add(wt[i], 1.0, g[i]);
    auto add_meat = [&](bool lag1) {
        meat = Mat2{};
        for (std::size_t i = 0; i < n; ++i) {
            const double si0 = wt[i] * r[i], si1 = wt[i] * r[i] * g[i];
            meat.a00 += si0 * si0; meat.a01 += si0 * si1; meat.a11 += si1 * si1;
            if (lag1 && i + 1 < n && windows[i + 1].segment == windows[i].segment) {
                const double sj0 = wt[i + 1] * r[i + 1], sj1 = wt[i + 1] * r[i + 1] * g[i + 1];
                meat.a00 += 2 * si0 * sj0;
                meat.a01 += si0 * sj1 + sj0 * si1;
                meat.a11 += 2 * si1 * sj1;
            }
        }
    };
    const double small_sample = static_cast<double>(n) / static_cast<double>(n - static_cast<std::size_t>(p));
    auto covariance = [&] {
        Mat2 c;
        if (p == 1) {
            c.a00 = meat.a00 / (bread.a00 * bread.a00) * small_sample;
        } else {
            c = bread.inverse().sandwich(meat);
            c.a00 *= small_sample; c.a01 *= small_sample; c.a11 *= small_sample;
        }
        return c;
    };
    add_meat(false);
    const Mat2 cov_lag0 = covariance();
    add_meat(true);
    Mat2 cov = covariance();
    // The lag-1 terms are a noisy estimate: they can make a variance implausibly small (or
    // negative on short runs). Keep each variance at least kMinHacFraction of its lag-0 value.
    res.hac_fallback = cov.a00 < kMinHacFraction * cov_lag0.a00 || (p == 2 && cov.a11 < kMinHacFraction * cov_lag0.a11);
    cov.a00 = std::max(cov.a00, kMinHacFraction * cov_lag0.a00);
    cov.a11 = std::max(cov.a11, kMinHacFraction * cov_lag0.a11);
    // Step 6b: D = sum_i h_i recon_error_i, the move of the estimate under the fourth-order
    // reconstruction at the same weights; |D| / kReconErrorZ in quadrature.
    {
        const Mat2 inv = p == 2 ? bread.inverse() : Mat2{1.0 / bread.a00, 0, 0};
        double d0 = 0, d1 = 0;
        for (std::size_t i = 0; i < n; ++i) {
            d0 += (inv.a00 + inv.a01 * g[i]) * wt[i] * windows[i].recon_error_nm;
            d1 += (inv.a01 + inv.a11 * g[i]) * wt[i] * windows[i].recon_error_nm;
            if (std::abs(windows[i].recon_error_nm) > scale) ++res.recon_weighted_windows;
        }
        res.fdj_recon_se_nm = std::abs(d0) / kReconErrorZ;
        res.eta_o_recon_se = p == 2 ? std::abs(d1) / kReconErrorZ : 0.0;
        cov.a00 += res.fdj_recon_se_nm * res.fdj_recon_se_nm;
        cov.a11 += res.eta_o_recon_se * res.eta_o_recon_se;
    }
    return cov;
}

}  // namespace

WrlsResult fit_friction_wrls(const std::vector<SlipWindow>& windows, double tau) {
    WrlsResult res;
    res.windows = windows.size();
    for (const auto& w : windows) res.samples += w.last - w.first + 1;
    if (windows.size() < kMinWindows) {
        throw EmadiagError("too few slipping samples: " + std::to_string(res.samples) + " in " +
                           std::to_string(windows.size()) + " windows of " + std::to_string(kWindowSamples) +
                           "; need at least " + std::to_string(kMinWindows) + " windows (samples with |speed| >= " +
                           std::to_string(kMinSlipSpeedRadS) + " rad/s and |k_t I| below T_max)");
    }
    const std::size_t n = windows.size();
    const auto prior = load_coefficient_prior(tau);
    double fr_min = std::numeric_limits<double>::infinity(), fr_max = -fr_min;
    for (const auto& w : windows) {
        fr_min = std::min(fr_min, w.x_opp_nm + w.x_aid_nm);
        fr_max = std::max(fr_max, w.x_opp_nm + w.x_aid_nm);
    }
    res.fr_spread_nm = fr_max - fr_min;

    // Model value and Jacobian at (fdj, eta_o).
    auto predict = [&](double fdj, double eta, std::size_t i) {
        return fdj + load_coefficient_opposing(eta) * windows[i].x_opp_nm +
               load_coefficient_aiding(eta, tau) * windows[i].x_aid_nm;
    };
    auto d_eta = [&](double eta, std::size_t i) {
        return -windows[i].x_opp_nm / (eta * eta) - eta_a_derivative(eta, tau) * windows[i].x_aid_nm;
    };

    // Identifiability from the unweighted, column-scaled Jacobian at the prior middle: the
    // condition number of a two-column matrix with unit columns is sqrt((1 + |cos|) / (1 - |cos|)).
    {
        double s11 = 0, s12 = 0, s22 = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const double g = d_eta(prior.eta_o_mid, i);
            s11 += 1.0;
            s12 += g;
            s22 += g * g;
        }
        const double cosine = s22 > 0 ? std::abs(s12) / std::sqrt(s11 * s22) : 1.0;
        res.condition_number = cosine < 1.0 ? std::sqrt((1.0 + cosine) / (1.0 - cosine))
                                            : std::numeric_limits<double>::infinity();
    }
    res.eta_identifiable = res.condition_number <= kMaxConditionNumber && res.fr_spread_nm >= kMinFrSpreadNm;
    if (!res.eta_identifiable) {
        res.why_not_identifiable = "not identifiable: |F_R| spread " + fmt(res.fr_spread_nm) + " N m (need >= " +
                                   fmt(kMinFrSpreadNm) + "), condition number " + fmt(res.condition_number) +
                                   " (need <= " + fmt(kMaxConditionNumber) + ")";
    }

    const int p = res.eta_identifiable ? 2 : 1;
    double fdj = 0, eta = prior.eta_o_mid;
    {
        double acc = 0;
        for (std::size_t i = 0; i < n; ++i) acc += windows[i].y_nm - predict(0, eta, i);
        fdj = acc / static_cast<double>(n);
    }
    std::vector<double> r(n), wt(n, 1.0), g(n, 0.0);  // residual, Huber weight, d y / d eta
    auto update_residuals = [&] {
        for (std::size_t i = 0; i < n; ++i) {
            r[i] = windows[i].y_nm - predict(fdj, eta, i);
            g[i] = p == 2 ? d_eta(eta, i) : 0.0;
        }
    };
    double scale = 0;
    for (int it = 0; it < kMaxIterations; ++it) {
        update_residuals();
        scale = std::max(mad_scale(r), kMinScaleNm);
        for (std::size_t i = 0; i < n; ++i) {
            // Step 6a: the window's error sd is max(s, |recon_error|); Huber on the residual in
            // units of that sd, times the inverse-variance factor s^2 / sd^2.
            const double sd = std::max(scale, std::abs(windows[i].recon_error_nm));
            const double u = std::abs(r[i]) / (kHuberK * sd);
            wt[i] = (u <= 1 ? 1.0 : 1.0 / u) * (scale / sd) * (scale / sd);
        }
        // Weighted Gauss-Newton step: (J^T W J) step = J^T W r, J = [1, g].
        Mat2 a;
        double b0 = 0, b1 = 0;
        for (std::size_t i = 0; i < n; ++i) {
            a.add(wt[i], 1.0, g[i]);
            b0 += wt[i] * r[i];
            b1 += wt[i] * g[i] * r[i];
        }
        double step0 = 0, step1 = 0;
        if (p == 2) {
            const Mat2 inv = a.inverse();
            step0 = inv.a00 * b0 + inv.a01 * b1;
            step1 = inv.a01 * b0 + inv.a11 * b1;
        } else {
            step0 = b0 / a.a00;
        }
        fdj += step0;
        if (p == 2) eta = std::clamp(eta + step1, kEtaMin, kEtaMax);
        if (std::hypot(step0, step1) < kConvergedStep) break;
    }
    update_residuals();
    res.residual_scale_nm = scale;
    Mat2 cov = sandwich_covariance(windows, p, r, wt, g, scale, res);
    res.fdj_se_nm = std::sqrt(std::max(0.0, cov.a00));
    const double eta_var = cov.a11;
    res.fdj_nm = fdj;
    if (p == 2) {
        res.eta_o = eta;
        res.eta_o_se = std::sqrt(std::max(0.0, eta_var));
    } else {
        // FDJ absorbed c |F_R| at the prior middle; the uniform confound goes into its se.
        double fr_mean = 0;
        for (const auto& w : windows) fr_mean += w.x_opp_nm + w.x_aid_nm;
        fr_mean /= static_cast<double>(n);
        res.fdj_se_nm = uniform_plus_gaussian_se(prior.c_half_width * fr_mean, res.fdj_se_nm);
        res.eta_o = prior.eta_o_mid;
        res.eta_o_se = 0;
    }
    res.eta_a = 1.0 - load_coefficient_aiding(res.eta_o, tau);
    res.eta_a_se = std::abs(eta_a_derivative(res.eta_o, tau)) * res.eta_o_se;  // delta method on eq. (4)
    return res;
}

}  // namespace emadiag
