#include "core/run_summary.hpp"

#include "core/residual_torque.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

namespace emadiag {
namespace {
std::optional<double> median(std::vector<double> v) {
    if (v.empty()) return std::nullopt;
    const std::size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
    if (v.size() % 2 == 1) return v[mid];
    const double hi = v[mid];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid) - 1, v.end());
    return 0.5 * (hi + v[mid - 1]);
}
}  // namespace

RunSummary summarise(const Run& run) {
    RunSummary out;
    out.samples = run.samples.size();
    if (run.samples.empty()) return out;
    const auto tr = residual_torque_nm(run);
    std::vector<double> down, up;
    out.min_surface_deg = out.max_surface_deg = run.samples[0].theta_m_rad / run.constants.tau * 180.0 / std::numbers::pi;
    int last_sign = 0;
    double last_nonzero_t = 0;
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const auto& s = run.samples[i];
        out.peak_current_a = std::max(out.peak_current_a, std::abs(s.current_a));
        const double deg = s.theta_m_rad / run.constants.tau * 180.0 / std::numbers::pi;
        out.min_surface_deg = std::min(out.min_surface_deg, deg);
        out.max_surface_deg = std::max(out.max_surface_deg, deg);
        if (s.speed_rad_s < -kPlateauSpeedRadS) down.push_back(tr[i]);
        if (s.speed_rad_s > kPlateauSpeedRadS) up.push_back(tr[i]);
        const int sign = (s.speed_rad_s > 0) - (s.speed_rad_s < 0);
        if (sign != 0) {
            if (last_sign != 0 && sign != last_sign && !out.reversal_s) out.reversal_s = {last_nonzero_t, s.t_s};
            last_sign = sign;
            last_nonzero_t = s.t_s;
        }
    }
    out.tr_plateau_down_nm = median(down);
    out.tr_plateau_up_nm = median(up);
    return out;
}

std::string format_summary(const RunSummary& s) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os << "samples                : " << s.samples << '\n';
    if (s.reversal_s) {
        os.precision(4);
        os << "speed reversal         : between t = " << s.reversal_s->first << " s and " << s.reversal_s->second << " s\n";
    } else {
        os << "speed reversal         : none\n";
    }
    os.precision(3);
    os << "peak current           : " << s.peak_current_a << " A\n";
    os << "surface angle          : " << s.min_surface_deg << " .. " << s.max_surface_deg << " deg\n";
    os.precision(4);
    auto plateau = [&](const char* label, const std::optional<double>& v) {
        os << label;
        if (v) os << *v << " N m\n"; else os << "n/a (never that fast)\n";
    };
    plateau("T_R plateau moving down: ", s.tr_plateau_down_nm);
    plateau("T_R plateau moving up  : ", s.tr_plateau_up_nm);
    return os.str();
}

}  // namespace emadiag
