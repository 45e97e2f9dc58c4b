#pragma once
// `--actuator FILE|PART_NUMBER` (issue 23 part 1): where the CLI looks for installed actuator
// profiles, and the profile an argument names (EMA-REF-1 when none is given).
#include "actuator/profile_finder.hpp"

#include <string>
#include <vector>

namespace emadiag::cli {

/// The environment variable that names the profile folder explicitly (it alone counts when set).
inline constexpr const char* kActuatorsDirEnvVar = "EMADIAG_ACTUATORS_DIR";

/// Where installed profiles are looked for, in order (the first that exists counts): only
/// $EMADIAG_ACTUATORS_DIR when set (an error if it is not a folder); else <prefix>/share/emadiag/actuators
/// of an installed binary; else <source>/actuators of a binary in its build tree. Never ./actuators.
[[nodiscard]] std::vector<actuator::ProfileLocation> actuator_locations();

/// The profile `arg` names (a file, or a part number among the installed profiles); an empty `arg`
/// is actuator::kDefaultPartNumber.
[[nodiscard]] actuator::ActuatorProfile load_actuator_option(const std::string& arg);

}  // namespace emadiag::cli
