#pragma once
// Residual torque T_R, paper eq. (7): T_R = k_t I - J dw/dt - H / tau (ema-reference.md section 2).
//
// Differentiator (chosen and documented here, issue 4 part 1):
//   dw/dt at sample k is the central difference of the neighbouring period-mean speeds,
//   (wbar[k+1] - wbar[k-1]) / (t[k+1] - t[k-1]), one-sided at the first and last sample.
//   - Why no extra low-pass filter: for a speed that is quadratic over three periods, this
//     difference of period MEANS equals the mean of dw/dt over period k exactly, so T_R is the
//     period mean of the friction torque (the quantity the simulator's SampleTruth records) with
//     no lag and no amplitude loss. A filter would smear the friction switching at reversals.
//   - Noise: the difference amplifies speed noise (J sigma_w / (sqrt 2 T), about 0.05 N m per
//     sample with the `typical` profile). Consumers that need less noise average T_R over
//     consecutive samples instead of filtering: the sum of central differences over samples
//     a..b telescopes to (w[b+1] + w[b] - w[a] - w[a-1]) / 2, so the mean of T_R over n samples
//     has a derivative noise of only J sigma_w / (n T) and stays unbiased (this is the window
//     mean the physics estimator regresses on).
//   - Limits: at kinks of the speed (breakaway, a stop, the speed limit) the quadratic assumption
//     fails for the two samples around the kink; and when |k_t I| exceeds T_max eq. (7)
//     overstates the torque (ema-reference.md section 7). Estimators exclude those samples.
#include "core/run.hpp"

#include <vector>

namespace emadiag {

/// dw/dt from the period-mean speeds: central difference of neighbouring means over 2 periods
/// (one-sided at the ends). Period means are centred half a period before each row's time, so the
/// central difference of means estimates the mean acceleration over the period (see above).
/// Throws EmadiagError naming the sample when time does not increase.
[[nodiscard]] std::vector<double> speed_derivative_rad_s2(const Run& run);

/// T_R per sample (signed: positive while moving in the positive direction), eq. (7).
[[nodiscard]] std::vector<double> residual_torque_nm(const Run& run);

/// Mean of T_R over samples [first, last] (inclusive), computed in the telescoped form above:
/// mean(k_t I - H/tau) - J (w[last+1] + w[last] - w[first] - w[first-1]) / (2 n T) with one-sided
/// ends. Equal to the mean of residual_torque_nm over the same samples. Throws on a bad range.
[[nodiscard]] double residual_torque_mean_nm(const Run& run, std::size_t first, std::size_t last);

}  // namespace emadiag
