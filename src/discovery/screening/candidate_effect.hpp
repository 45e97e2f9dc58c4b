#pragma once
// The library of candidate effects (docs/discovery.md "Candidates"): each is an effect the
// datasheet model lacks, with the signature it leaves in the model-consistent residual r of
// run_signals.hpp, computed from the measured signals only:
//
//   effect              sim::Effects fields                    signature x_k (r_k ~ a x_k)
//   viscous             viscous                                w_k                               (a = F_v)
//   stribeck            stribeck_amplitude, stribeck_speed     d exp(-(w_k / w_s)^2)             (a = amplitude; w_s scanned)
//   spall               spall_amplitude, _center, _width       d exp(-((theta_u - c) / s)^2 / 2) (a = amplitude; c, s scanned)
//   ripple              ripple_amplitude, ripple_periods       -mean over the period of sin(p theta_m) (a = amplitude; p scanned)
//   current_gain_error  current_gain_error                     k_t I_k                           (a = e / (1 + e))
//   hinge_offset        hinge_offset                           -1 / tau                          (a = offset, N m surface side)
//   inertia             true_inertia                           dw/dt                             (a = J_true - J)
//
// d = sgn(w). Where they come from (eq. 6 with the sim_backend effects): friction terms add to
// T_F, so to T_R; ripple adds to the motor torque, so it subtracts from T_R; a current gain error
// scales the measured I, so T_R gains e k_t I_true = a k_t I_measured; a hinge offset shifts the
// measured H, so T_R loses offset / tau; an inertia error leaves (J_true - J) dw/dt in T_R.
#include "discovery/model/fit_parameter.hpp"
#include "discovery/model/run_signals.hpp"

#include <string>
#include <utility>
#include <vector>

namespace emadiag::discovery {

enum class EffectKind { Viscous, Stribeck, Spall, Ripple, CurrentGain, HingeOffset, Inertia };

/// One hypothesis: an effect with its scanned shape parameters fixed.
struct EffectShape {
    EffectKind kind = EffectKind::Viscous;
    double shape1 = 0;  ///< stribeck: w_s (rad/s); spall: centre (deg); ripple: periods per rev
    double shape2 = 0;  ///< spall: width (deg)
};

/// Every candidate kind, in the order they are screened.
[[nodiscard]] const std::vector<EffectKind>& candidate_kinds();
/// Short name ("viscous", "stribeck", ...), used in reports.
[[nodiscard]] std::string effect_name(EffectKind kind);
/// Parses a short name; throws EmadiagError listing the known names.
[[nodiscard]] EffectKind parse_effect_name(const std::string& name);
/// The signature formula, as text for reports.
[[nodiscard]] std::string signature_text(EffectKind kind);
/// Number of shape parameters that screening scans (they count in the BIC penalty).
[[nodiscard]] int scanned_parameters(EffectKind kind);
/// The scan grid of shapes for one kind, from the run's signals (e.g. spall centres over the
/// surface angles the run visits).
[[nodiscard]] std::vector<EffectShape> shape_grid(EffectKind kind, const RunSignals& s);
/// The signature x_k of every sample (zero where it is undefined).
[[nodiscard]] std::vector<double> signature(const RunSignals& s, const EffectShape& shape);
/// The amplitude's physical sign constraint: +1 must be > 0, 0 either sign.
[[nodiscard]] int amplitude_sign(EffectKind kind);

/// sim::Effects values (name used by Effects::set, value) of a hypothesis with amplitude a: the
/// fitted ones first, in the order of fitted_sim_effects, then the scanned ones (ripple periods).
[[nodiscard]] std::vector<std::pair<std::string, double>> sim_effects(const EffectShape& shape, double amplitude,
                                                                      double j_kgm2);
/// The signature amplitude of a fitted sim::Effects amplitude value (inverse of sim_effects).
[[nodiscard]] double signature_amplitude(EffectKind kind, double sim_value, double j_kgm2);
/// The sim::Effects a re-simulation fit varies for this kind (amplitude first, then the
/// continuous shape parameters; ripple periods stay at the scanned integer).
[[nodiscard]] std::vector<FittedEffect> fitted_sim_effects(EffectKind kind);
/// A short text of the shape ("w_s = 50 rad/s"), empty for linear candidates.
[[nodiscard]] std::string shape_text(const EffectShape& shape);

/// Field name of sim::Effects for a name used by Effects::set ("viscous" -> "viscous_nm_s_rad"),
/// the key of a term in the model JSON. Throws EmadiagError on an unknown name.
[[nodiscard]] std::string effect_field(const std::string& sim_name);
/// Inverse of effect_field; throws EmadiagError listing the known fields.
[[nodiscard]] std::string effect_sim_name(const std::string& field);

}  // namespace emadiag::discovery
