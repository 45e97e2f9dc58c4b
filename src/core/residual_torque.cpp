#include "core/residual_torque.hpp"

#include "core/emadiag_error.hpp"

namespace emadiag {

std::vector<double> speed_derivative_rad_s2(const Run& run) {
    const auto& s = run.samples;
    const std::size_t n = s.size();
    std::vector<double> d(n, 0.0);
    if (n < 2) return d;
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t a = i == 0 ? 0 : i - 1;
        const std::size_t b = i + 1 < n ? i + 1 : n - 1;
        const double dt = s[b].t_s - s[a].t_s;
        if (!(dt > 0)) throw EmadiagError("time does not increase at sample row " + std::to_string(b + 1));
        d[i] = (s[b].speed_rad_s - s[a].speed_rad_s) / dt;
    }
    return d;
}

std::vector<double> residual_torque_nm(const Run& run) {
    const auto dw = speed_derivative_rad_s2(run);
    const auto& c = run.constants;
    std::vector<double> tr(run.samples.size());
    for (std::size_t i = 0; i < tr.size(); ++i) {
        const auto& s = run.samples[i];
        tr[i] = c.k_t_nm_per_a * s.current_a - c.j_kgm2 * dw[i] - s.hinge_moment_nm / c.tau;  // eq. (7)
    }
    return tr;
}

double residual_torque_mean_nm(const Run& run, std::size_t first, std::size_t last) {
    const auto& s = run.samples;
    if (first > last || last >= s.size()) {
        throw EmadiagError("residual torque window [" + std::to_string(first) + ", " + std::to_string(last) +
                           "] is outside the run's " + std::to_string(s.size()) + " samples");
    }
    const auto& c = run.constants;
    double sum = 0;
    for (std::size_t i = first; i <= last; ++i) sum += c.k_t_nm_per_a * s[i].current_a - s[i].hinge_moment_nm / c.tau;
    // Sum of the central differences of speed_derivative_rad_s2 over first..last (it telescopes).
    const std::size_t n_all = s.size();
    double dsum = 0;
    for (std::size_t i = first; i <= last; ++i) {
        const std::size_t a = i == 0 ? 0 : i - 1;
        const std::size_t b = i + 1 < n_all ? i + 1 : n_all - 1;
        const double dt = s[b].t_s - s[a].t_s;
        if (!(dt > 0)) throw EmadiagError("time does not increase at sample row " + std::to_string(b + 1));
        dsum += (s[b].speed_rad_s - s[a].speed_rad_s) / dt;
    }
    const double n = static_cast<double>(last - first + 1);
    return sum / n - c.j_kgm2 * dsum / n;  // eq. (7), averaged
}

}  // namespace emadiag
