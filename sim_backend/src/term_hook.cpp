#include "term_hook.hpp"

#include <numbers>

namespace emadiag::sim::detail {

bool has_torque_terms(const std::vector<Term>& terms) {
    for (const auto& t : terms) {
        if (t.target == TermTarget::Torque) return true;
    }
    return false;
}

double torque_terms_at(const std::vector<Term>& terms, double w, double theta_m, double theta_u_rad, double f_r,
                       double t, double i) {
    TermInputs x;
    x.w = w;
    x.theta_m = theta_m;
    x.theta_u_deg = theta_u_rad * (180.0 / std::numbers::pi);
    x.f_r = f_r;
    x.t = t;
    x.i = i;
    return sum_terms(terms, TermTarget::Torque, x);
}

void apply_sensor_terms(std::vector<Sample>& samples, const std::vector<Term>& terms, double tau) {
    bool any = false;
    for (const auto& t : terms) any = any || t.target != TermTarget::Torque;
    if (!any) return;
    for (auto& smp : samples) {
        TermInputs x;
        x.w = smp.speed_rad_s;
        x.theta_m = smp.theta_m_rad;
        x.theta_u_deg = smp.theta_m_rad / tau * (180.0 / std::numbers::pi);
        x.f_r = smp.hinge_moment_nm / tau;
        x.t = smp.t_s;
        x.i = smp.current_a;
        smp.current_a += sum_terms(terms, TermTarget::Current, x);
        smp.speed_rad_s += sum_terms(terms, TermTarget::Speed, x);
        smp.theta_m_rad += sum_terms(terms, TermTarget::Theta, x);
        smp.hinge_moment_nm += sum_terms(terms, TermTarget::Hinge, x);
    }
}

}  // namespace emadiag::sim::detail
