#pragma once
// The simulator's hook for terms as data (terms.hpp): the extra torque of the torque terms at one
// step (the scalar path, and each lane of the batched path with that lane's terms), and the sensor
// terms on the reported samples.
#include "emadiag/sim/simulator.hpp"
#include "emadiag/sim/terms.hpp"

#include <vector>

namespace emadiag::sim::detail {

/// True when some term acts on the torque balance.
[[nodiscard]] bool has_torque_terms(const std::vector<Term>& terms);
/// T_x (N m, motor side) of the torque terms at one step: speed w, motor angle theta_m, surface
/// angle theta_u_rad (load side, radians: converted to degrees here), load torque f_r, time t, current i.
[[nodiscard]] double torque_terms_at(const std::vector<Term>& terms, double w, double theta_m, double theta_u_rad,
                                     double f_r, double t, double i);
/// torque_terms_at for `lanes` lanes at once (terms[l] null: no terms, 0), with the same result per
/// lane bit for bit: the periodic factors of all lanes are gathered and their sin/cos evaluated side
/// by side (term_eval.hpp), then each lane's sum is formed as sum_terms forms it.
void torque_terms_lanes(int lanes, const std::vector<Term>* const* terms, const double* w, const double* theta_m,
                        const double* theta_u_rad, const double* f_r, double t, const double* i, double* out);
/// Adds the current/speed/theta/hinge terms to the samples, each evaluated on the true sample.
void apply_sensor_terms(std::vector<Sample>& samples, const std::vector<Term>& terms, double tau);

}  // namespace emadiag::sim::detail
