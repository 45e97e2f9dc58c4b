#pragma once
// The four health parameters of the paper (FDJ, FSJ, eta_O, eta_A), typed between the modules. Their
// names are text only at the edges (CLI, JSON, database), through the one printer and the one parser.
#include <optional>
#include <string_view>

namespace emadiag {

/// Parameter names, in this order everywhere (CLI, JSON, database).
inline constexpr const char* kParamFdj = "FDJ_Nm";
inline constexpr const char* kParamFsj = "FSJ_Nm";
inline constexpr const char* kParamEtaO = "eta_O";
inline constexpr const char* kParamEtaA = "eta_A";

enum class HealthParameter { Fdj, Fsj, EtaO, EtaA };

/// Every parameter, in the order of the kParam* names.
inline constexpr HealthParameter kHealthParameters[] = {HealthParameter::Fdj, HealthParameter::Fsj, HealthParameter::EtaO,
                                                        HealthParameter::EtaA};

/// Their names, in the same order (to_string of each): the list to loop over where a name is wanted.
inline constexpr const char* kHealthParameterNames[] = {kParamFdj, kParamFsj, kParamEtaO, kParamEtaA};

/// The name: kParamFdj, kParamFsj, kParamEtaO or kParamEtaA.
[[nodiscard]] const char* to_string(HealthParameter p);
/// The one parser of a name (exactly a kParam* name); nullopt for any other text.
[[nodiscard]] std::optional<HealthParameter> parse_health_parameter(std::string_view name);

}  // namespace emadiag
