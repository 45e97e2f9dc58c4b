// The batched path's step, compiled once per instruction set with Google Highway (foreach_target.h
// re-includes this file for SSE4, AVX2, AVX-512, ... and the baseline) and chosen at run time by
// HWY_DYNAMIC_DISPATCH (simulator.cpp). The lane count follows the target: 2 doubles on SSE4 (and
// on NEON), 4 on AVX2, 8 on AVX-512. The step itself is step_kernel-inl.h, the same text the scalar
// path compiles over plain doubles; here its lane type holds one or K Highway vectors.
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
/// Independent lane groups stepped together to hide the latency of the step's dependency chain,
/// interleaved operation by operation (LaneVec<K> below). Measured on Zen 5 (sim_bench, ns per
/// simulation-step on one core): AVX-512 3.3 step by step with 3 groups, 2.5 interleaved with 3 or 4;
/// AVX2 4.1 with 3, 3.7 with 4; SSE4 8.2 with 3, 8.4 with 4 (16 registers hold fewer copies).
/// Zen 4, session 9, after the step lost a fifth of its operations (one core, min of 5 interleaved
/// runs, K = 2 / 3 / 4 / 5 / 6): AVX-512 2.32 / 1.93 / 1.81 / 1.87 / 1.90; AVX2 3.65 / 2.58 / 2.41 /
/// 17.2 / 11.3 (5 and 6 spill into code that runs 4x slower per instruction); SSE4 7.19 / 5.27 /
/// 4.73 / 4.78 / 4.81: SSE4 now 4 too (10 % faster than 3 here).
// EMADIAG_GROUPS_SSE4 / _AVX2 / _AVX512 override the count at compile time (to measure other counts).
#if (HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL) && defined(EMADIAG_GROUPS_AVX512)
inline constexpr int kGroups = EMADIAG_GROUPS_AVX512;
#elif HWY_TARGET == HWY_AVX2 && defined(EMADIAG_GROUPS_AVX2)
inline constexpr int kGroups = EMADIAG_GROUPS_AVX2;
#elif HWY_TARGET == HWY_SSE4 && defined(EMADIAG_GROUPS_SSE4)
inline constexpr int kGroups = EMADIAG_GROUPS_SSE4;
#elif HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2 || HWY_TARGET == HWY_SSE4
inline constexpr int kGroups = 4;
#else
inline constexpr int kGroups = 3;
#endif

/// K vectors of kLanes doubles (K * kLanes lanes) and their masks, with the operators the step is
/// written in. Every operator is one IEEE operation per lane (no FMA), as the scalar path's double
/// arithmetic, issued K times back to back on independent vectors: the K copies of the step's long
/// dependency chain sit side by side in the instruction stream, so the out-of-order core always
/// finds independent work (stepping whole groups one after another leaves that to its window, which
/// on AVX-512 holds less than two steps).
// The constructors are written out: an implicit one would not be compiled for this target.
#define EMADIAG_EACH _Pragma("GCC unroll 8") for (int k = 0; k < K; ++k)
template <int K>
struct LaneMask {
    LaneMask() { EMADIAG_EACH m[k] = hn::MaskFromVec(hn::Zero(DTag())); }  // all false
    LaneMask(const LaneMask&) = default;
    LaneMask& operator=(const LaneMask& o) {
        EMADIAG_EACH m[k] = o.m[k];
        return *this;
    }
    hn::Mask<DTag> m[K];
};
// The copy assignment is written out vector by vector: GCC 12's implicit one stored a LaneVec
// member of Lanes (z.i = i1) through the stack and general registers (vmovq, vpinsrq, 16-byte
// stores): 557 -> 525 instructions per AVX2 step of 16 lanes (callgrind), 8 % less time.
template <int K>
struct LaneVec {
    LaneVec() { EMADIAG_EACH v[k] = hn::Zero(DTag()); }
    LaneVec(const LaneVec&) = default;
    LaneVec& operator=(const LaneVec& o) {
        EMADIAG_EACH v[k] = o.v[k];
        return *this;
    }
    hn::Vec<DTag> v[K];
};
template <int K, class F>
HWY_INLINE LaneVec<K> map2(LaneVec<K> a, LaneVec<K> b, F f) {
    LaneVec<K> r;
    EMADIAG_EACH r.v[k] = f(a.v[k], b.v[k]);
    return r;
}
template <int K, class F>
HWY_INLINE LaneMask<K> cmp2(LaneVec<K> a, LaneVec<K> b, F f) {
    LaneMask<K> r;
    EMADIAG_EACH r.m[k] = f(a.v[k], b.v[k]);
    return r;
}
template <int K>
HWY_INLINE LaneVec<K> splat(double a) {
    LaneVec<K> r;
    const auto v = hn::Set(DTag(), a);
    EMADIAG_EACH r.v[k] = v;
    return r;
}

