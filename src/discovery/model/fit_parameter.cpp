#include "discovery/model/fit_parameter.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <vector>

namespace emadiag::discovery {
namespace {

/// The sim::Effects names, in the order of FittedEffect.
constexpr std::array<const char*, kFittedEffectCount> kEffectNames = {
    "viscous",       "stribeck_amplitude", "stribeck_speed",     "spall_amplitude", "spall_center",
    "spall_width",   "ripple_amplitude",   "current_gain_error", "hinge_offset",    "true_inertia",
};
static_assert(static_cast<std::size_t>(FittedEffect::TrueInertia) + 1 == kFittedEffectCount);

constexpr std::string_view kTermPrefix = "term:";

/// Range and finite-difference step of each fittable parameter.
struct ParamSpec {
    double lo, hi;
    double step_abs;  ///< finite-difference step floor
};

/// An effect fitted by discovery: its finite-difference step floor and, where the fit must stay
/// inside the simulator's range (sim::Effects::range, the one definition), the lower end and why.
struct EffectFit {
    FittedEffect effect;
    double step_abs;
    double fit_lo;  ///< NaN: the simulator's lower end
};
constexpr double kSimulatorLo = std::numeric_limits<double>::quiet_NaN();
/// In the order of FittedEffect.
constexpr EffectFit kEffectFits[] = {
    {FittedEffect::Viscous, 1e-7, kSimulatorLo},
    {FittedEffect::StribeckAmplitude, 2e-3, kSimulatorLo},
    // the simulator takes 1e-6 rad/s; a fit starts at its 1 rad/s step, so a step never leaves the range
    {FittedEffect::StribeckSpeed, 1.0, 1.0},
    {FittedEffect::SpallAmplitude, 2e-3, kSimulatorLo},
    {FittedEffect::SpallCenter, 0.02, kSimulatorLo},
    // the simulator takes 1e-6 deg; a fit keeps 2.5 of its 0.02 deg steps above zero
    {FittedEffect::SpallWidth, 0.02, 0.05},
    {FittedEffect::RippleAmplitude, 2e-3, kSimulatorLo},
    {FittedEffect::CurrentGainError, 2e-4, kSimulatorLo},
    {FittedEffect::HingeOffset, 0.5, kSimulatorLo},
    // the simulator reads 0 as "the datasheet J"; a fitted inertia is one step above it
    {FittedEffect::TrueInertia, 1e-7, 1e-7},
};
static_assert(std::size(kEffectFits) == kFittedEffectCount);

constexpr ParamSpec kFdjSpec = {0.0, 10.0, 2e-4};
constexpr ParamSpec kEtaOSpec = {0.3, 0.9999, 2e-3};  // below 1: eq. (4) gives eta_A = 1 at eta_O = 1, outside the simulator range
/// Coefficients of sim::Term entries (FitParameter::term): any value; the fit's step is relative
/// with this floor.
constexpr ParamSpec kTermSpec = {-1e12, 1e12, 1e-12};

const ParamSpec& effect_spec(FittedEffect effect) {
    static const std::vector<ParamSpec> all = [] {
        std::vector<ParamSpec> v;
        for (const auto& e : kEffectFits) {
            const sim::Effects::Range r = sim::Effects::range(effect_name(e.effect));
            v.push_back({std::isnan(e.fit_lo) ? r.min : e.fit_lo, r.max, e.step_abs});
        }
        return v;
    }();
    return all.at(static_cast<std::size_t>(effect));
}

const ParamSpec& spec(const FitParameter& parameter) {
    switch (parameter.kind()) {
        case FitParameter::Kind::Fdj: return kFdjSpec;
        case FitParameter::Kind::EtaO: return kEtaOSpec;
        case FitParameter::Kind::Effect: return effect_spec(parameter.fitted_effect());
        case FitParameter::Kind::Term: return kTermSpec;
    }
    throw EmadiagError("discovery: parameter '" + fit_parameter_name(parameter) + "' cannot be fitted");
}

std::size_t term_index(const FitParameter& parameter, const sim::EmaParams& p) {
    const std::size_t k = parameter.term_index();
    if (k >= p.terms.size()) {
        throw EmadiagError("discovery: parameter '" + fit_parameter_name(parameter) + "': the model has " +
                           std::to_string(p.terms.size()) + " terms");
    }
    return k;
}

}  // namespace

const char* effect_name(FittedEffect e) { return kEffectNames.at(static_cast<std::size_t>(e)); }

std::string fit_parameter_name(const FitParameter& p) {
    switch (p.kind()) {
        case FitParameter::Kind::Fdj: return "fdj_nm";
        case FitParameter::Kind::EtaO: return "eta_o";
        case FitParameter::Kind::Effect: return effect_name(p.fitted_effect());
        case FitParameter::Kind::Term: return std::string(kTermPrefix) + std::to_string(p.term_index());
    }
    throw EmadiagError("discovery: fit parameter of unknown kind");
}

FitRange fit_range(const FitParameter& parameter) {
    const ParamSpec& s = spec(parameter);
    return {s.lo, s.hi};
}

double fit_step_floor(const FitParameter& parameter) { return spec(parameter).step_abs; }

std::vector<std::string> fitted_effect_names() {
    std::vector<std::string> v;
    for (const auto& e : kEffectFits) v.emplace_back(effect_name(e.effect));
    return v;
}

double get_parameter(const sim::EmaParams& p, const FitParameter& parameter) {
    switch (parameter.kind()) {
        case FitParameter::Kind::Term: return p.terms[term_index(parameter, p)].coefficient;
        case FitParameter::Kind::Fdj: return p.fdj_nm;
        case FitParameter::Kind::EtaO: return p.eta_o;
        case FitParameter::Kind::Effect: return p.effects.get(effect_name(parameter.fitted_effect()));
    }
    throw EmadiagError("discovery: parameter '" + fit_parameter_name(parameter) + "' cannot be fitted");
}

void set_parameter(sim::EmaParams& p, const FitParameter& parameter, double value) {
    const ParamSpec& s = spec(parameter);
    value = std::clamp(value, s.lo, s.hi);
    switch (parameter.kind()) {
        case FitParameter::Kind::Term: p.terms[term_index(parameter, p)].coefficient = value; break;
        case FitParameter::Kind::Fdj:
            p.fdj_nm = value;
            p.fsj_nm = std::max(p.fsj_nm, p.fdj_nm);
            break;
        case FitParameter::Kind::EtaO:
            p.eta_o = value;
            p.eta_a = sim::eta_a_from_eta_o(value, p.tau);
            break;
        case FitParameter::Kind::Effect: p.effects.set(effect_name(parameter.fitted_effect()), value); break;
    }
}

}  // namespace emadiag::discovery
