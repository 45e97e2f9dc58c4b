#pragma once
// The batched path's entry points (batch_kernels.cpp): one group of simulations on the instruction
// set Highway chose at run time (the widest this CPU has, unless narrowed by hwy::DisableTargets).
#include "emadiag/sim/simulator.hpp"

namespace emadiag::sim::detail {

/// Lane layout of the chosen target: its name (Highway's: "SSE4", "AVX2", "AVX3" = AVX-512, ...),
/// doubles per vector, and vectors stepped together. A group is lanes * groups simulations.
struct BatchShape {
    const char* target = "";
    int lanes = 1;
    int groups = 1;
};
[[nodiscard]] BatchShape batch_shape();

/// Runs batch_shape().lanes * groups simulations that may differ in health, effects (not backlash),
/// inertia and terms (run_group in step_kernel-inl.h); configs and out hold that many pointers (pad
/// the rest). Finishes each run as simulate does.
void run_batch_group(const SimConfig* const* configs, SimResult* const* out);
/// The same with one vector (groups = 1): batch_shape().lanes simulations, for small batches.
void run_batch_vector(const SimConfig* const* configs, SimResult* const* out);

/// One simulation on the scalar path (W = 1) compiled for the chosen target: the baseline
/// run_group<1, 1>'s results bit for bit, faster on targets with more registers (batch_kernels.cpp).
void run_scalar(const SimConfig& config, SimResult& out);

}  // namespace emadiag::sim::detail