#define EMADIAG_VEC_OP(op)                                                                                       \
    template <int K>                                                                                             \
    HWY_INLINE LaneVec<K> operator op(LaneVec<K> a, LaneVec<K> b) {                                              \
        return map2(a, b, [](hn::Vec<DTag> x, hn::Vec<DTag> y) HWY_ATTR { return x op y; });                       \
    }                                                                                                            \
    template <int K>                                                                                             \
    HWY_INLINE LaneVec<K> operator op(LaneVec<K> a, double b) { return a op splat<K>(b); }                        \
    template <int K>                                                                                             \
    HWY_INLINE LaneVec<K> operator op(double a, LaneVec<K> b) { return splat<K>(a) op b; }
EMADIAG_VEC_OP(+)
EMADIAG_VEC_OP(-)
EMADIAG_VEC_OP(*)
#undef EMADIAG_VEC_OP
template <int K>
HWY_INLINE LaneVec<K> operator-(LaneVec<K> a) {  // sign bit flipped, as scalar -x
    LaneVec<K> r;
    EMADIAG_EACH r.v[k] = hn::Neg(a.v[k]);
    return r;
}

// Ordered comparisons (false when either side is NaN), as C++'s <, >, <=, == on doubles.
#define EMADIAG_CMP_OP(op)                                                                                       \
    template <int K>                                                                                             \
    HWY_INLINE LaneMask<K> operator op(LaneVec<K> a, LaneVec<K> b) {                                             \
        return cmp2(a, b, [](hn::Vec<DTag> x, hn::Vec<DTag> y) HWY_ATTR { return x op y; });                       \
    }                                                                                                            \
    template <int K>                                                                                             \
    HWY_INLINE LaneMask<K> operator op(LaneVec<K> a, double b) { return a op splat<K>(b); }                       \
    template <int K>                                                                                             \
    HWY_INLINE LaneMask<K> operator op(double a, LaneVec<K> b) { return splat<K>(a) op b; }
EMADIAG_CMP_OP(<)
EMADIAG_CMP_OP(>)
EMADIAG_CMP_OP(<=)
EMADIAG_CMP_OP(>=)
EMADIAG_CMP_OP(==)
#undef EMADIAG_CMP_OP

template <int K>
HWY_INLINE LaneMask<K> operator&(LaneMask<K> a, LaneMask<K> b) {
    LaneMask<K> r;
    EMADIAG_EACH r.m[k] = hn::And(a.m[k], b.m[k]);
    return r;
}
template <int K>
HWY_INLINE LaneMask<K> operator|(LaneMask<K> a, LaneMask<K> b) {
    LaneMask<K> r;
    EMADIAG_EACH r.m[k] = hn::Or(a.m[k], b.m[k]);
    return r;
}

