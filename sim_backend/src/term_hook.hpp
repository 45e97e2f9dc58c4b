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
/// Adds the current/speed/theta/hinge terms to the samples, each evaluated on the true sample.
void apply_sensor_terms(std::vector<Sample>& samples, const std::vector<Term>& terms, double tau);

}  // namespace emadiag::sim::detail
