#pragma once
// Which estimator made an estimate or a finding (ARCHITECTURE.md "seams"): the method, and for a
// session's finding the sequence of the run it came from. Typed between the modules; text only at the
// edges (CLI, JSON, database), through the one printer and the one parser below:
//   method "physics" | "network";  finding "physics:dyn", "network:brk", ...
#include "emadiag/record/estimator_method.hpp"
#include "emadiag/sim/simulator.hpp"

#include <optional>
#include <string>
#include <string_view>

namespace emadiag {

// EstimatorMethod, its printer and its parser: emadiag/record/estimator_method.hpp (the record reads it too).

/// A finding's estimator: the method, and the sequence of the run it came from.
struct EstimatorId {
    EstimatorMethod method = EstimatorMethod::Physics;
    /// Empty only in findings stored before findings named their sequence (the text "physics").
    std::optional<sim::Sequence> sequence;

    bool operator==(const EstimatorId&) const = default;
};

/// "physics:dyn" (method ':' sequence), or the method alone when there is no sequence.
[[nodiscard]] std::string to_string(const EstimatorId& e);
/// The one parser of that text (as the database stores it); nullopt for any other text.
[[nodiscard]] std::optional<EstimatorId> parse_estimator_id(std::string_view text);

}  // namespace emadiag
