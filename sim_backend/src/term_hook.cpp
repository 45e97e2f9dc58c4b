#include "term_hook.hpp"

#include "term_eval.hpp"

#include <numbers>

namespace emadiag::sim::detail {
namespace {

/// Periodic factors gathered per call of torque_terms_lanes (8 lanes of up to 8 periodic factors);
/// more run lane by lane.
constexpr int kMaxGatheredPeriodic = 64;

TermInputs lane_inputs(double w, double theta_m, double theta_u_rad, double f_r, double t, double i) {
    TermInputs x;
    x.w = w;
    x.theta_m = theta_m;
    x.theta_u_deg = theta_u_rad * (180.0 / std::numbers::pi);
    x.f_r = f_r;
    x.t = t;
    x.i = i;
    return x;
}

}  // namespace

bool has_torque_terms(const std::vector<Term>& terms) {
    for (const auto& t : terms) {
        if (t.target == TermTarget::Torque) return true;
    }
    return false;
}

double torque_terms_at(const std::vector<Term>& terms, double w, double theta_m, double theta_u_rad, double f_r,
                       double t, double i) {
    return sum_terms(terms, TermTarget::Torque, lane_inputs(w, theta_m, theta_u_rad, f_r, t, i));
}

void torque_terms_lanes(int lanes, const std::vector<Term>* const* terms, const double* w, const double* theta_m,
                        const double* theta_u_rad, const double* f_r, double t, const double* i, double* out) {
    double arg[kMaxGatheredPeriodic], sn[kMaxGatheredPeriodic], cs[kMaxGatheredPeriodic];
    int n = 0;
    bool too_many = false;
    for (int l = 0; l < lanes && !too_many; ++l) {
        if (terms[l] == nullptr) continue;
        const TermInputs x = lane_inputs(w[l], theta_m[l], theta_u_rad[l], f_r[l], t, i[l]);
        for (const auto& term : *terms[l]) {
            if (term.target != TermTarget::Torque) continue;
            for (const auto& f : term.factors) {
                if (!is_periodic(f.basis)) continue;
                if (n == kMaxGatheredPeriodic) {
                    too_many = true;
                    break;
                }
                arg[n++] = periodic_argument(f, signal_value(f.signal, x));
            }
        }
    }
    if (too_many) {  // lane by lane
        for (int l = 0; l < lanes; ++l) {
            out[l] = terms[l] == nullptr ? 0.0 : torque_terms_at(*terms[l], w[l], theta_m[l], theta_u_rad[l], f_r[l], t, i[l]);
        }
        return;
    }
    if (n > 0) term_sincos_many(arg, sn, cs, n);
    int k = 0;
    for (int l = 0; l < lanes; ++l) {
        if (terms[l] == nullptr) {
            out[l] = 0.0;
            continue;
        }
        const TermInputs x = lane_inputs(w[l], theta_m[l], theta_u_rad[l], f_r[l], t, i[l]);
        double v = 0.0;  // as sum_terms, term_value and term_basis form it
        for (const auto& term : *terms[l]) {
            if (term.target != TermTarget::Torque) continue;
            double b = 1.0;
            for (const auto& f : term.factors) {
                if (is_periodic(f.basis)) {
                    b *= f.basis == TermBasis::Sin ? sn[k] : cs[k];
                    ++k;
                } else {
                    b *= factor_value(f, signal_value(f.signal, x));
                }
            }
            v += term.coefficient * b;
        }
        out[l] = v;
    }
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
