#include "cli/actuator_option.hpp"

#include "actuator/actuator_error.hpp"
#include "core/data_location.hpp"

#include <cstdlib>

namespace emadiag::cli {

std::vector<actuator::ProfileLocation> actuator_locations() {
    if (const char* env = std::getenv(kActuatorsDirEnvVar); env != nullptr && *env != '\0') {
        std::error_code ec;
        if (!std::filesystem::is_directory(env, ec)) {
            throw actuator::ActuatorError(std::string(kActuatorsDirEnvVar) + "=" + env + ": no such folder (the profile folder given explicitly)");
        }
        return {{env, kActuatorsDirEnvVar}};
    }
    std::vector<actuator::ProfileLocation> out;
    if (const auto data = installed_data_dir()) out.push_back({*data / "actuators", "installed"});
    if (const auto src = build_tree_source_dir()) out.push_back({*src / "actuators", "build tree"});
    return out;
}

actuator::ActuatorProfile load_actuator_option(const std::string& arg) {
    return actuator::find_profile(arg.empty() ? std::string(actuator::kDefaultPartNumber) : arg, actuator_locations());
}

}  // namespace emadiag::cli
