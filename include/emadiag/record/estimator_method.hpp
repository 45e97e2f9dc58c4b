#pragma once
// The method of an estimate or a finding (physics or network), and the text a finding's estimator
// is stored as in the maintenance record: "METHOD" or "METHOD:SEQUENCE" ("physics:dyn").
// Header-only and in the lowest layer, because the record (maintenance_db), which keeps only the
// physics findings as measurements, sits below estimation; estimation/estimator_id.hpp adds the
// sequence (a sim::Sequence) and parses the whole text with the method parser below.
#include <optional>
#include <string>
#include <string_view>

namespace emadiag {

enum class EstimatorMethod { Physics, Network };

/// Between the method and the sequence in a finding's stored estimator text.
inline constexpr char kEstimatorSequenceSeparator = ':';

/// "physics" or "network".
[[nodiscard]] inline std::string to_string(EstimatorMethod m) { return m == EstimatorMethod::Physics ? "physics" : "network"; }

/// The one parser of a method's text; nullopt for any other text.
[[nodiscard]] inline std::optional<EstimatorMethod> parse_estimator_method(std::string_view text) {
    for (const EstimatorMethod m : {EstimatorMethod::Physics, EstimatorMethod::Network})
        if (text == to_string(m)) return m;
    return std::nullopt;
}

/// The method part of a stored estimator text ("physics:dyn" -> Physics, "network" -> Network);
/// nullopt when that part is not a method. The sequence part is estimation's to read.
[[nodiscard]] inline std::optional<EstimatorMethod> estimator_method_of(std::string_view text) {
    return parse_estimator_method(text.substr(0, text.find(kEstimatorSequenceSeparator)));
}

}  // namespace emadiag
