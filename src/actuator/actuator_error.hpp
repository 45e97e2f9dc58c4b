#pragma once
// The one exception type of the actuator profiles (issue 23 part 1): a profile that cannot be used,
// or a part number that names no installed profile. Every message starts with "[actuator] " and
// names the file, the field and its value (or the folders searched).
#include <stdexcept>
#include <string>

namespace emadiag::actuator {

class ActuatorError : public std::runtime_error {
public:
    explicit ActuatorError(const std::string& what) : std::runtime_error("[actuator] " + what) {}
};

}  // namespace emadiag::actuator