template <int W>
struct Vec {
    static_assert(W % kLanes == 0, "the batched step runs at a multiple of the target's lane count");
    using D = LaneVec<W / kLanes>;
    using M = LaneMask<W / kLanes>;
};
template <int K>
HWY_INLINE LaneVec<K> sel(LaneMask<K> m, LaneVec<K> a, LaneVec<K> b) {
    LaneVec<K> r;
    EMADIAG_EACH r.v[k] = hn::IfThenElse(m.m[k], a.v[k], b.v[k]);
    return r;
}
// sel(m, +0, a) and sel(m, a, +0): one and-not / and with the mask (GCC turned the blend with a zero
// into a sign-bit compare and an and-not).
template <int K>
HWY_INLINE LaneVec<K> zero_if(LaneMask<K> m, LaneVec<K> a) {
    EMADIAG_EACH a.v[k] = hn::IfThenZeroElse(m.m[k], a.v[k]);
    return a;
}
template <int K>
HWY_INLINE LaneVec<K> keep_if(LaneMask<K> m, LaneVec<K> a) {
    EMADIAG_EACH a.v[k] = hn::IfThenElseZero(m.m[k], a.v[k]);
    return a;
}
template <int K>
HWY_INLINE LaneVec<K> vxor(LaneVec<K> a, LaneVec<K> b) {  // bitwise: a ^ (-0) = -a, a ^ (+0) = a
    EMADIAG_EACH a.v[k] = hn::Xor(a.v[k], b.v[k]);
    return a;
}
template <int K>
HWY_INLINE bool any(LaneMask<K> m) {  // some lane of the K vectors set: one test of their union
    auto u = m.m[0];
    _Pragma("GCC unroll 8") for (int k = 1; k < K; ++k) u = hn::Or(u, m.m[k]);
    return !hn::AllFalse(DTag(), u);
}
template <int K>
HWY_INLINE LaneMask<K> vnot(LaneMask<K> m) {
    LaneMask<K> r;
    EMADIAG_EACH r.m[k] = hn::Not(m.m[k]);
    return r;
}
template <int K>
HWY_INLINE LaneVec<K> vabs(LaneVec<K> a) {  // sign bit cleared, as std::fabs
    LaneVec<K> r;
    EMADIAG_EACH r.v[k] = hn::Abs(a.v[k]);
    return r;
}
// clamp_below(a, lo) = sel(a < lo, lo, a) and clamp_above(a, hi) = sel(a > hi, hi, a), per lane.
// x86's maxpd(x, y) is x > y ? x : y and minpd(x, y) is x < y ? x : y per lane (the second operand
// when either is NaN), so maxpd(lo, a) and minpd(hi, a) are exactly those selects, NaN and signed
// zeros included, in one operation instead of a compare and a blend. Highway's portable targets
// treat NaN otherwise in Max and Min: they keep the compare and the select.
#if HWY_ARCH_X86 && (HWY_TARGET == HWY_SSE4 || HWY_TARGET == HWY_AVX2 || HWY_TARGET == HWY_AVX3 || \
                     HWY_TARGET == HWY_AVX3_DL)
template <int K>
HWY_INLINE LaneVec<K> clamp_below(LaneVec<K> a, double lo) {
    const auto l = hn::Set(DTag(), lo);
    EMADIAG_EACH a.v[k] = hn::Max(l, a.v[k]);
    return a;
}
template <int K>
HWY_INLINE LaneVec<K> clamp_above(LaneVec<K> a, double hi) {
    const auto h = hn::Set(DTag(), hi);
    EMADIAG_EACH a.v[k] = hn::Min(h, a.v[k]);
    return a;
}
template <int K>
HWY_INLINE LaneVec<K> vmax(LaneVec<K> lo, LaneVec<K> a) {  // clamp_below with a bound per lane
    EMADIAG_EACH a.v[k] = hn::Max(lo.v[k], a.v[k]);
    return a;
}
#else
template <int K>
HWY_INLINE LaneVec<K> vmax(LaneVec<K> lo, LaneVec<K> a) { return sel(a < lo, lo, a); }
template <int K>
HWY_INLINE LaneVec<K> clamp_below(LaneVec<K> a, double lo) { return sel(a < lo, splat<K>(lo), a); }
template <int K>
HWY_INLINE LaneVec<K> clamp_above(LaneVec<K> a, double hi) { return sel(a > hi, splat<K>(hi), a); }
#endif
template <int K>
HWY_INLINE void to_array(LaneVec<K> v, double* out) {
    EMADIAG_EACH hn::StoreU(v.v[k], DTag(), out + k * kLanes);
}

/// Every lane 0.0 + a: what D{} + a gives (K adds of zero and a broadcast), in one broadcast.
template <class D>
    requires(!std::is_same_v<D, double>)
HWY_INLINE D bcast(double a) {
    constexpr int K = static_cast<int>(sizeof(D::v) / sizeof(D::v[0]));
    return splat<K>(0.0 + a);
}

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
        D r;
        constexpr int K = static_cast<int>(sizeof(r.v) / sizeof(r.v[0]));
        EMADIAG_EACH r.v[k] = hn::LoadU(DTag(), in + k * kLanes);
        return r;
    }
}
#undef EMADIAG_EACH

namespace self = ::emadiag::sim::HWY_NAMESPACE;
#include "step_kernel-inl.h"

void RunBatchGroup(const SimConfig* const* configs, SimResult* const* out) {
    self::run_group<kLanes * kGroups, 1>(configs, out);
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
