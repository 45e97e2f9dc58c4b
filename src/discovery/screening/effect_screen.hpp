#pragma once
// Screening the candidate effects against the torque residual (docs/discovery.md "Selection").
// Over the comparison samples (resimulation.hpp comparison_mask), the residual
//   r = T_R,measured - T_R,model                     (eq. 7 on both; the model re-simulated)
// summed over windows of up to kScreenWindowSamples consecutive samples (least squares on window
// means weighted by n_i^2: the derivative noise of eq. 7 telescopes in a window mean and falls as
// 1/n_i, residual_torque.hpp) is regressed on the base columns (dT_R,model/dFDJ and dT_R,model/deta_O by re-simulation, and the
// signatures of effects already in the model) plus ONE candidate signature x (candidate_effect.hpp,
// computed from the measured signals: the first-order change of T_R the effect makes). With RSS_0
// without and RSS_1 with x:
//   delta_BIC = n ln(RSS_0 / RSS_1) - (1 + m) ln n - 2 ln G
// (Schwarz 1978; m = scanned shape parameters; G = shapes scanned: the best of G fits is a maximum
// of G likelihood ratios, and 2 ln G is the Bonferroni allowance for it in the same chi-square units)
// with n the number of windows. A candidate is accepted when delta_BIC > kMinDeltaBic, its amplitude has the physical sign, and
// the largest torque it makes on the compared samples, |a| max|x_k|, is at least kMinEffectPeakNm:
// below that the effect does not matter for the actuator's health (it is 6 % of the datasheet FDJ).
#include "discovery/screening/candidate_effect.hpp"
#include "discovery/model/run_signals.hpp"

#include <string>
#include <optional>
#include <vector>

namespace emadiag::discovery {

/// Consecutive comparison samples summed into one regression row.
inline constexpr std::size_t kScreenWindowSamples = 8;
/// Bayesian information criterion gain needed to accept a candidate.
inline constexpr double kMinDeltaBic = 0.0;
/// Smallest peak torque (N m, motor side) an accepted effect must make on the compared samples.
inline constexpr double kMinEffectPeakNm = 0.005;
/// Fewest comparison samples discovery works with.
inline constexpr std::size_t kMinScreenSamples = 60;

struct ScreenInput {
    std::vector<double> residual_nm;                ///< r per sample (measured T_R - model T_R)
    std::vector<std::vector<double>> base_columns;  ///< per sample, each
    std::vector<char> mask;                         ///< the samples used
    std::vector<EffectKind> exclude;                ///< kinds already in the model
};

struct CandidateEvidence {
    EffectShape shape;               ///< the best shape of this kind
    double amplitude = 0;            ///< coefficient of the signature
    double amplitude_se = 0;         ///< its standard error (OLS, residual scale of the full fit)
    double delta_bic = 0;
    double explained_rms_nm = 0;     ///< sqrt((RSS_0 - RSS_1) / sum n_i^2), N m
    double rss_ratio = 1;            ///< RSS_1 / RSS_0
    double peak_torque_nm = 0;       ///< |amplitude| max |x_k| over the compared samples
    bool sign_ok = true;
    bool accepted = false;           ///< passes the criterion (the best one that passes is added)
    std::string reason;              ///< why it was or was not accepted
};

struct ScreenResult {
    std::size_t samples = 0;
    std::size_t windows = 0;
    double base_rms_nm = 0;          ///< RMS of the window means of r after the base columns
    std::vector<CandidateEvidence> ranking;  ///< accepted first, then best delta_BIC first
};

/// Screens every candidate kind not excluded. Throws EmadiagError naming the count and
/// kMinScreenSamples when the mask holds too few samples.
[[nodiscard]] ScreenResult screen_effects(const RunSignals& measured, const ScreenInput& in);

/// The screening's least squares at one shape only: its amplitude and standard error on the residual
/// of `in` after the base columns (accepted, sign, BIC and peak are not judged). nullopt when the
/// shape's column is inside the base's span.
[[nodiscard]] std::optional<CandidateEvidence> evidence_at(const RunSignals& measured, const ScreenInput& in,
                                                           const EffectShape& shape);

}  // namespace emadiag::discovery
