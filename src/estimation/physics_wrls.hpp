#pragma once
// Weighted robust least squares on eq. (5) over the slipping samples of a run (issue 4 part 4).
//
// 1. Slipping samples: |w| >= kMinSlipSpeedRadS for the sample and both neighbours, with the same
//    sign (so the central difference of residual_torque.hpp sees a smooth, fully slipping
//    stretch), and |k_t I| at least kTorqueLimitMarginNm below T_max (eq. 7 overstates a clipped
//    torque, section 7).
// 2. Windows: consecutive slipping samples of one direction are cut into windows of
//    kWindowSamples. Each window gives y = d mean(T_R) (the telescoped mean: its derivative noise
//    falls as 1/n) and the regressors x_opp = mean |F_R| over opposing samples, x_aid over aiding
//    ones, so that y = FDJ + c_opp(eta_O) x_opp + c_aid(eta_O) x_aid exactly (eq. 5, eq. 4).
// 3. Gauss-Newton in (FDJ, eta_O) with Huber weights (iteratively reweighted, MAD scale).
// 4. Standard errors: a sandwich, heteroscedasticity and lag-1 autocorrelation consistent within
//    a segment (consecutive windows share a boundary speed: e_i = u_i + v_{i+1} - v_i), with
//    the factor n/(n-p); each variance at least kMinHacFraction of its lag-0 value.
// 5. Identifiability: eta is identifiable only when the condition number of the column-scaled
//    weighted Jacobian is below kMaxConditionNumber and the |F_R| spread over the windows is at
//    least kMinFrSpreadNm. Otherwise eta is fixed at the section-8 prior middle, and FDJ carries
//    the confound c |F_R| in its standard error.
#include "core/run.hpp"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

inline constexpr double kMinSlipSpeedRadS = 20.0;
/// ema-reference.md section 1: motor torque saturation (not among the Run constants).
inline constexpr double kTorqueLimitNm = 4.0;
/// Chatter (0.108 A, section 5) plus margin, as torque: samples closer to T_max are not used.
inline constexpr double kTorqueLimitMarginNm = 0.1;
inline constexpr std::size_t kWindowSamples = 8;
inline constexpr std::size_t kMinWindows = 6;
inline constexpr double kMaxConditionNumber = 200.0;
inline constexpr double kMinFrSpreadNm = 0.05;
inline constexpr double kHuberK = 1.345;
/// Lower bound of a lag-1 (HAC) variance, as a fraction of the lag-0 variance.
inline constexpr double kMinHacFraction = 0.1;
inline constexpr int kMaxIterations = 30;

struct SlipWindow {
    std::size_t first = 0, last = 0;  ///< sample indices, inclusive
    int direction = 0;                ///< +1 / -1
    std::size_t segment = 0;          ///< index of the contiguous slipping stretch
    double y_nm = 0;                  ///< d * mean T_R
    double x_opp_nm = 0;              ///< mean |F_R| over opposing samples (0 for aiding ones)
    double x_aid_nm = 0;              ///< mean |F_R| over aiding samples
};

/// The slipping windows of a run (step 1 and 2 above).
[[nodiscard]] std::vector<SlipWindow> slip_windows(const Run& run);

struct WrlsResult {
    double fdj_nm = 0, fdj_se_nm = 0;
    bool eta_identifiable = false;
    double eta_o = 0, eta_o_se = 0;          ///< fitted, or the prior middle when not identifiable
    double eta_a = 0, eta_a_se = 0;          ///< eq. (4)
    double condition_number = 0;
    double fr_spread_nm = 0;
    double residual_scale_nm = 0;            ///< robust (MAD) scale of the window residuals
    bool hac_fallback = false;               ///< a lag-1 variance was raised to kMinHacFraction of lag 0
    std::size_t windows = 0, samples = 0;
    std::string why_not_identifiable;        ///< empty when identifiable
};

/// Fits eq. (5) to the windows; throws EmadiagError when there are fewer than kMinWindows
/// ("too few slipping samples: N in M windows; need ...").
[[nodiscard]] WrlsResult fit_friction_wrls(const std::vector<SlipWindow>& windows, double tau);

}  // namespace emadiag
