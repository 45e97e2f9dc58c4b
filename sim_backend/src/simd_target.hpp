#pragma once
// The choice between the scalar and the Highway-dispatched batched path (simd_target.cpp).
#include "emadiag/sim/simulator.hpp"

namespace emadiag::sim::detail {

/// True when simulate_batch must run one simulation at a time on the scalar path (EMADIAG_SIMD=scalar
/// or set_simd_target("scalar")). Reads the environment variable on first use.
[[nodiscard]] bool batch_runs_scalar();

}  // namespace emadiag::sim::detail
