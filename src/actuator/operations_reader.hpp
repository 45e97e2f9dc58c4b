#pragma once
// Reads "operations" of a profile (docs/actuator-profile.md): the sequences, the load cases, the
// limits, the priors of the health parameters and the CAN ICD. Internal to src/actuator/.
#include "actuator/actuator_profile.hpp"
#include "actuator/profile_reader.hpp"

namespace emadiag::actuator::detail {

/// Reads root["operations"] into p.operations (after the transmission: field units follow the output).
void read_operations(ProfileReader& r, const nlohmann::json& root, ActuatorProfile& p);

}  // namespace emadiag::actuator::detail
