#pragma once
// The integration step of ema-reference.md section 3, written once over W lanes (structure of
// arrays). W = 1 is the scalar path; W = kBatchLanes is the SIMD batch. Every lane operation is
// branch-free so the compiler vectorises the lane loops; decisions are selects.
// kFull adds the effects beyond the datasheet, the truth and the energy accounts.
#include "emadiag/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
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
inline constexpr double kCaseAHingeNm = 5.0;
inline constexpr double kAExtHingeRateNmPerS = 1990.0;
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
    Effects fx;
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

/// W doubles in one GCC vector, and its mask type. W = 1 is plain double and bool: the scalar path.
template <int W>
struct Vec {
    typedef double D __attribute__((vector_size(W * sizeof(double))));
    typedef long long M __attribute__((vector_size(W * sizeof(long long))));
};
template <>
struct Vec<1> {
    using D = double;
    using M = bool;
};

template <int W>
struct Lanes {
    using D = typename Vec<W>::D;
    // health parameters per lane
    D fdj, fsj, c_opp, c_aid;
    // state
    D i, w, th, x[4];
    D gap;  // backlash: motor angle minus load angle, within +/- backlash/2
    // BRK sequencer
    D phase, ramp_i, ramp_start_th, last_iref, hold_end_n;
    // period accumulators
    D sum_i, sum_w, sum_h, sum_tf, sum_tm, sum_fr, stuck_count;
    // energy accounts (kFull)
    D e_in, e_cu, e_fr, e_load, e_sat, e_stop;
};

template <class D, class M>
inline D sel(M m, D a, D b) { return m ? a : b; }
template <class M>
inline M vnot(M m) {
    if constexpr (std::is_same_v<M, bool>) {
        return !m;
    } else {
        return ~m;
    }
}
template <class M>
inline M mask_of(bool b) { return b ? vnot(M{}) : M{}; }
/// Lane l of a vector, or the scalar itself.
template <class D>
inline double& lane(D& v, int l) {
    if constexpr (std::is_same_v<D, double>) {
        (void)l;
        return v;
    } else {
        return reinterpret_cast<double*>(&v)[l];  // clang binds no reference to v[l] (fuzz build)
    }
}
/// |a| by clearing the sign bit (one AND; -0 becomes +0, which no caller can tell apart).
template <class D>
inline D vabs(D a) {
    if constexpr (std::is_same_v<D, double>) {
        return std::fabs(a);
    } else {
        using I = decltype(a < a);
        return reinterpret_cast<D>(reinterpret_cast<I>(a) & (I{} + 0x7fffffffffffffffLL));
    }
}
template <class D>
inline D vclamp(D a, double lo, double hi) {
    a = a < lo ? D{} + lo : a;
    return a > hi ? D{} + hi : a;
}
template <class D>
inline D vsgn(D a) {
    const D one = D{} + 1.0;
    return sel(a > 0.0, one, sel(a < 0.0, -one, D{}));
}

