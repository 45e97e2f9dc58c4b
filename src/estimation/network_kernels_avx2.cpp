// network_kernels.hpp for AVX2 + FMA, in a baseline x86-64 build. Called only when the CPU
// has it (network.cpp asks the simulator's Highway dispatch).
//
// How: the standard headers are included first, at the baseline, so any of their inline functions
// this file emits out of line is baseline code (a copy compiled with -m flags could be the one the
// linker keeps for the whole program, and fault on an older CPU). Then #pragma GCC target compiles
// everything after it for avx2; GCC does not define the feature macros for a pragma, so they are
// defined here for Eigen's ConfigureVectorization.h. Eigen itself is renamed (Eigen -> Eigen_avx2),
// so none of its functions is shared with the baseline copy the rest of the program uses.
// Clang (the fuzz build) does not carry #pragma GCC target into Eigen's inline assembly: there this
// variant forwards to the baseline one, like on a CPU that is not x86.
#if (defined(__x86_64__) || defined(__i386__)) && !defined(__clang__)
#include <algorithm>
#include <array>
#include <cassert>
#include <cfloat>
#include <climits>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <immintrin.h>
#include <iosfwd>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#pragma GCC push_options
#pragma GCC target("avx2,fma")
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-variable"       // inside Eigen's AVX PacketMath.h
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // false positives in Eigen's AVX-512 GEMM (GCC 12)
#pragma GCC diagnostic ignored "-Wuninitialized"
#ifndef __SSE3__
#define __SSE3__ 1
#define __SSSE3__ 1
#define __SSE4_1__ 1
#define __SSE4_2__ 1
#endif
#define __AVX__ 1
#define __AVX2__ 1
#define __FMA__ 1
#define Eigen Eigen_avx2
#define EMADIAG_NN_VARIANT avx2
#include "estimation/network_kernels-inl.h"
#pragma GCC diagnostic pop
#pragma GCC pop_options
#else
// Not x86 (network.cpp never calls this variant), or clang: it forwards to the baseline one.
#include "estimation/network_kernels.hpp"
namespace emadiag::nn_kernels::avx2 {
void forward(const NetworkView& n, const double* x, long cols, double* y) { baseline::forward(n, x, cols, y); }
double mse(const NetworkView& n, const double* x, const double* t, long cols, double* grad) {
    return baseline::mse(n, x, t, cols, grad);
}
}  // namespace emadiag::nn_kernels::avx2
#endif
