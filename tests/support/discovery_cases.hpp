#pragma once
// The test protocol of open-world discovery (issue 10 part 6): effects injected into simulated runs
// as terms (emadiag/sim/terms.hpp), each with its truth, kept OUT of the discovery code. Discovery
// never sees these definitions; it reads only the run's samples and constants.
//
// Two sets:
// - kDevelopmentCases: used while developing and tuning discovery (thresholds, grids, names).
// - kHeldOutCases: written down before the open-world discovery existed and never used to tune it;
//   they are only run by discovery_bench and reported as they come out.
// Neither set contains an effect of the candidate library as such (viscous, Stribeck, spall, motor
// ripple at an integer period per rev, current gain error, hinge offset, inertia): the library
// effects are drawn separately (library_case()).
//
// A case is named correctly when the report names `expected_name` (a key of the names table,
// discovery/physics_names.hpp) or, for kExpectUnexplained, reports unexplained structure whose
// strongest variable is `expected_variable`. Any other named effect is a wrong name.
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/simulator.hpp"
#include "emadiag/sim/terms.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace emadiag::testcases {

struct InjectedCase {
    const char* id;
    const char* description;
    /// Term text with "{a}" where the drawn magnitude goes (one term per case).
    const char* term_pattern;
    double magnitude_lo, magnitude_hi;  ///< |a| drawn uniformly in this range
    bool random_sign;                   ///< a gets a random sign
    const char* expected_name;          ///< names-table key the report must give (or "" if unexplained)
    /// Unexplained structure counts as correct when it depends most on one of these (comma separated,
    /// trajectory.hpp variable names); "" when only the name is correct (e.g. a constant offset).
    const char* expected_variable;
    sim::Sequence sequence = sim::Sequence::Dyn;
};

inline constexpr const char* kExpectUnexplained = "";

// Development cases: tuning allowed.
inline const std::vector<InjectedCase> kDevelopmentCases = {
    {"dev-quadratic-friction", "friction growing with the square of the speed", "torque: {a}*sgn(w)*sq(w)", 4e-8, 1.2e-7,
     false, "friction_speed_squared", "|w|,w", sim::Sequence::Dyn},
    {"dev-bump-at-zero", "localised torque (no sgn) near 0 deg", "torque: {a}*gauss(theta_u, -1, 1.2)", 0.04, 0.1, true,
     "localised_torque_surface", "theta_u", sim::Sequence::Dyn},
    {"dev-constant-torque", "a constant torque on the shaft (Coulomb asymmetry)", "torque: {a}", 0.02, 0.05, true,
     "constant_torque", "", sim::Sequence::Dyn},
    {"dev-theta-offset", "position sensor offset", "theta: {a}", 0.02, 0.08, true, "theta_sensor_offset", "",
     sim::Sequence::Dyn},
    {"dev-hinge-gain", "hinge-moment sensor gain error", "hinge: {a}*F_R", 40.0, 80.0, true, "hinge_sensor_gain", "F_R",
     sim::Sequence::Dyn},
};

// Held-out cases: never used for tuning.
inline const std::vector<InjectedCase> kHeldOutCases = {
    {"friction-with-deflection", "friction growing with |surface angle|", "torque: {a}*sgn(w)*abs(theta_u)", 0.004,
     0.008, false, "friction_deflection", "|theta_u|,theta_u", sim::Sequence::Dyn},
    {"friction-with-load-squared", "efficiency falling with load: friction ~ F_R^2", "torque: {a}*sgn(w)*sq(F_R)", 0.15,
     0.3, false, "friction_load_squared", "|F_R|,F_R", sim::Sequence::Dyn},
    {"coulomb-asymmetry", "friction higher in one direction (constant torque)", "torque: {a}", 0.025, 0.06, true,
     "constant_torque", "", sim::Sequence::Dyn},
    {"periodic-surface", "position-dependent torque, period 5 deg of surface angle",
     "torque: {a}*sin(theta_u, 5)", 0.03, 0.08, false, "periodic_torque_surface", "theta_u", sim::Sequence::Dyn},
    {"bump", "localised torque bump (not friction) at -6 deg", "torque: {a}*gauss(theta_u, -6, 0.8)", 0.05, 0.12, true,
     "localised_torque_surface", "theta_u", sim::Sequence::Dyn},
    {"speed-sensor-gain", "speed sensor gain error", "speed: {a}*w", 0.02, 0.05, true, "speed_sensor_gain", "w,|w|,dw/dt",
     sim::Sequence::Dyn},
    {"current-offset", "current sensor offset", "current: {a}", 0.08, 0.2, true, "current_sensor_offset", "",
     sim::Sequence::Dyn},
    {"position-drift", "position sensor drift", "theta: {a}*t", 0.04, 0.1, true, "theta_sensor_drift", "t",
     sim::Sequence::Dyn},
    {"friction-over-time", "friction rising during the run (warm-up)", "torque: {a}*sgn(w)*t", 0.08, 0.16, false,
     "friction_time", "t", sim::Sequence::Dyn},
    {"torque-constant-loss", "motor torque constant below the datasheet (a real loss ~ I)", "torque: {a}*I", 0.004,
     0.01, false, "motor_torque_constant", "I", sim::Sequence::Dyn},
    {"periodic-motor-slow", "torque periodic in the motor angle, period 40 rad (6.4 rev)",
     "torque: {a}*cos(theta_m, 40)", 0.03, 0.08, false, "periodic_torque_motor", "", sim::Sequence::Dyn},
    {"friction-speed-load", "friction growing with speed times load", "torque: {a}*w*abs(F_R)", 1e-4, 2.5e-4, false,
     "friction_speed_load", "|F_R|,F_R,w,|w|", sim::Sequence::Dyn},
};

/// Uniform on [lo, hi) from the top 53 bits (the same on every standard library).
inline double uniform(std::mt19937_64& g, double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(g() >> 11) * 0x1.0p-53;
}

/// The term of a case with a drawn magnitude.
inline sim::Term draw_term(const InjectedCase& c, std::mt19937_64& g, double* magnitude = nullptr) {
    double a = uniform(g, c.magnitude_lo, c.magnitude_hi);
    if (c.random_sign && uniform(g, 0, 1) < 0.5) a = -a;
    if (magnitude != nullptr) *magnitude = a;
    std::string text = c.term_pattern;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", a);
    text.replace(text.find("{a}"), 3, buf);
    return sim::parse_term(text);
}

/// A simulation config for a case: DYN case B (or the case's sequence), datasheet health, noise and seed.
inline sim::SimConfig case_config(const InjectedCase& c, const sim::Term& term, sim::NoiseProfile noise,
                                  std::uint64_t seed) {
    sim::SimConfig cfg;
    cfg.load_case = sim::LoadCase::B;
    cfg.sequence = c.sequence;
    cfg.noise = noise;
    cfg.seed = seed;
    cfg.params.terms.push_back(term);
    return cfg;
}

}  // namespace emadiag::testcases
