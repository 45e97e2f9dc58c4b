#pragma once
// What the scalar and the batched paths share (constants of sections 4 and 5, the parameters every
// lane shares, the command), and the scalar path itself: step_kernel-inl.h instantiated over plain
// doubles (W = 1). batch_kernels.cpp instantiates the same step over Highway vectors, once per
// instruction set (SSE4, AVX2, AVX-512, ...), and simulator.cpp picks one at run time.
#include "emadiag/sim/physics.hpp"
#include "emadiag/sim/simulator.hpp"
#include "term_hook.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <numbers>
#include <memory>
#include <type_traits>

namespace emadiag::sim::detail {

// Aircraft model of section 4, case B (Stevens & Lewis medium transport, linearised).
inline constexpr double kA[4][4] = {
    {-1.609609e-02, 1.883200e+01, -3.217000e+01, 0.0},
    {-1.018923e-03, -6.353718e-01, 0.0, 1.0},
    {0.0, 0.0, 0.0, 1.0},
    {1.074365e-04, -7.754388e-01, 0.0, -5.297657e-01},
};
inline constexpr double kB3 = -1.100812e-02;  // B = [0 0 0 kB3]^T
inline constexpr double kQbarPa = 3200.0;
inline constexpr double kSeM2 = 6.0;
inline constexpr double kCeM = 0.9;
inline constexpr double kChAlphaPerRad = -0.15;
inline constexpr double kChDeltaPerRad = -0.25;
inline constexpr double kTailArmM = 20.0;
inline constexpr double kAirspeedMS = 76.2;
// Cases A and A-ext: kCaseAHingeNm and kAExtHingeRateNmPerS of physics.hpp.
using sim::kAExtHingeRateNmPerS;
using sim::kCaseAHingeNm;
// BRK phases (the sequence itself is defined in simulator.hpp, section 5).
inline constexpr double kPhaseHold0 = 0, kPhaseRampUp = 1, kPhaseHold1 = 2, kPhaseRampDown = 3, kPhaseHold2 = 4;

inline double deg2rad(double d) { return d * (std::numbers::pi / 180.0); }
inline double rad2deg(double r) { return r * (180.0 / std::numbers::pi); }

/// Parameters shared by every lane of a batch.
struct Shared {
    double dt_over_l, inv_tau, dt_inv_j;  // precomputed: multiplications replace divisions in the hot loop
    double dt, v_dc, r, l, k_t, i_max, t_max, w_max, inv_j, j, tau, k_theta, k_w, stop_m;
    LoadCase load_case;
    Sequence sequence;
    Effects fx;  // backlash_rad is the one shared effect; the others are per lane (Lanes::fx)
    long steps_per_sample, steps_per_aircraft, total_samples, brk_first_hold_steps, brk_mid_hold_steps;
};

/// Validates the config and precomputes what every lane shares.
[[nodiscard]] Shared make_shared(const SimConfig& c);

/// Surface-angle command in degrees (section 5).
inline double command_deg_inline(Sequence seq, double t) {
    switch (seq) {
        case Sequence::Dyn: {
            const double tc = std::clamp(t, 0.0, 0.5);
            return ((-1080.0 * tc + 1080.0) * tc - 240.0) * tc;
        }
        case Sequence::Sweep: {
            // Linear chirp 1 Hz -> 4 Hz over 0.5 s, 12 deg amplitude (the idea of the paper's Table 8).
            constexpr double kAmpDeg = 12.0, kF0Hz = 1.0, kF1Hz = 4.0, kLenS = 0.5;
            const double tc = std::clamp(t, 0.0, kLenS);
            return kAmpDeg * std::sin(2.0 * std::numbers::pi * (kF0Hz * tc + 0.5 * (kF1Hz - kF0Hz) / kLenS * tc * tc));
        }
        case Sequence::Brk:
            return 0.0;
    }
    return 0.0;
}

/// The scalar path's lane types: one double, one bool.
template <int W>
struct Vec;
#include "scalar_lanes-inl.h"
template <class D>
inline D from_array(const double* in) { return in[0]; }

/// Finishes a run after the integration: drops the truth unless asked for, applies the sensor
/// effects, then the noise profile (simulator.cpp).
void finish_run(const SimConfig& config, SimResult& result);

namespace self = ::emadiag::sim::detail;
#include "step_kernel-inl.h"

}  // namespace emadiag::sim::detail
