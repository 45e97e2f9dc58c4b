#pragma once
// The generated term library (issue 10 part 1; docs/discovery.md "Open world"): candidate torque
// terms built from the signals a run carries, not a list of effects. Each candidate is a family of
// terms (emadiag/sim/terms.hpp) with its scanned shapes; a shape is a block of one term, or two for
// a periodic basis (sin and cos: amplitude and phase).
//   products:  monomials of degree 1 and 2 over w, |w|, w^2, theta_u, |theta_u|, F_R, |F_R|, F_R^2, t
//              (different signals), each alone and times sgn(w) (friction-like: degree up to 3);
//   periodic:  sin/cos of theta_u with periods 1 to 40 deg, and of theta_m with periods 8 to 250 rad
//              (wider than the motor's per-revolution ripple), each alone and times sgn(w);
//   bumps:     gauss(theta_u, c, s) over the angles the run visits, s in {0.5, 1, 2, 4} deg.
// Left out because the model or the library already holds them: sgn(w) (FDJ), sgn(w)|F_R| (eta),
// w (viscous), 1 and I (hinge offset, current gain: hypotheses.hpp adds the alternatives),
// sgn(w) gauss (spall), sgn(w) exp(-(w/w_s)^2) (Stribeck), integer ripple per rev.
#include "discovery/model/run_signals.hpp"
#include "emadiag/sim/terms.hpp"

#include <string>
#include <vector>

namespace emadiag::discovery {

struct TermFamily {
    std::string name;                              ///< e.g. "sgn(w)*abs(theta_u)", "sin/cos(theta_u, P)"
    std::vector<std::vector<sim::Term>> shapes;    ///< blocks of torque terms with coefficient 1
    int scanned = 0;                               ///< scanned shape parameters (BIC penalty)
    bool opposes_motion = false;                   ///< friction-like: sgn(w) times a shape (a torque that opposes the motion)
};

/// The generated library for a run (bump centres from the angles it visits).
[[nodiscard]] std::vector<TermFamily> generated_library(const RunSignals& s);
/// Number of shapes over all families (the Bonferroni count of the selection).
[[nodiscard]] std::size_t library_size(const std::vector<TermFamily>& lib);

/// The first-order change of T_R a term makes at every sample, from the measured signals only:
///   torque:  + term (evaluated at the period's mid time, speed and surface angle; averaged over the
///            period when it reads the motor angle, which moves up to 0.4 rad in a period)
///   current: + k_t term      speed: - J d(term)/dt      hinge: - term / tau      theta: 0
[[nodiscard]] std::vector<double> term_signature(const RunSignals& s, const sim::Term& term);

/// The term inputs of sample k (mid-period angles and time).
[[nodiscard]] sim::TermInputs sample_inputs(const RunSignals& s, std::size_t k);

}  // namespace emadiag::discovery
