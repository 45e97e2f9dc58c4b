#pragma once
// The integration step of ema-reference.md section 3, written once over W lanes (structure of
// arrays). W = 1 is the scalar path; W = kBatchLanes is the SIMD batch. Every lane operation is
// branch-free so the compiler vectorises the lane loops; decisions are selects.
// kFull adds the effects beyond the datasheet, the truth and the energy accounts.
#include "emadiag/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

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
// BRK sequence (section 5).
inline constexpr double kBrkFirstHoldS = 0.05;
inline constexpr double kBrkMidHoldS = 0.1;
inline constexpr double kBrkRampAPerS = 10.0;
inline constexpr double kBrkMoveRad = 0.01;
// BRK phases.
inline constexpr double kPhaseHold0 = 0, kPhaseRampUp = 1, kPhaseHold1 = 2, kPhaseRampDown = 3, kPhaseHold2 = 4;

inline double deg2rad(double d) { return d * (std::numbers::pi / 180.0); }
inline double rad2deg(double r) { return r * (180.0 / std::numbers::pi); }

/// Parameters shared by every lane of a batch.
struct Shared {
    double dt, v_dc, r, l, k_t, i_max, t_max, w_max, inv_j, j, tau, k_theta, k_w, stop_m;
    LoadCase load_case;
    Sequence sequence;
    Effects fx;
    long steps_per_sample, steps_per_aircraft, total_samples, brk_first_hold_steps, brk_mid_hold_steps;
};

template <int W>
struct Lanes {
    // health parameters per lane
    double fdj[W], fsj[W], c_opp[W], c_aid[W];
    // state
    double i[W], w[W], th[W], x[4][W];
    double gap[W];  // backlash: motor angle minus load angle, within +/- backlash/2
    // BRK sequencer
    double phase[W], ramp_i[W], ramp_start_th[W], last_iref[W], hold_end_n[W];
    // period accumulators
    double sum_i[W], sum_w[W], sum_h[W], sum_tf[W], sum_tm[W], sum_fr[W], stuck_count[W];
    // energy accounts (kFull)
    double e_in[W], e_cu[W], e_fr[W], e_load[W], e_sat[W], e_stop[W];
    bool bad[W];
};

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

inline double sgn(double v) { return static_cast<double>((v > 0.0) - (v < 0.0)); }

