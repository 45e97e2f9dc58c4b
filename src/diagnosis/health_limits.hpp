#pragma once
// Serviceability limits of the health parameters: friction at most, efficiency at least. The
// default is the envelope of ema-reference.md section 8 (nominal +/-20 %: FDJ <= 0.096 N m,
// FSJ <= 0.144 N m, eta_A >= 0.659031, eta_O >= its eq. (4) image); the operator's maintenance
// manual sets the real ones in a JSON file (docs/test-run.md).
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag {

enum class LimitKind { Max, Min };

struct ParameterLimit {
    std::string parameter;  ///< kParamFdj, kParamFsj, kParamEtaO or kParamEtaA
    LimitKind kind = LimitKind::Max;
    double limit = 0;       ///< in the parameter's unit (N m for FDJ_Nm / FSJ_Nm)
};

struct HealthLimits {
    std::vector<ParameterLimit> limits;
    std::string source;  ///< "datasheet section 8 envelope" or the file it came from

    /// Nominal +/-20 % of ema-reference.md section 8.
    [[nodiscard]] static HealthLimits datasheet_envelope();
    /// {"FDJ_Nm": {"max": 0.09}, "eta_A": {"min": 0.7}, ...}; parameters left out keep their
    /// datasheet limit. Throws EmadiagError naming the file, the key and the value on anything else
    /// (an unknown parameter, both or neither of max/min, a non-finite or non-positive limit, the
    /// wrong direction such as a minimum on friction, an efficiency above 1, a friction torque above
    /// the motor's T_max, a key repeated in the file).
    [[nodiscard]] static HealthLimits load(const std::string& path);
    [[nodiscard]] static HealthLimits from_json(const nlohmann::json& j, const std::string& where);

    [[nodiscard]] const ParameterLimit* find(const std::string& parameter) const;
    [[nodiscard]] nlohmann::json to_json() const;
};

[[nodiscard]] const char* to_string(LimitKind k);

}  // namespace emadiag
