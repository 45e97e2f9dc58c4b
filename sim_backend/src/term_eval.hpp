#pragma once
// Evaluation of terms as data (terms.hpp) at one point: the signals, the basis functions, and the
// sin and cos of the periodic term bases (terms.hpp: sin/cos(signal, period)). The simulator
// evaluates them at every integration step of every lane that has such a term; the C library's
// calls (which save and restore the rounding mode, and branch on the argument's range) were half of
// a re-simulation fit's time (perf, issue 10). These are the kernels of fdlibm (FreeBSD msun
// k_sin.c, k_cos.c) after its medium-range Cody-Waite reduction (e_rem_pio2.c) with all three
// rounds always taken: error below 1 ulp (the C library's results within 1 ulp), and no branch but
// the quadrant's selection, so a loop over many arguments runs them side by side. Plain IEEE
// operations (the library builds with -ffp-contract=off): the same result on every machine, for
// one argument (terms.cpp) or many (term_sincos_kernels.cpp). Beyond kTrigMediumMax and for non-finite
// arguments std::sin/std::cos are used (no term comes near: angles in degrees or radians, seconds,
// rad/s over periods of a fraction of their range).
#include "emadiag/sim/terms.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace emadiag::sim::detail {

/// Below fdlibm's medium-range limit 2^20 pi/2 = 1647099.3 (n pi/2 exact in the first part).
inline constexpr double kTrigMediumMax = 1.6e6;

/// sin(x) and cos(x) together (both from one reduction), for |x| <= kTrigMediumMax (else any value).
inline void term_sincos_medium(double x, double& s, double& c) {
    constexpr double inv_pio2 = 6.36619772367581382433e-01, pio2_1 = 1.57079632673412561417e+00,
                     pio2_1t = 6.07710050650619224932e-11, pio2_2 = 6.07710050630396597660e-11,
                     pio2_2t = 2.02226624879595063154e-21, pio2_3 = 2.02226624871116645580e-21,
                     pio2_3t = 8.47842766036889956997e-32;
    // n = round(x / (pi/2)) by the 1.5 * 2^52 shift (round to nearest, |x| / (pi/2) < 2^51): its
    // low mantissa bits are n's two's complement.
    constexpr double kShift = 0x1.8p52;
    const double shifted = x * inv_pio2 + kShift;
    const double fn = shifted - kShift;
    const auto quadrant = static_cast<unsigned>(std::bit_cast<std::uint64_t>(shifted) & 3u);
    // x - n pi/2 in three rounds (151 bits of pi/2), y0 + y1.
    double r = x - fn * pio2_1;
    double w = fn * pio2_1t;
    double t = r;
    w = fn * pio2_2;
    r = t - w;
    w = fn * pio2_2t - ((t - r) - w);
    t = r;
    w = fn * pio2_3;
    r = t - w;
    w = fn * pio2_3t - ((t - r) - w);
    const double y0 = r - w;
    const double y1 = (r - y0) - w;
    // k_sin.c (with the tail y1) and k_cos.c on |y0 + y1| <= pi/4.
    constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                     S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                     S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
    constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                     C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                     C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
    const double z = y0 * y0;
    const double zz = z * z;
    const double rs = S2 + z * (S3 + z * S4) + z * zz * (S5 + z * S6);
    const double v = z * y0;
    const double ks = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * S1);
    const double rc = z * (C1 + z * (C2 + z * C3)) + zz * zz * (C4 + z * (C5 + z * C6));
    const double hz = 0.5 * z;
    const double wc = 1.0 - hz;
    const double kc = wc + (((1.0 - wc) - hz) + (z * rc - y0 * y1));
    // Quadrant q: sin = (ks, kc, -ks, -kc)[q], cos = (kc, -ks, -kc, ks)[q].
    const double s_abs = (quadrant & 1u) != 0 ? kc : ks;
    const double c_abs = (quadrant & 1u) != 0 ? ks : kc;
    s = (quadrant & 2u) != 0 ? -s_abs : s_abs;
    c = ((quadrant + 1u) & 2u) != 0 ? -c_abs : c_abs;
}

/// sin(x) and cos(x) together.
inline void term_sincos(double x, double& s, double& c) {
    if (std::fabs(x) <= kTrigMediumMax) {
        term_sincos_medium(x, s, c);
    } else {
        s = std::sin(x);
        c = std::cos(x);
    }
}

/// term_sincos for x[0..n): the same values, side by side in SIMD registers of the instruction set
/// the simulator uses (term_sincos_kernels.cpp: Highway's dynamic dispatch, EMADIAG_SIMD narrows it).
void term_sincos_many(const double* x, double* s, double* c, int n);

/// The argument of sin/cos(signal, period) for the signal's value v.
inline double periodic_argument(const TermFactor& f, double v) { return 2.0 * std::numbers::pi * v / f.a; }

inline double signal_value(TermSignal s, const TermInputs& x) {
    switch (s) {
        case TermSignal::Speed: return x.w;
        case TermSignal::ThetaMotor: return x.theta_m;
        case TermSignal::ThetaSurface: return x.theta_u_deg;
        case TermSignal::LoadTorque: return x.f_r;
        case TermSignal::Time: return x.t;
        case TermSignal::Current: return x.i;
    }
    return 0.0;
}

inline bool is_periodic(TermBasis b) { return b == TermBasis::Sin || b == TermBasis::Cos; }

/// A basis function at the signal's value v.
inline double factor_value(const TermFactor& f, double v) {
    switch (f.basis) {
        case TermBasis::Identity: return v;
        case TermBasis::Abs: return std::fabs(v);
        case TermBasis::Sgn: return static_cast<double>((v > 0) - (v < 0));
        case TermBasis::Square: return v * v;
        case TermBasis::Sin:
        case TermBasis::Cos: {
            double sn = 0, cs = 0;
            term_sincos(periodic_argument(f, v), sn, cs);
            return f.basis == TermBasis::Sin ? sn : cs;
        }
        case TermBasis::Gauss: {
            const double z = (v - f.a) / f.b;
            return std::exp(-0.5 * z * z);
        }
        case TermBasis::Step: return v >= f.a ? 1.0 : 0.0;
    }
    return 0.0;
}

}  // namespace emadiag::sim::detail
