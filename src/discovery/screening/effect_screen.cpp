#include "discovery/screening/effect_screen.hpp"

#include "discovery/screening/screen_windows.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace emadiag::discovery {

ScreenResult screen_effects(const RunSignals& s, const ScreenInput& in) {
    const WindowedBase wb = windowed_base(s, in);
    const std::vector<std::size_t>& rows = wb.rows;
    const std::size_t n = rows.size();
    const auto ni = static_cast<Eigen::Index>(wb.windows.size());
    const auto p = static_cast<Eigen::Index>(in.base_columns.size());
    const Eigen::MatrixXd& q = wb.q;
    const Eigen::VectorXd& e0 = wb.e0;
    const double rss0 = wb.rss0;
    const double weight_sum = wb.weight_sum;
    const double dn = static_cast<double>(ni);

    ScreenResult out;
    out.samples = n;
    out.windows = wb.windows.size();
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
            Eigen::VectorXd x = wb.window_sums(signature(s, shape));
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
            best.reason = "amplitude " + fmt3(best.amplitude) + " has the unphysical sign";
        } else if (best.delta_bic <= kMinDeltaBic) {
            best.reason = "delta BIC " + fmt3(best.delta_bic) + " <= " + fmt3(kMinDeltaBic);
        } else if (best.peak_torque_nm < kMinEffectPeakNm) {
            best.reason = "peak torque " + fmt3(best.peak_torque_nm) + " N m < " + fmt3(kMinEffectPeakNm) + " N m";
        } else {
            best.accepted = true;
            best.reason = "delta BIC " + fmt3(best.delta_bic) + ", peak torque " + fmt3(best.peak_torque_nm) + " N m";
        }
        out.ranking.push_back(best);
    }
    std::sort(out.ranking.begin(), out.ranking.end(), [](const CandidateEvidence& a, const CandidateEvidence& b) {
        if (a.accepted != b.accepted) return a.accepted;
        return a.delta_bic > b.delta_bic;
    });
    return out;
}

std::optional<CandidateEvidence> evidence_at(const RunSignals& s, const ScreenInput& in, const EffectShape& shape) {
    const WindowedBase wb = windowed_base(s, in);
    Eigen::VectorXd x = wb.window_sums(signature(s, shape));
    const double sxx_raw = x.squaredNorm();
    x = wb.project_out(x);
    const double sxx = x.squaredNorm();
    if (!(sxx > kMinResidualColumnFraction * sxx_raw) || sxx_raw == 0) return std::nullopt;
    const double sxy = x.dot(wb.e0);
    const double dof = static_cast<double>(wb.windows.size()) - static_cast<double>(in.base_columns.size()) - 1.0;
    if (!(dof > 0)) return std::nullopt;
    CandidateEvidence e;
    e.shape = shape;
    e.amplitude = sxy / sxx;
    const double rss1 = std::max(wb.rss0 - sxy * sxy / sxx, std::numeric_limits<double>::min());
    e.amplitude_se = std::sqrt(rss1 / dof / sxx);
    e.rss_ratio = rss1 / wb.rss0;
    return e;
}

}  // namespace emadiag::discovery
