// The batched path's step, compiled once per instruction set with Google Highway (foreach_target.h
// re-includes this file for SSE4, AVX2, AVX-512, ... and the baseline) and chosen at run time by
// HWY_DYNAMIC_DISPATCH (simulator.cpp). The lane count follows the target: 2 doubles on SSE4 (and
// on NEON), 4 on AVX2, 8 on AVX-512. The step itself is step_kernel-inl.h, the same text the scalar
// path compiles over plain doubles; here its lane type wraps a Highway vector.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "batch_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "batch_kernels.hpp"
#include "step_kernel.hpp"

HWY_BEFORE_NAMESPACE();
namespace emadiag::sim::HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;
using DTag = hn::ScalableTag<double>;

/// Highway's lane count for doubles on this target (a compile-time constant on x86 and NEON).
inline constexpr int kLanes = static_cast<int>(HWY_LANES(double));
/// Independent lane groups stepped together to hide the latency of the step's dependency chain.
inline constexpr int kGroups = kBatchGroups;

/// kLanes doubles and their mask, with the operators the step is written in. Every operator is one
/// IEEE operation per lane (no FMA), as the scalar path's double arithmetic.
// The constructors are written out: an implicit one would not be compiled for this target.
struct LaneMask {
    LaneMask() : m(hn::MaskFromVec(hn::Zero(DTag()))) {}  // all false
    LaneMask(hn::Mask<DTag> mask) : m(mask) {}             // NOLINT(google-explicit-constructor)
    hn::Mask<DTag> m;
};
struct LaneVec {
    LaneVec() : v(hn::Zero(DTag())) {}
    LaneVec(hn::Vec<DTag> vec) : v(vec) {}  // NOLINT(google-explicit-constructor)
    hn::Vec<DTag> v;
};
inline LaneVec splat(double a) { return {hn::Set(DTag(), a)}; }

inline LaneVec operator+(LaneVec a, LaneVec b) { return {a.v + b.v}; }
inline LaneVec operator-(LaneVec a, LaneVec b) { return {a.v - b.v}; }
inline LaneVec operator*(LaneVec a, LaneVec b) { return {a.v * b.v}; }
inline LaneVec operator-(LaneVec a) { return {hn::Neg(a.v)}; }  // sign bit flipped, as scalar -x
inline LaneVec operator+(LaneVec a, double b) { return a + splat(b); }
inline LaneVec operator-(LaneVec a, double b) { return a - splat(b); }
inline LaneVec operator*(LaneVec a, double b) { return a * splat(b); }
inline LaneVec operator+(double a, LaneVec b) { return splat(a) + b; }
inline LaneVec operator-(double a, LaneVec b) { return splat(a) - b; }
inline LaneVec operator*(double a, LaneVec b) { return splat(a) * b; }

// Ordered comparisons (false when either side is NaN), as C++'s <, >, <=, == on doubles.
inline LaneMask operator<(LaneVec a, LaneVec b) { return {a.v < b.v}; }
inline LaneMask operator>(LaneVec a, LaneVec b) { return {a.v > b.v}; }
inline LaneMask operator<=(LaneVec a, LaneVec b) { return {a.v <= b.v}; }
inline LaneMask operator>=(LaneVec a, LaneVec b) { return {a.v >= b.v}; }
inline LaneMask operator==(LaneVec a, LaneVec b) { return {a.v == b.v}; }
inline LaneMask operator<(LaneVec a, double b) { return a < splat(b); }
inline LaneMask operator>(LaneVec a, double b) { return a > splat(b); }
inline LaneMask operator<=(LaneVec a, double b) { return a <= splat(b); }
inline LaneMask operator>=(LaneVec a, double b) { return a >= splat(b); }
inline LaneMask operator==(LaneVec a, double b) { return a == splat(b); }
inline LaneMask operator<(double a, LaneVec b) { return splat(a) < b; }
inline LaneMask operator>(double a, LaneVec b) { return splat(a) > b; }

inline LaneMask operator&(LaneMask a, LaneMask b) { return {hn::And(a.m, b.m)}; }
inline LaneMask operator|(LaneMask a, LaneMask b) { return {hn::Or(a.m, b.m)}; }

template <int W>
struct Vec {
    static_assert(W == kLanes, "the batched step runs at the target's lane count");
    using D = LaneVec;
    using M = LaneMask;
};
inline LaneVec sel(LaneMask m, LaneVec a, LaneVec b) { return {hn::IfThenElse(m.m, a.v, b.v)}; }
inline LaneMask vnot(LaneMask m) { return {hn::Not(m.m)}; }
inline LaneVec vabs(LaneVec a) { return {hn::Abs(a.v)}; }  // sign bit cleared, as std::fabs
inline void to_array(LaneVec v, double* out) { hn::StoreU(v.v, DTag(), out); }

// The scalar path (W = 1) compiled for this target too: plain double and bool as in step_kernel.hpp,
// but with this target's registers and instructions (AVX-512: 32 registers, no spills in the step;
// AVX: three-operand forms and blends). The same IEEE operations in the same order (no FMA), so
// every target's scalar path gives the baseline's results bit for bit.
#include "scalar_lanes-inl.h"

template <class D>
inline D from_array(const double* in) {
    if constexpr (std::is_same_v<D, double>) {
        return in[0];
    } else {
        return LaneVec{hn::LoadU(DTag(), in)};
    }
}

namespace self = ::emadiag::sim::HWY_NAMESPACE;
#include "step_kernel-inl.h"

void RunBatchGroup(const SimConfig* const* configs, SimResult* const* out) {
    self::run_group<kLanes, kGroups>(configs, out);
}
void RunBatchVector(const SimConfig* const* configs, SimResult* const* out) { self::run_group<kLanes, 1>(configs, out); }
void RunScalar(const SimConfig* config, SimResult* out) { self::run_group<1, 1>(&config, &out); }
detail::BatchShape GetBatchShape() { return {hwy::TargetName(HWY_TARGET), kLanes, kGroups}; }

}  // namespace emadiag::sim::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace emadiag::sim::detail {

HWY_EXPORT(RunBatchGroup);
HWY_EXPORT(RunBatchVector);
HWY_EXPORT(GetBatchShape);
HWY_EXPORT(RunScalar);

void run_batch_group(const SimConfig* const* configs, SimResult* const* out) {
    HWY_DYNAMIC_DISPATCH(RunBatchGroup)(configs, out);
}
void run_batch_vector(const SimConfig* const* configs, SimResult* const* out) {
    HWY_DYNAMIC_DISPATCH(RunBatchVector)(configs, out);
}
BatchShape batch_shape() { return HWY_DYNAMIC_DISPATCH(GetBatchShape)(); }
void run_scalar(const SimConfig& config, SimResult& out) { HWY_DYNAMIC_DISPATCH(RunScalar)(&config, &out); }

}  // namespace emadiag::sim::detail
#endif  // HWY_ONCE
