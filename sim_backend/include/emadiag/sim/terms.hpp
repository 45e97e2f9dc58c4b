#pragma once
// Terms as data (issue 10 part 2): an extra torque on the motor shaft, or an error of a measured
// signal, written as a coefficient times a product of basis functions of named signals. The
// simulator evaluates them during integration (torque) or on the reported samples (sensors), so a
// model found by discovery, or an effect injected by a test, needs no code in the simulator.
//
//   term    := [target ":"] [coefficient ["*"]] factor ("*" factor)*     (no factor: a constant)
//   target  := torque | current | speed | theta | hinge                   (default torque)
//   factor  := SIGNAL | abs(SIGNAL) | sgn(SIGNAL) | sq(SIGNAL)
//            | sin(SIGNAL, P) | cos(SIGNAL, P)          sin(2 pi x / P), period P in x's units
//            | gauss(SIGNAL, c, s)                      exp(-((x - c) / s)^2 / 2)
//            | step(SIGNAL, x0)                         1 for x >= x0, else 0
//   SIGNAL  := w (motor speed, rad/s) | theta_m (motor angle, rad) | theta_u (surface angle, deg)
//            | F_R (load torque H / tau, motor side, N m) | t (s) | I (motor current, A)
//
// torque:  T_x (N m, motor side) acts like a load: T_act = T_M - F_R - T_x. A term with sgn(w) is
//          friction-like (it opposes the motion and vanishes at rest).
// current, speed, theta, hinge: the reported sample is the true one plus the term, evaluated on
//          the true signals of the sample (e.g. "current: 0.05" is a current-sensor offset of
//          0.05 A; "speed: 0.03*w" a speed-sensor gain error of 3 %; "theta: 0.02*t" a drift).
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::sim {

enum class TermTarget { Torque, Current, Speed, Theta, Hinge };
enum class TermSignal { Speed, ThetaMotor, ThetaSurface, LoadTorque, Time, Current };
enum class TermBasis { Identity, Abs, Sgn, Square, Sin, Cos, Gauss, Step };

struct TermFactor {
    TermBasis basis = TermBasis::Identity;
    TermSignal signal = TermSignal::Speed;
    double a = 0;  ///< sin/cos: period; gauss: centre; step: threshold
    double b = 0;  ///< gauss: width (1 sigma)
};

struct Term {
    TermTarget target = TermTarget::Torque;
    double coefficient = 0;
    double std_error = 0;  ///< uncertainty of the coefficient (0: exact, e.g. injected)
    std::vector<TermFactor> factors;

    /// The product of the factors (without the coefficient); the text form is parse_term's.
    [[nodiscard]] std::string basis_text() const;
    [[nodiscard]] std::string text() const;  ///< "torque: 0.02*sgn(w)*abs(theta_u)"
};

/// The signals a term reads, at one integration step or one sample.
struct TermInputs {
    double w = 0, theta_m = 0, theta_u_deg = 0, f_r = 0, t = 0, i = 0;
};

[[nodiscard]] std::string to_string(TermTarget t);
[[nodiscard]] std::string to_string(TermSignal s);
/// The product of the factors at `x`.
[[nodiscard]] double term_basis(const Term& term, const TermInputs& x);
/// coefficient * basis.
[[nodiscard]] inline double term_value(const Term& term, const TermInputs& x) {
    return term.coefficient * term_basis(term, x);
}
/// Sum of the terms with this target.
[[nodiscard]] double sum_terms(const std::vector<Term>& terms, TermTarget target, const TermInputs& x);

/// Parses the text form; throws SimError naming the position and what was expected.
[[nodiscard]] Term parse_term(const std::string& text);
/// {"target", "basis" (text of the factors), "coefficient", "std_error"}.
[[nodiscard]] nlohmann::json to_json(const Term& term);
/// Reads to_json's form (or a string in the text form); throws SimError naming `where`.
[[nodiscard]] Term term_from_json(const nlohmann::json& j, const std::string& where);
/// Throws SimError when a coefficient or parameter is not finite, or a period or width is not > 0.
void validate_term(const Term& term, const std::string& where);

}  // namespace emadiag::sim
