#include "discovery/fit_parameter.hpp"

#include "core/emadiag_error.hpp"

#include <array>

namespace emadiag::discovery {
namespace {

/// The sim::Effects names, in the order of FittedEffect.
constexpr std::array<const char*, kFittedEffectCount> kEffectNames = {
    "viscous",       "stribeck_amplitude", "stribeck_speed",     "spall_amplitude", "spall_center",
    "spall_width",   "ripple_amplitude",   "current_gain_error", "hinge_offset",    "true_inertia",
};
static_assert(static_cast<std::size_t>(FittedEffect::TrueInertia) + 1 == kFittedEffectCount);

constexpr std::string_view kTermPrefix = "term:";

}  // namespace

const char* effect_name(FittedEffect e) { return kEffectNames.at(static_cast<std::size_t>(e)); }

std::optional<FittedEffect> fitted_effect(std::string_view name) {
    for (std::size_t i = 0; i < kEffectNames.size(); ++i) {
        if (name == kEffectNames[i]) return static_cast<FittedEffect>(i);
    }
    return std::nullopt;
}

std::string fit_parameter_name(const FitParameter& p) {
    switch (p.kind()) {
        case FitParameter::Kind::Fdj: return "fdj_nm";
        case FitParameter::Kind::EtaO: return "eta_o";
        case FitParameter::Kind::Effect: return effect_name(p.fitted_effect());
        case FitParameter::Kind::Term: return std::string(kTermPrefix) + std::to_string(p.term_index());
    }
    throw EmadiagError("discovery: fit parameter of unknown kind");
}

std::optional<FitParameter> find_fit_parameter(const std::string& name) {
    if (name.size() > kTermPrefix.size() && name.compare(0, kTermPrefix.size(), kTermPrefix) == 0 &&
        name.find_first_not_of("0123456789", kTermPrefix.size()) == std::string::npos) {
        return FitParameter::term(std::stoul(name.substr(kTermPrefix.size())));
    }
    if (name == "fdj_nm") return FitParameter::fdj();
    if (name == "eta_o") return FitParameter::eta_o();
    if (const auto e = fitted_effect(name)) return FitParameter::effect(*e);
    return std::nullopt;
}

FitParameter fit_parameter_from_name(const std::string& name) {
    if (const auto p = find_fit_parameter(name)) return *p;
    throw EmadiagError("discovery: parameter '" + name + "' cannot be fitted");
}

}  // namespace emadiag::discovery
