#include "estimation/estimator_id.hpp"

namespace emadiag {
namespace {

constexpr sim::Sequence kSequences[] = {sim::Sequence::Dyn, sim::Sequence::Brk, sim::Sequence::Sweep};

}  // namespace

std::string to_string(const EstimatorId& e) {
    std::string s = to_string(e.method);
    if (e.sequence) s += kEstimatorSequenceSeparator + sim::to_string(*e.sequence);
    return s;
}

std::optional<EstimatorId> parse_estimator_id(std::string_view text) {
    const auto sep = text.find(kEstimatorSequenceSeparator);
    const auto method = estimator_method_of(text);
    if (!method) return std::nullopt;
    if (sep == std::string_view::npos) return EstimatorId{*method, std::nullopt};
    // Exactly the printer's text: the sequence's own lower-case name.
    const std::string_view sequence = text.substr(sep + 1);
    for (const sim::Sequence s : kSequences)
        if (sequence == sim::to_string(s)) return EstimatorId{*method, s};
    return std::nullopt;
}

}  // namespace emadiag
