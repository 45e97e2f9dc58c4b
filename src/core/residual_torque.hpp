#pragma once
// Residual torque T_R, paper eq. (7): T_R = k_t I - J dw/dt - H / tau (ema-reference.md section 2).
#include "core/run.hpp"

#include <vector>

namespace emadiag {

/// dw/dt from the period-mean speeds: central difference of neighbouring means over 2 periods
/// (one-sided at the ends). Period means are centred half a period before each row's time, so the
/// central difference of means estimates the mean acceleration over the two periods around it.
[[nodiscard]] std::vector<double> speed_derivative_rad_s2(const Run& run);

/// T_R per sample (signed: positive while moving in the positive direction).
[[nodiscard]] std::vector<double> residual_torque_nm(const Run& run);

}  // namespace emadiag
