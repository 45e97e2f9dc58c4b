#include "estimation/health_parameter.hpp"

namespace emadiag {

const char* to_string(HealthParameter p) {
    switch (p) {
        case HealthParameter::Fdj: return kParamFdj;
        case HealthParameter::Fsj: return kParamFsj;
        case HealthParameter::EtaO: return kParamEtaO;
        case HealthParameter::EtaA: return kParamEtaA;
    }
    return "?";
}

std::optional<HealthParameter> parse_health_parameter(std::string_view name) {
    for (const HealthParameter p : kHealthParameters)
        if (name == to_string(p)) return p;
    return std::nullopt;
}

}  // namespace emadiag
