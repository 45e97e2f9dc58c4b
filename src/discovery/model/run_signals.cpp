#include "discovery/model/run_signals.hpp"

#include "core/residual_torque.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "estimation/physics_friction_law.hpp"
#include "estimation/run_checks.hpp"

#include <cmath>

namespace emadiag::discovery {
namespace {

/// Relative step of the numerical derivative of eq. (4).
constexpr double kEta4StepRel = 1e-6;

int sgn(double v) { return (v > 0) - (v < 0); }

}  // namespace

std::size_t RunSignals::slipping_count() const {
    std::size_t n = 0;
    for (char c : slipping) n += c ? 1 : 0;
    return n;
}

RunSignals run_signals(const Run& run) { return run_signals(check_run(run)); }

RunSignals run_signals(const CheckedRun& checked) { return unchecked_run_signals(checked.run()); }

RunSignals unchecked_run_signals(const Run& run) {
    RunSignals s;
    s.k_t_nm_per_a = run.constants.k_t_nm_per_a;
    s.j_kgm2 = run.constants.j_kgm2;
    s.tau = run.constants.tau;
    s.sample_period_s = run.constants.sample_period_s;
    const std::size_t n = run.samples.size();
    s.accel_rad_s2 = speed_derivative_rad_s2(run);
    s.residual_torque_nm = residual_torque_nm(run);
    for (std::size_t k = 0; k < n; ++k) {
        const auto& x = run.samples[k];
        s.t_s.push_back(x.t_s);
        s.current_a.push_back(x.current_a);
        s.speed_rad_s.push_back(x.speed_rad_s);
        s.theta_m_rad.push_back(x.theta_m_rad);
        s.theta_start_rad.push_back(k == 0 ? x.theta_m_rad - x.speed_rad_s * s.sample_period_s
                                           : run.samples[k - 1].theta_m_rad);
        s.load_torque_nm.push_back(x.hinge_moment_nm / s.tau);
    }
    s.slipping.assign(n, 0);
    for (std::size_t k = 1; k + 1 < n; ++k) {
        const double a = s.speed_rad_s[k - 1], b = s.speed_rad_s[k], c = s.speed_rad_s[k + 1];
        const bool fast = std::abs(a) >= kScreenMinSpeedRadS && std::abs(b) >= kScreenMinSpeedRadS &&
                          std::abs(c) >= kScreenMinSpeedRadS;
        const bool one_sign = sgn(a) == sgn(b) && sgn(b) == sgn(c);
        s.slipping[k] = fast && one_sign ? 1 : 0;
    }
    return s;
}

double friction_law_nm(const RunSignals& s, std::size_t k, double fdj_nm, double eta_o) {
    const double w = s.speed_rad_s[k];
    const double fr = s.load_torque_nm[k];
    const int d = w >= 0 ? 1 : -1;
    const bool opposing = fr * d > 0;
    const double c = opposing ? load_coefficient_opposing(eta_o) : load_coefficient_aiding(eta_o, s.tau);  // eq. (3), (4)
    return d * (fdj_nm + c * std::abs(fr));  // eq. (5)
}

double friction_law_eta_slope_nm(const RunSignals& s, std::size_t k, double eta_o) {
    const double w = s.speed_rad_s[k];
    const double fr = s.load_torque_nm[k];
    const int d = w >= 0 ? 1 : -1;
    const bool opposing = fr * d > 0;
    double dc = 0;
    if (opposing) {
        dc = -1.0 / (eta_o * eta_o);
    } else {
        const double h = kEta4StepRel * eta_o;
        dc = -eta_a_derivative_central(eta_o, s.tau, h);
    }
    return d * dc * std::abs(fr);
}

}  // namespace emadiag::discovery
