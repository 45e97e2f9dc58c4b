// term_sincos_many (term_eval.hpp): the sin and cos of many periodic term arguments at once,
// compiled once per instruction set with Google Highway (foreach_target.h re-includes this file for
// SSE4, AVX2, AVX-512 and the baseline) and chosen at run time by HWY_DYNAMIC_DISPATCH, as the
// batched step is (batch_kernels.cpp). So EMADIAG_SIMD / set_simd_target narrow it too (scalar: the
// baseline copy), and there is no ifunc resolver running before a sanitizer's runtime is set up
// (GCC's target_clones, which this replaces, had one: it crashed every ThreadSanitizer binary).
// Each vector lane runs term_sincos_medium's operations in its order (IEEE add, sub, mul, the
// quadrant's bits, selects, sign flips; no FMA: the library builds with -ffp-contract=off and
// Highway's Mul / Add are single operations), so every target gives term_sincos's values bit for bit.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "term_sincos_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "term_eval.hpp"

#include <cmath>

HWY_BEFORE_NAMESPACE();
namespace emadiag::sim::HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

/// term_sincos_medium (term_eval.hpp) on every lane of x: the same constants, the same operations
/// in the same order (the comments there say what each part is).
template <class D>
HWY_INLINE void SinCosMedium(D d, hn::Vec<D> x, hn::Vec<D>& s_out, hn::Vec<D>& c_out) {
    using V = hn::Vec<D>;
    const hn::RebindToUnsigned<D> du;
    constexpr double inv_pio2 = 6.36619772367581382433e-01, pio2_1 = 1.57079632673412561417e+00,
                     pio2_2 = 6.07710050630396597660e-11, pio2_2t = 2.02226624879595063154e-21,
                     pio2_3 = 2.02226624871116645580e-21, pio2_3t = 8.47842766036889956997e-32;
    const V shift = hn::Set(d, 0x1.8p52);
    const V shifted = x * hn::Set(d, inv_pio2) + shift;
    const V fn = shifted - shift;
    const auto quadrant = hn::And(hn::BitCast(du, shifted), hn::Set(du, 3u));
    V r = x - fn * hn::Set(d, pio2_1);
    V t = r;
    V w = fn * hn::Set(d, pio2_2);
    r = t - w;
    w = fn * hn::Set(d, pio2_2t) - ((t - r) - w);
    t = r;
    w = fn * hn::Set(d, pio2_3);
    r = t - w;
    w = fn * hn::Set(d, pio2_3t) - ((t - r) - w);
    const V y0 = r - w;
    const V y1 = (r - y0) - w;
    constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                     S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                     S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
    constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                     C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                     C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
    auto c = [d](double value) { return hn::Set(d, value); };
    const V z = y0 * y0;
    const V zz = z * z;
    const V rs = (c(S2) + z * (c(S3) + z * c(S4))) + (z * zz) * (c(S5) + z * c(S6));
    const V v = z * y0;
    const V half = c(0.5);
    const V ks = y0 - ((z * (half * y1 - v * rs) - y1) - v * c(S1));
    const V rc = z * (c(C1) + z * (c(C2) + z * c(C3))) + (zz * zz) * (c(C4) + z * (c(C5) + z * c(C6)));
    const V hz = half * z;
    const V one = c(1.0);
    const V wc = one - hz;
    const V kc = wc + (((one - wc) - hz) + (z * rc - y0 * y1));
    const auto zero_u = hn::Zero(du);
    const auto odd = hn::RebindMask(d, hn::Ne(hn::And(quadrant, hn::Set(du, 1u)), zero_u));
    const auto s_neg = hn::RebindMask(d, hn::Ne(hn::And(quadrant, hn::Set(du, 2u)), zero_u));
    const auto c_neg = hn::RebindMask(d, hn::Ne(hn::And(quadrant + hn::Set(du, 1u), hn::Set(du, 2u)), zero_u));
    const V s_abs = hn::IfThenElse(odd, kc, ks);
    const V c_abs = hn::IfThenElse(odd, ks, kc);
    s_out = hn::IfThenElse(s_neg, hn::Neg(s_abs), s_abs);
    c_out = hn::IfThenElse(c_neg, hn::Neg(c_abs), c_abs);
}

void TermSinCosMany(const double* x, double* s, double* c, int n) {
    const hn::ScalableTag<double> d;
    const int lanes = static_cast<int>(hn::Lanes(d));
    int k = 0;
    for (; k + lanes <= n; k += lanes) {
        hn::Vec<decltype(d)> vs, vc;
        SinCosMedium(d, hn::LoadU(d, x + k), vs, vc);
        hn::StoreU(vs, d, s + k);
        hn::StoreU(vc, d, c + k);
    }
    if (k < n) {  // the last partial vector, through a buffer padded with zeros
        HWY_ALIGN double xb[HWY_LANES(double)] = {};
        HWY_ALIGN double sb[HWY_LANES(double)];
        HWY_ALIGN double cb[HWY_LANES(double)];
        for (int j = 0; j < n - k; ++j) xb[j] = x[k + j];
        hn::Vec<decltype(d)> vs, vc;
        SinCosMedium(d, hn::Load(d, xb), vs, vc);
        hn::Store(vs, d, sb);
        hn::Store(vc, d, cb);
        for (int j = 0; j < n - k; ++j) {
            s[k + j] = sb[j];
            c[k + j] = cb[j];
        }
    }
    // Beyond the medium range, and NaN or infinite arguments: the C library (term_sincos).
    for (int j = 0; j < n; ++j) {
        if (!(std::fabs(x[j]) <= detail::kTrigMediumMax)) detail::term_sincos(x[j], s[j], c[j]);
    }
}

}  // namespace emadiag::sim::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace emadiag::sim::detail {

HWY_EXPORT(TermSinCosMany);

void term_sincos_many(const double* x, double* s, double* c, int n) { HWY_DYNAMIC_DISPATCH(TermSinCosMany)(x, s, c, n); }

}  // namespace emadiag::sim::detail
#endif  // HWY_ONCE
