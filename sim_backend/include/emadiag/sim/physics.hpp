#pragma once
// The physics facts of the reference actuator and of the paper, each defined once here and read
// everywhere else (issue 22 part 3):
//   - the EMA-REF-1 datasheet (ema-reference.md section 1), which EmaParams' defaults read;
//   - the load of the ground cases A and A-ext (section 4);
//   - the health-parameter envelope of section 8;
//   - the load coefficient c of the friction law (paper eq. 5).
// Eq. (4) and its inverse are sim::eta_a_from_eta_o / eta_o_from_eta_a (ema_params.hpp); its
// derivative is emadiag::eta_a_derivative (src/estimation/physics_friction_law.hpp).
// The lowest layer: every library (estimation, discovery, diagnosis, bench) may include it.

namespace emadiag::sim {

/// The EMA-REF-1 datasheet, ema-reference.md section 1 (SI units, motor side).
namespace ema_ref_1 {
inline constexpr double kVdcV = 270.0;
inline constexpr double kROhm = 1.0;
inline constexpr double kLH = 2.5e-3;
inline constexpr double kKtNmPerA = 0.2;
inline constexpr double kIMaxA = 20.0;
inline constexpr double kTMaxNm = 4.0;
inline constexpr double kWMaxRadS = 838.0;
inline constexpr double kJKgm2 = 1.65e-4;
inline constexpr double kTau = 800.0;
inline constexpr double kKThetaPerS = 30.0;
inline constexpr double kKwASPerRad = 0.25;
inline constexpr double kStopDeg = 25.0;
inline constexpr double kFdjNm = 0.08;
inline constexpr double kFsjNm = 0.12;
inline constexpr double kEtaO = 0.85;
/// eq. (4) with kTau, as the datasheet writes it (rounded to 6 places; EmaParams::datasheet()
/// computes the exact image of kEtaO).
inline constexpr double kEtaA = 0.823788;
inline constexpr double kDtS = 1e-6;
}  // namespace ema_ref_1

/// Section 4, case A: the constant hinge moment (the residual weight moment of a mass-balanced
/// elevator), surface side.
inline constexpr double kCaseAHingeNm = 5.0;
/// Section 4, extended case A: the ground rig ramps the load, H = kCaseAHingeNm + rate * t.
inline constexpr double kAExtHingeRateNmPerS = 1990.0;

/// Section 8: each health parameter varies within +/- this fraction of its nominal value.
inline constexpr double kHealthSpread = 0.20;
/// Section 8 ranges as the datasheet writes them (rounded): eta_A is uniform in
/// [0.659031, 0.988546]; eta_O follows from eq. (4). (The dataset's health_range computes the
/// unrounded ends, nominal * (1 -/+ kHealthSpread).)
inline constexpr double kPriorEtaAMin = 0.659031;
inline constexpr double kPriorEtaAMax = 0.988546;
/// Section 8 ranges of FDJ and FSJ (N m).
inline constexpr double kPriorFdjMinNm = 0.064, kPriorFdjMaxNm = 0.096;
inline constexpr double kPriorFsjMinNm = 0.096, kPriorFsjMaxNm = 0.144;

/// Eq. (5): the load coefficient c of the friction law, T_F = FDJ + c |F_R| (FSJ when static).
/// Opposing load (F_R d > 0): c = 1/eta_O - 1.
[[nodiscard]] inline double load_coefficient_opposing(double eta_o) { return 1.0 / eta_o - 1.0; }
/// Aiding load: c = 1 - eta_A.
[[nodiscard]] inline double load_coefficient_aiding(double eta_a) { return 1.0 - eta_a; }

}  // namespace emadiag::sim
