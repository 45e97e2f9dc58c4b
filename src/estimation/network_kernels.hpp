#pragma once
// The network's hot arithmetic (forward pass, MSE and its gradient: three GEMMs and a tanh per
// call), compiled once per instruction set: the baseline build (SSE2, what Eigen vectorises to on
// baseline x86-64), AVX2 + FMA and AVX-512 (network_kernels-inl.h). Network picks the variant of the
// instruction set the simulator's batched path uses (sim::simd_target(): the widest the CPU has, or
// EMADIAG_SIMD), so one portable binary trains at AVX2 / AVX-512 speed. Each variant is
// deterministic; they differ from each other in the last bits (FMA rounds once).
// No Eigen type crosses this interface: each variant has its own copy of Eigen.
#include <string>

namespace emadiag::nn_kernels {

/// A network's weights as raw column-major arrays (Network's w1_, b1_, w2_, b2_).
struct NetworkView {
    int inputs = 0;
    int hidden = 0;
    int outputs = 0;
    const double* w1 = nullptr;  ///< hidden x inputs
    const double* b1 = nullptr;
    const double* w2 = nullptr;  ///< outputs x hidden
    const double* b2 = nullptr;
};

#define EMADIAG_NN_KERNEL_DECLS                                                                           \
    /* y (outputs x cols) = satlins(w2 tansig(w1 x + b1) + b2) for x (inputs x cols). */                    \
    void forward(const NetworkView& n, const double* x, long cols, double* y);                             \
    /* Mean squared error against t (outputs x cols); its gradient into grad (parameter count) if set. */  \
    /* a1 (hidden x cols) and z2 (outputs x cols), if set, hold the forward pass's activations: read */    \
    /* from them when have_forward (the same weights and inputs as when they were written), else */       \
    /* written to them. */                                                                                  \
    double mse(const NetworkView& n, const double* x, const double* t, long cols, double* grad, double* a1,   \
               double* z2, bool have_forward);
namespace baseline { EMADIAG_NN_KERNEL_DECLS }
namespace avx2 { EMADIAG_NN_KERNEL_DECLS }
namespace avx512 { EMADIAG_NN_KERNEL_DECLS }
#undef EMADIAG_NN_KERNEL_DECLS

/// The variant in use: "avx512", "avx2" or "baseline".
[[nodiscard]] std::string variant();

}  // namespace emadiag::nn_kernels
