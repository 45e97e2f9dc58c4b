#pragma once
// Sparse selection over the generated term library (issue 10 part 1; docs/discovery.md "Open
// world"), on the same window sums of the torque residual as the library screening
// (effect_screen.hpp). One block of terms is selected per round (greedy forward selection: the
// block of largest likelihood gain, the others wait for the next round with it in the base; the
// re-simulation fit then refits all coefficients together and drops a term that falls below the
// effect-size floor: sequential thresholding as in STLSQ). The best block must pass all of:
//   - delta_BIC = n ln(RSS_0/RSS_1) - (k + m) ln n - 2 ln G > 0, G the number of shapes in the whole
//     generated library (Bonferroni for taking the best of G);
//   - block-time cross-validation: kCvFolds contiguous folds of windows; the prediction error on the
//     held-out folds falls with the block (cv_gain > 0);
//   - stability under subsampling: in at least kMinStability of kStabilityResamples moving-block
//     bootstrap resamples of the windows, the family still passes the BIC (with the Bonferroni
//     allowance) and no other family beats it by more than kStabilityTie, unless that family is
//     equivalent to it (kEquivalentR2);
//   - parsimony: of the families equivalent to the best within kParsimonyBic of its delta BIC, the
//     one with the fewest factors is the best (it names the physics: friction ~ F_R^2, not
//     ~ |theta_u| F_R^2 where the load follows the deflection);
//   - peak torque |sum b_j x_j| >= kMinEffectPeakNm on the compared samples.
#include "discovery/screening/effect_screen.hpp"
#include "discovery/screening/term_library.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag::discovery {

inline constexpr int kCvFolds = 5;
inline constexpr int kStabilityResamples = 24;
inline constexpr std::size_t kStabilityBlockWindows = 8;
inline constexpr double kMinStability = 0.6;
/// Penalised log-likelihood units by which another family may beat the best in a resample.
inline constexpr double kStabilityTie = 2.0;
/// Two families are equivalent on a run when each one's columns reproduce the other's fitted
/// contribution to at least this R^2 (after the model's columns); a resample won by an equivalent
/// family counts for the best.
inline constexpr double kEquivalentR2 = 0.95;
/// Among equivalent families within this delta BIC of the best (no evidence between them: Kass and
/// Raftery's "not worth more than a bare mention"), the one with the fewest factors leads.
inline constexpr double kParsimonyBic = 2.0;

struct GenericEvidence {
    std::string family;
    std::vector<sim::Term> terms;      ///< the best shape, coefficients from the screening least squares
    std::vector<double> se;            ///< their standard errors
    double delta_bic = 0;
    double explained_rms_nm = 0;       ///< sqrt((RSS_0 - RSS_1) / sum n_i^2)
    double rss_ratio = 1;
    double peak_torque_nm = 0;
    double cv_gain = 0;                ///< 1 - CV error with / CV error without (checked for the best only)
    double stability = 0;              ///< fraction of resamples this family wins (best only)
    bool checked = false;              ///< CV and stability computed
    bool accepted = false;
    std::string reason;
};

struct GenericScreen {
    std::size_t shapes = 0;            ///< G
    std::vector<GenericEvidence> ranking;  ///< best delta_BIC first (one per family)
};

/// Screens every family of `lib` against the residual and base columns of `in`; the best one gets
/// the cross-validation and stability checks. Deterministic (the resampling is seeded).
[[nodiscard]] GenericScreen screen_generated(const RunSignals& s, const ScreenInput& in,
                                             const std::vector<TermFamily>& lib, std::uint64_t seed = 1);

/// Factors of a block's most complex term (the parsimony of the screening and of the hypotheses).
[[nodiscard]] std::size_t term_degree(const std::vector<sim::Term>& terms);

/// A periodic basis (sin or cos): its parameter a is the period.
[[nodiscard]] bool is_period_basis(const sim::TermFactor& f);
/// The period factor of a periodic block (sin/cos of an angle), or nullptr.
[[nodiscard]] const sim::TermFactor* period_factor(const sim::Term& t);

/// Library scan steps are 1.26 (motor angle) to 1.33 (surface angle): the refinement covers one
/// step either side on a grid this many times finer.
inline constexpr double kPeriodRefineSpan = 1.4;
inline constexpr int kPeriodRefinePoints = 41;

/// A periodic block's period refined on a grid finer than the library's scan, on the same torque
/// residual and criterion (twice: over kPeriodRefineSpan, then over one step of that grid). The scan's
/// period can be off by half a step; the fit then leaves a beat in the residual that a second periodic
/// term patches (the same effect named twice), or a phase error growing over the travel that reads as
/// a position drift. Returns the block unchanged when it is not periodic or no finer period does better.
[[nodiscard]] std::vector<sim::Term> refine_period(const RunSignals& s, const ScreenInput& in, const GenericEvidence& best,
                                                   std::uint64_t seed);

}  // namespace emadiag::discovery
