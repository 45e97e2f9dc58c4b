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
//    Each window also carries an embedded estimate of its reconstruction error (step 6).
// 3. Gauss-Newton in (FDJ, eta_O) with Huber weights (iteratively reweighted, MAD scale s),
//    times a reconstruction-error weight (step 6).
// 4. Standard errors: a sandwich, heteroscedasticity and lag-1 autocorrelation consistent within
//    a segment (consecutive windows share a boundary speed: e_i = u_i + v_{i+1} - v_i), with
//    the factor n/(n-p); each variance at least kMinHacFraction of its lag-0 value. Plus the
//    reconstruction-error term of step 6, in quadrature.
// 5. Identifiability: eta is identifiable only when the condition number of the column-scaled
//    weighted Jacobian is below kMaxConditionNumber and the |F_R| spread over the windows is at
//    least kMinFrSpreadNm. Otherwise eta is fixed at the section-8 prior middle, and FDJ carries
//    the confound c |F_R| in its standard error.
// 6. Reconstruction error (issue 4: calibrated intervals on noise-free runs). Apart from
//    measurement noise, the only error of a window's y is deterministic: y needs the
//    instantaneous speed at the window's two boundaries (the ends of sample periods), and it gets
//    them from period MEANS. With W the integral of w, a period mean is a difference of W on the
//    sample grid, so the speed at the end of period k is dW/dt there, and
//      second order (the value used):  w2_k = (wbar[k] + wbar[k+1]) / 2,          error T^2 w''/6
//      fourth order:                   w4_k = (7 (wbar[k] + wbar[k+1]) - wbar[k-1] - wbar[k+2]) / 12
//    (central differences of W of order 2 and 4; error O(T^4)). As in an embedded Runge-Kutta
//    pair (Fehlberg), their difference estimates the error of the lower-order result:
//      recon_error = d J ((w4 - w2)_end - (w4 - w2)_start) / span   (the error of y, in N m).
//    The value keeps the second-order y: the fourth-order stencil has 39 % more speed-noise
//    variance (100/144 against 1/2 of sigma_w^2 per boundary), which costs accuracy on noisy runs.
//    The estimate is used twice:
//    a. Weighting. A window's error sd is the larger of the residual scale s and |recon_error|,
//       so its weight is multiplied by min(1, s^2 / recon_error^2). This removes the windows
//       where the differentiator fails (the fast speed transients at the start of a segment when
//       the speed demand saturates, the kink at its end): with Huber weights alone each of them
//       kept an influence of 1.345 s of one sign, a bias of the size of the noise-free error,
//       which the sandwich then counted as random. The threshold s leaves noisy runs almost
//       alone: the speed noise in recon_error has at most s / sqrt(18) sd (stencil weights 4/144
//       against 1/2 per boundary), so it rarely reaches s (a plain inverse-variance weight
//       1 / (s^2 + recon_error^2) reacted to that noise, broke the telescoping of consecutive
//       windows and cost 18 % of FDJ MSE on noisy sweeps). What remains on noisy runs is the
//       kink window at the end of a sweep segment (recon_error about 1.5 s there), where the
//       fourth-order stencil crosses the kink and overstates the error: about +10 % FDJ MSE on
//       noisy sweeps, nothing measurable on DYN.
//    b. Standard error. D = sum_i h_i recon_error_i (h = rows of the weighted least-squares
//       solution) is how far the estimate would move with the fourth-order reconstruction at the
//       same weights, i.e. the embedded estimate of the estimate's reconstruction error. It is
//       taken as the half-width of a 95 % interval for that error, se_model = |D| / 1.96
//       (kReconErrorZ), and added in quadrature to the sandwich se. Checked on seed 11 of
//       calibration_bench against |D| times 0.4, 0.6, 0.7 (see the commit message); one constant
//       for every load case and sequence.
//    Why D is not subtracted from the value: on noise-free runs it halves the A-ext error, but the
//    fourth-order noise costs 15-27 % of MSE on noisy runs (seed 11), and at a kink the
//    fourth-order stencil over-corrects (the difference is then an error bound, not an error).
//    At the two ends of the run the fourth-order stencil is shifted inwards by one sample.
#include "core/run.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "estimation/health_estimate.hpp"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

inline constexpr double kMinSlipSpeedRadS = 20.0;
/// ema-reference.md section 1: motor torque saturation (not among the Run constants).
inline constexpr double kTorqueLimitNm = sim::EmaParams{}.t_max_nm;
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
/// Step 6b: the embedded reconstruction-error estimate D is the half-width of a 95 % interval,
/// se_model = |D| / kReconErrorZ (the two-sided 95 % normal quantile).
inline constexpr double kReconErrorZ = kZ95;

struct SlipWindow {
    std::size_t first = 0, last = 0;  ///< sample indices, inclusive
    int direction = 0;                ///< +1 / -1
    std::size_t segment = 0;          ///< index of the contiguous slipping stretch
    double y_nm = 0;                  ///< d * mean T_R
    double x_opp_nm = 0;              ///< mean |F_R| over opposing samples (0 for aiding ones)
    double x_aid_nm = 0;              ///< mean |F_R| over aiding samples
    double recon_error_nm = 0;        ///< embedded estimate of the reconstruction error of y_nm (step 6)
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
    double fdj_recon_se_nm = 0;              ///< step 6b part of fdj_se_nm (before the eta confound)
    double eta_o_recon_se = 0;               ///< step 6b part of eta_o_se
    std::size_t recon_weighted_windows = 0;  ///< windows whose weight step 6a reduced
    std::size_t windows = 0, samples = 0;
    std::string why_not_identifiable;        ///< empty when identifiable
};

/// Fits eq. (5) to the windows; throws EmadiagError when there are fewer than kMinWindows
/// ("too few slipping samples: N in M windows; need ...").
[[nodiscard]] WrlsResult fit_friction_wrls(const std::vector<SlipWindow>& windows, double tau);

}  // namespace emadiag
