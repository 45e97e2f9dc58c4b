// GCC 12 reports false -Wmaybe-uninitialized inside Eigen's AVX-512 kernels (matrix-vector product).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include "discovery/effect_screen.hpp"

#include "core/emadiag_error.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace emadiag::discovery {
namespace {

/// A candidate column that is (numerically) inside the span of the base columns is skipped.
constexpr double kMinResidualColumnFraction = 1e-8;

std::string fmt(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
}

}  // namespace

ScreenResult screen_effects(const RunSignals& s, const ScreenInput& in) {
    std::vector<std::size_t> rows;
    for (std::size_t k = 0; k < s.size() && k < in.mask.size(); ++k) {
        if (in.mask[k]) rows.push_back(k);
    }
    const std::size_t n = rows.size();
    if (n < kMinScreenSamples) {
        throw EmadiagError("discovery: " + std::to_string(n) + " comparison samples (slipping in the run and the "
                           "model); at least " + std::to_string(kMinScreenSamples) + " are needed");
    }
    // Windows of up to kScreenWindowSamples consecutive comparison samples; each row of the
    // regression is a window SUM (least squares on window means weighted by n_i^2).
    std::vector<std::vector<std::size_t>> windows;
    for (std::size_t i = 0; i < n; ++i) {
        if (windows.empty() || windows.back().size() == kScreenWindowSamples || rows[i] != windows.back().back() + 1) {
            windows.emplace_back();
        }
        windows.back().push_back(rows[i]);
    }
    const auto ni = static_cast<Eigen::Index>(windows.size());
    double weight_sum = 0;  // sum of n_i^2: RSS / weight_sum is a mean square of window means
    for (const auto& w : windows) weight_sum += static_cast<double>(w.size() * w.size());
    auto window_sums = [&](const std::vector<double>& full) {
        Eigen::VectorXd v(ni);
        for (Eigen::Index i = 0; i < ni; ++i) {
            double sum = 0;
            for (std::size_t k : windows[static_cast<std::size_t>(i)]) sum += full[k];
            v(i) = sum;
        }
        return v;
    };
    const auto p = static_cast<Eigen::Index>(in.base_columns.size());
    Eigen::MatrixXd x0(ni, p);
    const Eigen::VectorXd y = window_sums(in.residual_nm);
    for (Eigen::Index j = 0; j < p; ++j) x0.col(j) = window_sums(in.base_columns[static_cast<std::size_t>(j)]);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(x0);
    const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(ni, p);
    const Eigen::VectorXd e0 = y - q * (q.transpose() * y);
    const double rss0 = e0.squaredNorm();
    const double dn = static_cast<double>(ni);

    ScreenResult out;
    out.samples = n;
    out.windows = windows.size();
    out.base_rms_nm = std::sqrt(rss0 / weight_sum);
    for (EffectKind kind : candidate_kinds()) {
        const bool taken = std::find(in.exclude.begin(), in.exclude.end(), kind) != in.exclude.end();
        if (taken) continue;
        CandidateEvidence best;
        best.shape.kind = kind;
        double best_drss = -1;
        bool best_sign_ok = false;
        double best_sxx = 0;
        const auto grid = shape_grid(kind, s);
        const std::size_t grid_size = std::max<std::size_t>(1, grid.size());
        for (const auto& shape : grid) {
            Eigen::VectorXd x = window_sums(signature(s, shape));
            const double sxx_raw = x.squaredNorm();
            x -= q * (q.transpose() * x);
            const double sxx = x.squaredNorm();
            if (!(sxx > kMinResidualColumnFraction * sxx_raw) || sxx_raw == 0) continue;
            const double sxy = x.dot(e0);
            const double b = sxy / sxx;
            const double drss = sxy * sxy / sxx;
            const bool sign_ok = amplitude_sign(kind) == 0 || b > 0;
            // Prefer physically signed fits; among those the largest RSS reduction.
            if ((sign_ok && !best_sign_ok) || (sign_ok == best_sign_ok && drss > best_drss)) {
                best_drss = drss;
                best_sign_ok = sign_ok;
                best_sxx = sxx;
                best.shape = shape;
                best.amplitude = b;
            }
        }
        if (best_drss < 0) continue;  // no usable column (e.g. no spall centre)
        const double rss1 = std::max(rss0 - best_drss, std::numeric_limits<double>::min());
        const double dof = dn - static_cast<double>(p) - 1.0;
        best.amplitude_se = std::sqrt(rss1 / dof / best_sxx);
        best.rss_ratio = rss1 / rss0;
        best.delta_bic = dn * std::log(rss0 / rss1) - (1.0 + scanned_parameters(kind)) * std::log(dn) -
                         2.0 * std::log(static_cast<double>(grid_size));
        best.explained_rms_nm = std::sqrt(best_drss / weight_sum);
        {
            const auto full = signature(s, best.shape);
            double peak = 0;
            for (std::size_t k : rows) peak = std::max(peak, std::abs(full[k]));
            best.peak_torque_nm = std::abs(best.amplitude) * peak;
        }
        best.sign_ok = best_sign_ok;
        if (!best.sign_ok) {
            best.reason = "amplitude " + fmt(best.amplitude) + " has the unphysical sign";
        } else if (best.delta_bic <= kMinDeltaBic) {
            best.reason = "delta BIC " + fmt(best.delta_bic) + " <= " + fmt(kMinDeltaBic);
        } else if (best.peak_torque_nm < kMinEffectPeakNm) {
            best.reason = "peak torque " + fmt(best.peak_torque_nm) + " N m < " + fmt(kMinEffectPeakNm) + " N m";
        } else {
            best.accepted = true;
            best.reason = "delta BIC " + fmt(best.delta_bic) + ", peak torque " + fmt(best.peak_torque_nm) + " N m";
        }
        out.ranking.push_back(best);
    }
    std::sort(out.ranking.begin(), out.ranking.end(), [](const CandidateEvidence& a, const CandidateEvidence& b) {
        if (a.accepted != b.accepted) return a.accepted;
        return a.delta_bic > b.delta_bic;
    });
    return out;
}

}  // namespace emadiag::discovery
