#include "discovery/model/model_correction.hpp"

#include "core/emadiag_error.hpp"

#include <cmath>
#include <numbers>

namespace emadiag::discovery {
namespace {

/// Fixed-point iterations of the sensor inversion (a gain error g converges as g^n).
constexpr int kSensorIterations = 6;

sim::Term term_of(const std::string& text) { return sim::parse_term(text); }

std::string num(double v) {
    char b[40];
    std::snprintf(b, sizeof b, "%.10g", v);
    return b;
}

sim::TermInputs inputs(const RunSample& s, double tau) {
    sim::TermInputs x;
    x.w = s.speed_rad_s;
    x.theta_m = s.theta_m_rad;
    x.theta_u_deg = s.theta_m_rad / tau * (180.0 / std::numbers::pi);
    x.f_r = s.hinge_moment_nm / tau;
    x.t = s.t_s;
    x.i = s.current_a;
    return x;
}

}  // namespace

bool is_discovery_model(const nlohmann::json& j) {
    return j.is_object() && j.contains("version") && j.contains("terms") && (j.contains("health") || j.contains("base"));
}

std::string ModelCorrection::text() const {
    std::string s;
    for (const auto& t : terms) s += (s.empty() ? "" : "; ") + t.text();
    if (j_kgm2 > 0) s += (s.empty() ? "" : "; ") + std::string("inertia J = ") + num(j_kgm2) + " kg m^2";
    return s.empty() ? "nothing" : s;
}

ModelCorrection model_correction(const sim::EmaParams& model) {
    const sim::Effects& fx = model.effects;
    if (fx.backlash_rad != 0.0) {
        throw EmadiagError("model: effect backlash (" + num(fx.backlash_rad) +
                           " rad) cannot be removed from a run's samples; the estimators cannot use this model");
    }
    ModelCorrection c;
    if (fx.viscous_nm_s_rad != 0) c.terms.push_back(term_of("torque: " + num(fx.viscous_nm_s_rad) + "*w"));
    // Stribeck: A exp(-(w / w_s)^2) in the direction of motion; gauss(w, 0, s) = exp(-(w / s)^2 / 2).
    if (fx.stribeck_amplitude_nm != 0) {
        c.terms.push_back(term_of("torque: " + num(fx.stribeck_amplitude_nm) + "*sgn(w)*gauss(w, 0, " +
                                  num(fx.stribeck_speed_rad_s / std::numbers::sqrt2) + ")"));
    }
    if (fx.spall_amplitude_nm != 0) {
        c.terms.push_back(term_of("torque: " + num(fx.spall_amplitude_nm) + "*sgn(w)*gauss(theta_u, " +
                                  num(fx.spall_center_deg) + ", " + num(fx.spall_width_deg) + ")"));
    }
    // Ripple adds to the motor torque: as a load it is its negative; sin(theta_m, P) = sin(2 pi theta_m / P).
    if (fx.ripple_amplitude_nm != 0) {
        c.terms.push_back(term_of("torque: " + num(-fx.ripple_amplitude_nm) + "*sin(theta_m, " +
                                  num(2.0 * std::numbers::pi / fx.ripple_periods_per_rev) + ")"));
    }
    if (fx.current_gain_error != 0) c.terms.push_back(term_of("current: " + num(fx.current_gain_error) + "*I"));
    if (fx.hinge_offset_nm != 0) c.terms.push_back(term_of("hinge: " + num(fx.hinge_offset_nm)));
    c.j_kgm2 = fx.true_inertia_kgm2;
    for (const auto& t : model.terms) c.terms.push_back(t);
    return c;
}

Run remove_model_effects(const Run& run, const ModelCorrection& correction) {
    const double tau = run.constants.tau;
    const double k_t = run.constants.k_t_nm_per_a;
    if (!(tau > 0) || !(k_t > 0)) {
        throw EmadiagError("model: the run's constants (tau, k_t) are needed to remove the model's terms");
    }
    Run out = run;
    if (correction.j_kgm2 > 0) out.constants.j_kgm2 = correction.j_kgm2;
    bool sensors = false, torque = false;
    for (const auto& t : correction.terms) (t.target == sim::TermTarget::Torque ? torque : sensors) = true;
    for (auto& s : out.samples) {
        if (sensors) {
            // measured = true + term(true): iterate true = measured - term(true).
            const RunSample measured = s;
            for (int it = 0; it < kSensorIterations; ++it) {
                const sim::TermInputs x = inputs(s, tau);
                s.current_a = measured.current_a - sim::sum_terms(correction.terms, sim::TermTarget::Current, x);
                s.speed_rad_s = measured.speed_rad_s - sim::sum_terms(correction.terms, sim::TermTarget::Speed, x);
                s.theta_m_rad = measured.theta_m_rad - sim::sum_terms(correction.terms, sim::TermTarget::Theta, x);
                s.hinge_moment_nm = measured.hinge_moment_nm - sim::sum_terms(correction.terms, sim::TermTarget::Hinge, x);
            }
        }
        if (torque) s.current_a -= sim::sum_terms(correction.terms, sim::TermTarget::Torque, inputs(s, tau)) / k_t;
        for (const double v : {s.current_a, s.speed_rad_s, s.theta_m_rad, s.hinge_moment_nm}) {
            if (!std::isfinite(v)) {
                throw EmadiagError("model: removing its terms gives a value that is not finite at t = " + num(s.t_s) + " s");
            }
        }
    }
    return out;
}

}  // namespace emadiag::discovery
