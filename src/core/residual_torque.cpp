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
        if (!(dt > 0)) throw EmadiagError("time does not increase at sample " + std::to_string(b));
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

}  // namespace emadiag
