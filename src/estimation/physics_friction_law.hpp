#pragma once
// The Borello friction law of the paper as the estimators see it (eqs. 2, 3, 5 and 4):
//   slipping in direction d:  d T_R = FDJ + c(d) |F_R|,  c = 1/eta_O - 1 (opposing, F_R d > 0)
//                                                      c = 1 - eta_A   (aiding)
//   breakaway in direction d: d (k_t I - F_R) = FSJ + c(d) |F_R|
// and eta_A from eta_O by eq. (4). Also the prior of section 8 (the +/-20 % ranges) used when the
// data cannot tell eta from FDJ. The constants and c are defined once in emadiag/sim/physics.hpp.
#include "emadiag/sim/physics.hpp"

namespace emadiag {

/// Section 8: eta_A is uniform in [0.659031, 0.988546]; eta_O follows from eq. (4).
using sim::kPriorEtaAMax;
using sim::kPriorEtaAMin;
/// Section 8 ranges of FDJ and FSJ (N m), used only for normalised errors and sanity limits.
using sim::kPriorFdjMaxNm;
using sim::kPriorFdjMinNm;
using sim::kPriorFsjMaxNm;
using sim::kPriorFsjMinNm;

/// Load coefficient c of eq. (5) for an opposing load: 1/eta_O - 1.
using sim::load_coefficient_opposing;
/// Load coefficient for an aiding load: 1 - eta_A, eta_A from eq. (4) with tau.
[[nodiscard]] double load_coefficient_aiding(double eta_o, double tau);
/// d eta_A / d eta_O of eq. (4) (analytic). The one home of this derivative, with the next.
[[nodiscard]] double eta_a_derivative(double eta_o, double tau);
/// d eta_A / d eta_O of eq. (4) by the central difference of step h:
/// (eta_A(eta_O + h) - eta_A(eta_O - h)) / (2 h). Kept beside the analytic form for the callers
/// whose figures were set with it (the two differ in the last bits).
[[nodiscard]] double eta_a_derivative_central(double eta_o, double tau, double h);

/// What the section-8 prior says about c when eta is not identifiable: the mean of c over the
/// eta_A range, and the half-width of its (nearly uniform) spread.
struct LoadCoefficientPrior {
    double eta_o_mid = 0;         ///< eta_O at the middle of the eta_A range
    double c_opp_mid = 0;         ///< c for opposing load at eta_o_mid
    double c_aid_mid = 0;         ///< c for aiding load at eta_o_mid
    double c_half_width = 0;      ///< max over both c of half the range over the prior
};
[[nodiscard]] LoadCoefficientPrior load_coefficient_prior(double tau);

/// A standard error that makes +/-1.96 se cover 95 % of a uniform error of this half-width
/// (0.95 * half_width / 1.96): used for confounds that are uniform, not Gaussian.
[[nodiscard]] double uniform_equivalent_se(double half_width);

/// The standard error s for which +/-1.96 s covers exactly 95 % of U + N, with U uniform on
/// [-half_width, half_width] (an eta confound) and N ~ N(0, gaussian_se^2) (the measurement)
/// independent. The coverage of +/-q is, with G(x) = x Phi(x) + phi(x) the antiderivative of Phi,
///   P(q) = sigma / (2 h) [G((q + h)/sigma) - G((q - h)/sigma) - G((h - q)/sigma) + G(-(q + h)/sigma)],
/// solved for P(q) = 0.95 by bisection. hypot(uniform_equivalent_se(h), sigma) is too small when
/// both parts matter (the sum is more Gaussian than the uniform, whose sd h/sqrt(3) exceeds
/// 0.95 h / 1.96); this is exact, and reduces to both limits.
[[nodiscard]] double uniform_plus_gaussian_se(double half_width, double gaussian_se);

}  // namespace emadiag