template <int W, bool kFull>
inline void step(const Shared& s, Lanes<W>& z, long n) {
    const double t = static_cast<double>(n) * s.dt;  // section 7: step n runs at t = n dt
    // 1. Command (shared by all lanes).
    const double cmd_m = s.tau * deg2rad(command_deg_inline(s.sequence, t));
    double h_shared = kCaseAHingeNm;
    if (s.load_case == LoadCase::AExt) h_shared = kCaseAHingeNm + kAExtHingeRateNmPerS * t;
    const bool case_b = s.load_case == LoadCase::B;
    const bool brk = s.sequence == Sequence::Brk;
    const double brk_start_n = static_cast<double>(s.brk_first_hold_steps);
    const double dn = static_cast<double>(n);

#pragma GCC ivdep
    for (int l = 0; l < W; ++l) {
        // BRK: entering a ramp at the start of this step (section 5 and 7).
        double phase = z.phase[l];
        const bool start_up = brk && phase == kPhaseHold0 && dn > brk_start_n;
        const bool start_down = brk && phase == kPhaseHold1 && dn > z.hold_end_n[l];
        const bool start_ramp = start_up || start_down;
        phase = start_up ? kPhaseRampUp : (start_down ? kPhaseRampDown : phase);
        z.ramp_i[l] = start_ramp ? z.last_iref[l] : z.ramp_i[l];
        z.ramp_start_th[l] = start_ramp ? z.th[l] : z.ramp_start_th[l];
        const bool ramping = phase == kPhaseRampUp || phase == kPhaseRampDown;

        // 2. Controller.
        const double w_ref = std::clamp(s.k_theta * (cmd_m - z.th[l]), -s.w_max, s.w_max);
        const double i_pos = std::clamp(s.k_w * (w_ref - z.w[l]), -s.i_max, s.i_max);
        const double i_ramp = std::clamp(z.ramp_i[l], -s.i_max, s.i_max);
        const double i_ref = ramping ? i_ramp : i_pos;
        const double ramp_rate = phase == kPhaseRampUp ? kBrkRampAPerS : -kBrkRampAPerS;
        z.ramp_i[l] = ramping ? z.ramp_i[l] + ramp_rate * s.dt : z.ramp_i[l];
        z.last_iref[l] = i_ref;

        // 3. Motor: bang-bang voltage, R-L with BEMF (paper section 2.2).
        const double i0 = z.i[l];
        const double w0 = z.w[l];
        const double v = s.v_dc * sgn(i_ref - i0);
        const double i1 = i0 + s.dt * (v - s.k_t * w0 - s.r * i0) / s.l;
        z.i[l] = i1;
        double t_m = std::clamp(s.k_t * i1, -s.t_max, s.t_max);

        // 4. Load (section 4). Case B: hinge moment from the trim deviations, theta_m at step start.
        double h = h_shared;
        double th_load = z.th[l];
        if constexpr (kFull) th_load -= z.gap[l];
        if (case_b) {
            const double alpha_t = z.x[1][l] + z.x[3][l] * kTailArmM / kAirspeedMS;
            const double delta_rad = th_load / s.tau;
            h = -(kQbarPa * kSeM2 * kCeM * (kChAlphaPerRad * alpha_t + kChDeltaPerRad * delta_rad));
        }
        double f_r = h / s.tau;

        // 5. Friction: Borello (paper eqs. 2, 3, 5).
        double extra_dyn = 0.0, extra_stat = 0.0, viscous = 0.0;
        bool in_gap = false;
        if constexpr (kFull) {
            t_m += s.fx.ripple_amplitude_nm * std::sin(s.fx.ripple_periods_per_rev * z.th[l]);
            const double spall = s.fx.spall_amplitude_nm == 0.0 ? 0.0
                : s.fx.spall_amplitude_nm *
                      std::exp(-0.5 * std::pow((rad2deg(th_load / s.tau) - s.fx.spall_center_deg) /
                                                   s.fx.spall_width_deg, 2));
            const double wr = w0 / s.fx.stribeck_speed_rad_s;
            extra_dyn = spall + s.fx.stribeck_amplitude_nm * std::exp(-wr * wr);
            extra_stat = spall;
            viscous = s.fx.viscous_nm_s_rad * w0;
            // Backlash: inside the free play the load and the transmission friction are not felt.
            in_gap = s.fx.backlash_rad > 0.0 && std::abs(z.gap[l]) < 0.5 * s.fx.backlash_rad;
            f_r = in_gap ? 0.0 : f_r;
        }
        const double t_act = t_m - f_r;
        const bool moving = w0 != 0.0;
        const double d = moving ? sgn(w0) : (t_act > 0.0 ? 1.0 : -1.0);
        const double c = (f_r * d > 0.0) ? z.c_opp[l] : z.c_aid[l];
        const double abs_fr = std::abs(f_r);
        double dyn = z.fdj[l] + c * abs_fr + extra_dyn;
        double stat = z.fsj[l] + c * abs_fr + extra_stat;
        if constexpr (kFull) {
            dyn = in_gap ? 0.0 : dyn;
            stat = in_gap ? 0.0 : stat;
        }
        const bool stuck = !moving && std::abs(t_act) <= stat;
        const double t_f = stuck ? t_act : d * dyn + viscous;
        double w1 = stuck ? 0.0 : w0 + s.dt * (t_act - t_f) * s.inv_j;
        const bool reversal_stop = moving && (w1 * w0 < 0.0);
        w1 = reversal_stop ? 0.0 : w1;

        // 6. Position and end stops.
        double th1 = z.th[l] + s.dt * w1;
        const bool at_stop = th1 > s.stop_m || th1 < -s.stop_m;
        th1 = std::clamp(th1, -s.stop_m, s.stop_m);
        const double w_before_stop = w1;
        w1 = at_stop ? 0.0 : w1;
        if constexpr (kFull) {
            const double half = 0.5 * s.fx.backlash_rad;
            z.gap[l] = std::clamp(z.gap[l] + (th1 - z.th[l]), -half, half);
            const double i_avg = 0.5 * (i0 + i1);
            z.e_in[l] += v * i_avg * s.dt;
            z.e_cu[l] += s.r * i0 * i_avg * s.dt;
            const double w_avg = 0.5 * (w0 + w1);
            z.e_fr[l] += t_f * w_avg * s.dt;
            z.e_load[l] += f_r * w_avg * s.dt;
            z.e_sat[l] += (s.k_t * i1 - t_m) * w_avg * s.dt;
            // Kinetic energy removed by the zeroing of speed (reversal stop and end stop).
            const double w_unclipped = reversal_stop ? w0 + s.dt * (t_act - t_f) * s.inv_j : w_before_stop;
            z.e_stop[l] += (reversal_stop || at_stop) ? 0.5 * s.j * (w_unclipped * w_unclipped - w1 * w1) : 0.0;
            z.sum_tf[l] += t_f;
            z.sum_tm[l] += t_m;
            z.sum_fr[l] += f_r;
            z.stuck_count[l] += stuck ? 1.0 : 0.0;
        }
        z.th[l] = th1;
        z.w[l] = w1;

        // BRK: end of a ramp after the position update; the next hold starts on the next step.
        const bool moved = ramping && std::abs(th1 - z.ramp_start_th[l]) >= kBrkMoveRad;
        const double next_phase = phase == kPhaseRampUp ? kPhaseHold1 : kPhaseHold2;
        z.hold_end_n[l] = (moved && phase == kPhaseRampUp) ? dn + static_cast<double>(s.brk_mid_hold_steps)
                                                          : z.hold_end_n[l];
        z.phase[l] = moved ? next_phase : phase;

        // Period means (section 7): I after step 3, w after step 6, the H used in step 4.
        z.sum_i[l] += i1;
        z.sum_w[l] += w1;
        z.sum_h[l] += h;
    }
}

/// Case B aircraft update every 1e-4 s (section 3 step 7), forward Euler, delta_e in degrees.
template <int W, bool kFull>
inline void aircraft_update(const Shared& s, Lanes<W>& z) {
#pragma GCC ivdep
    for (int l = 0; l < W; ++l) {
        double th_load = z.th[l];
        if constexpr (kFull) th_load -= z.gap[l];
        const double de = rad2deg(th_load / s.tau);
        double dx[4];
        for (int r = 0; r < 4; ++r) {
            dx[r] = kA[r][0] * z.x[0][l] + kA[r][1] * z.x[1][l] + kA[r][2] * z.x[2][l] + kA[r][3] * z.x[3][l];
        }
        dx[3] += kB3 * de;
        for (int r = 0; r < 4; ++r) z.x[r][l] += kAircraftPeriodS * dx[r];
    }
}

}  // namespace emadiag::sim::detail
