// The helpers the stages share: library effect names, the model's health values, a term.
#include "discovery/stages/context.hpp"

#include <algorithm>

namespace emadiag::discovery::pipeline {

HealthValue* find_health(std::vector<HealthValue>& v, const char* name) {
    for (auto& h : v) {
        if (h.name == name) return &h;
    }
    return nullptr;
}

const HealthValue* find_health(const std::vector<HealthValue>& v, const char* name) {
    for (const auto& h : v) {
        if (h.name == name) return &h;
    }
    return nullptr;
}

std::string library_effect_text(EffectKind kind) {
    switch (kind) {
        case EffectKind::Viscous: return "viscous friction";
        case EffectKind::Stribeck: return "Stribeck friction (extra friction at low speed)";
        case EffectKind::Spall: return "localised friction (spall)";
        case EffectKind::Ripple: return "motor torque ripple";
        case EffectKind::CurrentGain: return "current sensor gain error";
        case EffectKind::HingeOffset: return "hinge-moment sensor offset";
        case EffectKind::Inertia: return "inertia off the datasheet";
    }
    return "?";
}

sim::Term make_term(sim::TermTarget target, double coefficient, std::vector<sim::TermFactor> factors) {
    sim::Term t;
    t.target = target;
    t.coefficient = coefficient;
    t.factors = std::move(factors);
    return t;
}

bool steps_added(const DiscoveryReport& rep) {
    return std::any_of(rep.steps.begin(), rep.steps.end(), [](const DiscoveryStep& st) { return st.added || !st.added_terms.empty(); });
}

}  // namespace emadiag::discovery::pipeline
