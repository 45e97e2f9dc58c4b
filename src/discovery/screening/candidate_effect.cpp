#include "discovery/screening/candidate_effect.hpp"
#include "discovery/screening/screen_windows.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

namespace emadiag::discovery {
namespace {

/// Stribeck speeds scanned: geometric from kStribeckMinRadS to kStribeckMaxRadS.
constexpr double kStribeckMinRadS = 5.0;
constexpr double kStribeckMaxRadS = 400.0;
constexpr int kStribeckGridPoints = 19;
/// Spall centres are scanned over the surface angles the run visits, this far apart.
constexpr double kSpallCentreStepDeg = 0.25;
/// Spall widths (1 sigma, surface angle) scanned.
constexpr double kSpallWidthsDeg[] = {0.25, 0.5, 1.0, 2.0, 4.0};
/// Ripple periods per motor revolution scanned (integers).
constexpr int kRippleMaxPeriods = 12;
/// Below this phase advance over a period, the period mean of sin is the value at the middle.
constexpr double kRippleMinPhaseRad = 1e-6;

struct FieldName {
    const char* sim_name;
    const char* field;
};
/// sim::Effects::set names and the struct fields (sim_backend/include/emadiag/sim/ema_params.hpp).
constexpr FieldName kFieldNames[] = {
    {"viscous", "viscous_nm_s_rad"},
    {"stribeck_amplitude", "stribeck_amplitude_nm"},
    {"stribeck_speed", "stribeck_speed_rad_s"},
    {"backlash", "backlash_rad"},
    {"spall_amplitude", "spall_amplitude_nm"},
    {"spall_center", "spall_center_deg"},
    {"spall_width", "spall_width_deg"},
    {"ripple_amplitude", "ripple_amplitude_nm"},
    {"ripple_periods", "ripple_periods_per_rev"},
    {"current_gain_error", "current_gain_error"},
    {"hinge_offset", "hinge_offset_nm"},
    {"true_inertia", "true_inertia_kgm2"},
};

double surface_deg(const RunSignals& s, std::size_t k) {
    return 0.5 * (s.theta_start_rad[k] + s.theta_m_rad[k]) / s.tau * 180.0 / std::numbers::pi;
}

}  // namespace

const std::vector<EffectKind>& candidate_kinds() {
    static const std::vector<EffectKind> kinds = {EffectKind::Viscous,     EffectKind::Stribeck,
                                                  EffectKind::Spall,       EffectKind::Ripple,
                                                  EffectKind::CurrentGain, EffectKind::HingeOffset,
                                                  EffectKind::Inertia};
    return kinds;
}

std::string effect_name(EffectKind kind) {
    switch (kind) {
        case EffectKind::Viscous: return "viscous";
        case EffectKind::Stribeck: return "stribeck";
        case EffectKind::Spall: return "spall";
        case EffectKind::Ripple: return "ripple";
        case EffectKind::CurrentGain: return "current_gain_error";
        case EffectKind::HingeOffset: return "hinge_offset";
        case EffectKind::Inertia: return "inertia";
    }
    return "?";
}

EffectKind parse_effect_name(const std::string& name) {
    std::string known;
    for (EffectKind k : candidate_kinds()) {
        if (effect_name(k) == name) return k;
        known += (known.empty() ? "" : ", ") + effect_name(k);
    }
    throw EmadiagError("unknown candidate effect '" + name + "'; known: " + known);
}

std::string signature_text(EffectKind kind) {
    switch (kind) {
        case EffectKind::Viscous: return "w";
        case EffectKind::Stribeck: return "sgn(w) exp(-(w/w_s)^2), w_s scanned";
        case EffectKind::Spall: return "sgn(w) exp(-((theta_u - c)/s)^2 / 2), c and s scanned";
        case EffectKind::Ripple: return "-mean_period sin(p theta_m), p scanned";
        case EffectKind::CurrentGain: return "k_t I";
        case EffectKind::HingeOffset: return "-1/tau";
        case EffectKind::Inertia: return "dw/dt";
    }
    return "?";
}

int scanned_parameters(EffectKind kind) {
    switch (kind) {
        case EffectKind::Stribeck: return 1;
        case EffectKind::Spall: return 2;
        case EffectKind::Ripple: return 1;
        default: return 0;
    }
}

int amplitude_sign(EffectKind kind) {
    switch (kind) {
        case EffectKind::Viscous:
        case EffectKind::Stribeck:
        case EffectKind::Spall:
        case EffectKind::Ripple: return 1;
        default: return 0;
    }
}

std::vector<EffectShape> shape_grid(EffectKind kind, const RunSignals& s) {
    std::vector<EffectShape> g;
    switch (kind) {
        case EffectKind::Stribeck:
            for (int i = 0; i < kStribeckGridPoints; ++i) {
                const double f = static_cast<double>(i) / (kStribeckGridPoints - 1);
                g.push_back({kind, kStribeckMinRadS * std::pow(kStribeckMaxRadS / kStribeckMinRadS, f), 0});
            }
            break;
        case EffectKind::Spall: {
            double lo = 0, hi = 0;
            bool any = false;
            for (std::size_t k = 0; k < s.size(); ++k) {
                if (!s.slipping[k]) continue;
                const double a = surface_deg(s, k);
                lo = any ? std::min(lo, a) : a;
                hi = any ? std::max(hi, a) : a;
                any = true;
            }
            if (!any) break;
            for (double c = std::ceil(lo / kSpallCentreStepDeg) * kSpallCentreStepDeg; c <= hi; c += kSpallCentreStepDeg) {
                for (double w : kSpallWidthsDeg) g.push_back({kind, c, w});
            }
            break;
        }
        case EffectKind::Ripple:
            for (int p = 1; p <= kRippleMaxPeriods; ++p) g.push_back({kind, static_cast<double>(p), 0});
            break;
        default: g.push_back({kind, 0, 0});
    }
    return g;
}

std::vector<double> signature(const RunSignals& s, const EffectShape& shape) {
    std::vector<double> x(s.size(), 0.0);
    for (std::size_t k = 0; k < s.size(); ++k) {
        const double w = s.speed_rad_s[k];
        const double d = w >= 0 ? 1.0 : -1.0;
        switch (shape.kind) {
            case EffectKind::Viscous: x[k] = w; break;
            case EffectKind::Stribeck: {
                const double r = w / shape.shape1;
                x[k] = d * std::exp(-r * r);
                break;
            }
            case EffectKind::Spall: {
                const double z = (surface_deg(s, k) - shape.shape1) / shape.shape2;
                x[k] = d * std::exp(-0.5 * z * z);
                break;
            }
            case EffectKind::Ripple: {
                // Period mean of sin(p theta) for theta moving linearly over the period.
                const double p = shape.shape1;
                const double a = p * s.theta_start_rad[k], b = p * s.theta_m_rad[k];
                const double m = std::abs(b - a) < kRippleMinPhaseRad ? std::sin(0.5 * (a + b))
                                                                      : (std::cos(a) - std::cos(b)) / (b - a);
                x[k] = -m;
                break;
            }
            case EffectKind::CurrentGain: x[k] = s.k_t_nm_per_a * s.current_a[k]; break;
            case EffectKind::HingeOffset: x[k] = -1.0 / s.tau; break;
            case EffectKind::Inertia: x[k] = s.accel_rad_s2[k]; break;
        }
    }
    return x;
}

std::vector<std::pair<std::string, double>> sim_effects(const EffectShape& shape, double amplitude, double j_kgm2) {
    switch (shape.kind) {
        case EffectKind::Viscous: return {{"viscous", amplitude}};
        case EffectKind::Stribeck: return {{"stribeck_amplitude", amplitude}, {"stribeck_speed", shape.shape1}};
        case EffectKind::Spall:
            return {{"spall_amplitude", amplitude}, {"spall_center", shape.shape1}, {"spall_width", shape.shape2}};
        case EffectKind::Ripple: return {{"ripple_amplitude", amplitude}, {"ripple_periods", shape.shape1}};
        case EffectKind::CurrentGain: return {{"current_gain_error", amplitude / (1.0 - amplitude)}};
        case EffectKind::HingeOffset: return {{"hinge_offset", amplitude}};
        case EffectKind::Inertia: return {{"true_inertia", j_kgm2 + amplitude}};
    }
    return {};
}

double signature_amplitude(EffectKind kind, double sim_value, double j_kgm2) {
    switch (kind) {
        case EffectKind::CurrentGain: return sim_value / (1.0 + sim_value);
        case EffectKind::Inertia: return sim_value - j_kgm2;
        default: return sim_value;
    }
}

std::vector<FittedEffect> fitted_sim_effects(EffectKind kind) {
    switch (kind) {
        case EffectKind::Viscous: return {FittedEffect::Viscous};
        case EffectKind::Stribeck: return {FittedEffect::StribeckAmplitude, FittedEffect::StribeckSpeed};
        case EffectKind::Spall: return {FittedEffect::SpallAmplitude, FittedEffect::SpallCenter, FittedEffect::SpallWidth};
        case EffectKind::Ripple: return {FittedEffect::RippleAmplitude};
        case EffectKind::CurrentGain: return {FittedEffect::CurrentGainError};
        case EffectKind::HingeOffset: return {FittedEffect::HingeOffset};
        case EffectKind::Inertia: return {FittedEffect::TrueInertia};
    }
    return {};
}

std::string shape_text(const EffectShape& shape) {
    switch (shape.kind) {
        case EffectKind::Stribeck: return "w_s = " + fmt4(shape.shape1) + " rad/s";
        case EffectKind::Spall: return "centre " + fmt4(shape.shape1) + " deg, width " + fmt4(shape.shape2) + " deg";
        case EffectKind::Ripple: return "p = " + fmt4(shape.shape1) + " per rev";
        default: return {};
    }
}

std::string effect_field(const std::string& sim_name) {
    for (const auto& f : kFieldNames) {
        if (sim_name == f.sim_name) return f.field;
    }
    throw EmadiagError("unknown effect '" + sim_name + "'");
}

std::string effect_sim_name(const std::string& field) {
    std::string known;
    for (const auto& f : kFieldNames) {
        if (field == f.field) return f.sim_name;
        known += (known.empty() ? "" : ", ") + std::string(f.field);
    }
    throw EmadiagError("unknown effect field '" + field + "'; known: " + known);
}

}  // namespace emadiag::discovery