/// One step with the command of step n, cmd_m = tau * radians(command_deg(t = n dt)), computed by
/// the caller (it is shared by every lane and group of a batch).
template <int W, bool kFull>
inline void step(const Shared& shared, Lanes<W>& z, long n, double cmd_m) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    const Shared& s = shared;
    const double dt = s.dt;
    const double t = static_cast<double>(n) * dt;  // section 7: step n runs at t = n dt
    const D zero{};
    const D one = zero + 1.0;

    // BRK: entering a ramp at the start of this step (sections 5 and 7).
    D phase = z.phase;
    M ramping = M{};
    D ramp_rate = zero;
    if (s.sequence == Sequence::Brk) {
        const double dn = static_cast<double>(n);
        const M start_up = (phase == kPhaseHold0) & mask_of<M>(dn > static_cast<double>(s.brk_first_hold_steps));
        const M start_down = (phase == kPhaseHold1) & (z.hold_end_n < dn);
        const M start_ramp = start_up | start_down;
        phase = sel(start_up, zero + kPhaseRampUp, sel(start_down, zero + kPhaseRampDown, phase));
        z.ramp_i = sel(start_ramp, z.last_iref, z.ramp_i);
        z.ramp_start_th = sel(start_ramp, z.th, z.ramp_start_th);
        ramping = (phase == kPhaseRampUp) | (phase == kPhaseRampDown);
        ramp_rate = sel(phase == kPhaseRampUp, zero + kBrkRampAPerS * dt, zero - kBrkRampAPerS * dt);
    }

    // 1. Command: cmd_m (shared by all lanes).
    // 2. Controller.
    const D w_ref = vclamp(s.k_theta * (cmd_m - z.th), -s.w_max, s.w_max);
    const D i_pos = vclamp(s.k_w * (w_ref - z.w), -s.i_max, s.i_max);
    D i_ref = i_pos;
    if (s.sequence == Sequence::Brk) {
        i_ref = sel(ramping, vclamp(z.ramp_i, -s.i_max, s.i_max), i_pos);
        z.ramp_i = sel(ramping, z.ramp_i + ramp_rate, z.ramp_i);
        z.last_iref = i_ref;
    }

    // 3. Motor: bang-bang voltage, R-L with BEMF (paper section 2.2).
    const D i0 = z.i;
    const D w0 = z.w;
    // I += dt (V - k_t w - R I) / L with V = V_dc sgn(I_ref - I), arranged so that only the selects
    // follow the sign decision (the step's critical path): the three candidate currents are ready
    // before it. sgn(I_ref - I) compares I_ref with I directly (the same for every finite or infinite
    // pair: a difference of two different doubles is never zero), and I_base + (-dt V_dc / L) is
    // exactly I_base - dt V_dc / L.
    M v_up, v_down;
    if (s.sequence == Sequence::Brk) {
        v_up = i_ref > i0;
        v_down = i_ref < i0;
    } else {
        // I_ref = clamp(y, +/-I_max) = min(max(y, -I_max), I_max) is compared with I without waiting
        // for the clamp: min(a, M) > I <=> a > I and M > I; max(y, -M) > I <=> y > I or -M > I
        // (and the mirror images for <).
        const D y = s.k_w * (w_ref - w0);
        v_up = ((y > i0) | (-s.i_max > i0)) & (s.i_max > i0);
        v_down = ((y < i0) & (-s.i_max < i0)) | (s.i_max < i0);
    }
    const D i_base = i0 - s.dt_over_l * (s.k_t * w0 + s.r * i0);
    const double di_v = s.dt_over_l * s.v_dc;
    const D i1 = sel(v_up, i_base + di_v, sel(v_down, i_base - di_v, i_base + zero));
    z.i = i1;
    D t_m = vclamp(s.k_t * i1, -s.t_max, s.t_max);

    // 4. Load (section 4). Case B: hinge moment from the trim deviations, theta_m at step start.
    D th_load = z.th;
    if constexpr (kFull) th_load = th_load - z.gap;
    D h;
    if (s.load_case == LoadCase::B) {
        const D alpha_t = z.x[1] + z.x[3] * (kTailArmM / kAirspeedMS);
        const D delta_rad = th_load * s.inv_tau;
        h = -(kQbarPa * kSeM2 * kCeM * (kChAlphaPerRad * alpha_t + kChDeltaPerRad * delta_rad));
    } else if (s.load_case == LoadCase::AExt) {
        h = zero + (kCaseAHingeNm + kAExtHingeRateNmPerS * t);
    } else {
        h = zero + kCaseAHingeNm;
    }
    D f_r = h * s.inv_tau;

    // 5. Friction: Borello (paper eqs. 2, 3, 5).
    D extra_dyn = zero, extra_stat = zero, viscous = zero;
    M in_gap = M{};
    if constexpr (kFull) {
        D w0c = w0;
        for (int l = 0; l < W; ++l) {
            lane(t_m, l) += s.fx.ripple_amplitude_nm * std::sin(s.fx.ripple_periods_per_rev * lane(z.th, l));
            const double spall = s.fx.spall_amplitude_nm == 0.0 ? 0.0
                : s.fx.spall_amplitude_nm *
                      std::exp(-0.5 * std::pow((rad2deg(lane(th_load, l) * s.inv_tau) - s.fx.spall_center_deg) /
                                                   s.fx.spall_width_deg, 2));
            const double wr = lane(w0c, l) / s.fx.stribeck_speed_rad_s;
            lane(extra_dyn, l) = spall + s.fx.stribeck_amplitude_nm * std::exp(-wr * wr);
            lane(extra_stat, l) = spall;
        }
        viscous = s.fx.viscous_nm_s_rad * w0;
        // Backlash: inside the free play the load and the transmission friction are not felt.
        if (s.fx.backlash_rad > 0.0) in_gap = vabs(z.gap) < 0.5 * s.fx.backlash_rad;
        f_r = sel(in_gap, zero, f_r);
    }
    const D t_act = t_m - f_r;
    const M moving = w0 != 0.0;
    const M w_pos = w0 > 0.0;
    // Direction d = +1 where d_pos, else -1: sgn(w) while moving, sgn(T_act) (-1 at 0) while stuck.
    const M d_pos = w_pos | (vnot(moving) & (t_act > 0.0));
    // F_R d > 0 (opposing), without the multiplication by d = +/-1.
    const M opposing = (d_pos & (f_r > 0.0)) | (vnot(d_pos) & (f_r < 0.0));
    const D c = sel(opposing, z.c_opp, z.c_aid);
    const D c_fr = c * vabs(f_r);
    D dyn = z.fdj + c_fr;
    D stat = z.fsj + c_fr;
    if constexpr (kFull) {
        dyn = sel(in_gap, zero, dyn + extra_dyn);
        stat = sel(in_gap, zero, stat + extra_stat);
    }
    const M stuck = vnot(moving) & (vabs(t_act) <= stat);
    D t_slip = sel(d_pos, dyn, -dyn);  // d * dyn: friction while slipping (or breaking away)
    if constexpr (kFull) t_slip = t_slip + viscous;
    const D t_f = sel(stuck, t_act, t_slip);
    // w + dt (T_act - T_F) / J while slipping, arranged so T_act enters last (critical path).
    const D w_free = (w0 - t_slip * s.dt_inv_j) + t_act * s.dt_inv_j;
    // A moving shaft whose speed would change sign stops instead (max/min with 0 keep it one op deep).
    const M reversal_stop = moving & (w_free * w0 < 0.0);
    // w_new is 0 (stuck, or a moving shaft whose speed would change sign) or w_free. The two forms
    // below give the same value in every case; the faster one differs between the scalar step
    // (one decision, one select) and the vector step (max/min and blends).
    D w1;
    if constexpr (W == 1) {
        const M to_zero = stuck | (w_pos & (w_free < 0.0)) | ((moving & vnot(w_pos)) & (w_free > 0.0));
        w1 = sel(to_zero, zero, w_free);
    } else {
        const D w_slip = sel(w_pos, sel(w_free < 0.0, zero, w_free), sel(w_free > 0.0, zero, w_free));
        w1 = sel(moving, w_slip, sel(stuck, zero, w_free));
    }

    // 6. Position and end stops.
    D th1 = z.th + dt * w1;
    const M at_stop = vabs(th1) > s.stop_m;
    th1 = vclamp(th1, -s.stop_m, s.stop_m);
    const D w_before_stop = w1;
    w1 = sel(at_stop, zero, w1);
    if constexpr (kFull) {
        const double half = 0.5 * s.fx.backlash_rad;
        z.gap = vclamp(z.gap + (th1 - z.th), -half, half);
        const D v = sel(v_up, zero + s.v_dc, sel(v_down, zero - s.v_dc, zero));
        const D i_avg = 0.5 * (i0 + i1);
        z.e_in += v * i_avg * dt;
        z.e_cu += s.r * i0 * i_avg * dt;
        const D w_avg = 0.5 * (w0 + w1);
        z.e_fr += t_f * w_avg * dt;
        z.e_load += f_r * w_avg * dt;
        z.e_sat += (s.k_t * i1 - t_m) * w_avg * dt;
        // Kinetic energy removed by zeroing the speed (reversal stop and end stop).
        const D w_unclipped = sel(reversal_stop, w_free, w_before_stop);
        z.e_stop += sel(reversal_stop | at_stop, 0.5 * s.j * (w_unclipped * w_unclipped - w1 * w1), zero);
        z.sum_tf += t_f;
        z.sum_tm += t_m;
        z.sum_fr += f_r;
        z.stuck_count += sel(stuck, one, zero);
    }
    z.th = th1;
    z.w = w1;

    // BRK: end of a ramp after the position update; the next hold starts on the next step.
    if (s.sequence == Sequence::Brk) {
        const M moved = ramping & (vabs(th1 - z.ramp_start_th) >= kBrkMoveRad);
        const M up = phase == kPhaseRampUp;
        z.hold_end_n = sel(moved & up, zero + (static_cast<double>(n) + static_cast<double>(s.brk_mid_hold_steps)),
                           z.hold_end_n);
        z.phase = sel(moved, sel(up, zero + kPhaseHold1, zero + kPhaseHold2), phase);
    }

    // Period means (section 7): I after step 3, w after step 6, the H used in step 4.
    z.sum_i += i1;
    z.sum_w += w1;
    z.sum_h += h;
}

/// One step n, computing the command itself.
template <int W, bool kFull>
inline void step(const Shared& s, Lanes<W>& z, long n) {
    const double t = static_cast<double>(n) * s.dt;  // section 7: step n runs at t = n dt
    step<W, kFull>(s, z, n, s.tau * deg2rad(command_deg_inline(s.sequence, t)));
}

/// Case B aircraft update every 1e-4 s (section 3 step 7), forward Euler, delta_e in degrees.
template <int W, bool kFull>
inline void aircraft_update(const Shared& s, Lanes<W>& z) {
    using D = typename Vec<W>::D;
    D th_load = z.th;
    if constexpr (kFull) th_load = th_load - z.gap;
    const D de = th_load * s.inv_tau * (180.0 / std::numbers::pi);
    D dx[4];
    for (int r = 0; r < 4; ++r) dx[r] = kA[r][0] * z.x[0] + kA[r][1] * z.x[1] + kA[r][2] * z.x[2] + kA[r][3] * z.x[3];
    dx[3] += kB3 * de;
    for (int r = 0; r < 4; ++r) z.x[r] += kAircraftPeriodS * dx[r];
}

}  // namespace emadiag::sim::detail
