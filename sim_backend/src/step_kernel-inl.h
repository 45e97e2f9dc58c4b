// The integration step of ema-reference.md section 3, written once over W lanes (structure of
// arrays), and the loop that runs groups of lanes from rest to the end of a run.
//
// No include guard: this body is included inside a namespace, once per lane type. The scalar path
// (W = 1, plain double and bool) includes it in emadiag::sim::detail (step_kernel.hpp); the batched
// path includes it once per Highway target in emadiag::sim::N_<TARGET> (batch_kernels.cpp), so
// each instruction set gets its own copy compiled for it. The enclosing namespace provides:
//   Vec<W>::D, Vec<W>::M           the lane vector of doubles and its mask;
//   sel(M, D, D), vnot(M), vabs(D) select, mask negation, |x| (sign bit cleared);
//   zero_if(M, D), keep_if(M, D)   sel(m, +0, x) and sel(m, x, +0) (one and-not / and on SIMD);
//   bcast<D>(double x)             every lane 0.0 + x (the value `D{} + x` gives, in one broadcast);
//   any(M)                         whether some lane's mask is set;
//   vxor(D, D), vmax(D lo, D a)    bitwise xor (a sign flip with -0); maxpd(lo, a), as clamp_below;
//   to_array(D, double*), from_array<D>(const double*) -> D;
//   namespace self                 an alias of the enclosing namespace (calls here are qualified,
//                                  so argument-dependent lookup cannot pick another copy).
// The operations are the same, in the same order, for every W (IEEE add, sub, mul, compare,
// select, sign-bit and/or; no FMA: the library builds with -ffp-contract=off), so every lane width
// gives the scalar path's results bit for bit.
// kFull adds the effects beyond the datasheet, the truth and the energy accounts.

template <int W>
struct Lanes {
    using D = typename Vec<W>::D;
    // health parameters per lane
    D fdj, fsj, c_opp, c_aid;
    // Per lane, read only by the kFull step: the effects beyond the datasheet (backlash is shared,
    // Shared::fx), the torque terms (null: none), the plant inertia J and dt / J.
    Effects fx[W];
    const std::vector<Term>* torque_terms[W];
    bool any_torque_terms;
    bool any_lane_effects;  // some lane has ripple, spall or Stribeck (library calls per step)
    D j, dt_inv_j, viscous;
    // state
    D i, w, th, x[4];
    D hinge_alpha;  // case B: kChAlphaPerRad * alpha_t, which changes with x only (hinge_alpha_of)
    D gap;  // backlash: motor angle minus load angle, within +/- backlash/2
    // BRK sequencer
    D phase, ramp_i, ramp_start_th, last_iref, hold_end_n;
    // period accumulators
    D sum_i, sum_w, sum_h, sum_tf, sum_tm, sum_fr, stuck_count;
    // energy accounts (kFull)
    D e_in, e_cu, e_fr, e_load, e_sat, e_stop;
};

template <class M>
inline M mask_of(bool b) { return b ? vnot(M{}) : M{}; }
/// clamp(a, lo, hi) as sel(a < lo, lo, a), then sel(a > hi, hi, a) (NaN stays NaN); the lane type
/// gives the two halves (clamp_below, clamp_above: one max and one min on x86 SIMD targets).
/// The bounds are 0 + lo and 0 + hi as before (-0 becomes +0: the backlash gap's bounds with no
/// backlash).
template <class D>
inline D vclamp(D a, double lo, double hi) {
    return self::clamp_above(self::clamp_below(a, 0.0 + lo), 0.0 + hi);
}

// The step's parts below are forced inline (as HWY_INLINE, not included on the scalar path): one body.
#ifndef EMADIAG_STEP_INLINE
#define EMADIAG_STEP_INLINE inline __attribute__((always_inline))
#endif

/// The lane types of W lanes, for the signatures of the step's parts.
template <int W> using VecD = typename Vec<W>::D;
template <int W> using VecM = typename Vec<W>::M;

/// BRK: entering a ramp at the start of step n (sections 5 and 7): the phase of this step, whether
/// it ramps and the ramp's current change per step.
template <int W>
EMADIAG_STEP_INLINE void brk_enter_ramp(const detail::Shared& s, Lanes<W>& z, long n, VecD<W>& phase, VecM<W>& ramping,
                                        VecD<W>& ramp_rate) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    using detail::kPhaseHold0, detail::kPhaseRampUp, detail::kPhaseHold1, detail::kPhaseRampDown;
    const double dt = s.dt;
    const double dn = static_cast<double>(n);
    const M start_up = (phase == kPhaseHold0) & mask_of<M>(dn > static_cast<double>(s.brk_first_hold_steps));
    const M start_down = (phase == kPhaseHold1) & (z.hold_end_n < dn);
    const M start_ramp = start_up | start_down;
    phase = sel(start_up, self::bcast<D>(kPhaseRampUp), sel(start_down, self::bcast<D>(kPhaseRampDown), phase));
    z.ramp_i = sel(start_ramp, z.last_iref, z.ramp_i);
    z.ramp_start_th = sel(start_ramp, z.th, z.ramp_start_th);
    ramping = (phase == kPhaseRampUp) | (phase == kPhaseRampDown);
    ramp_rate = sel(phase == kPhaseRampUp, self::bcast<D>(kBrkRampAPerS * dt), self::bcast<D>(0.0 - kBrkRampAPerS * dt));
}

/// Step 2 of BRK: the current reference, the speed loop's or the ramp's where it ramps (the ramp
/// advances by ramp_rate); kept as the last reference, where the next ramp starts.
template <int W>
EMADIAG_STEP_INLINE VecD<W> brk_current_ref(const detail::Shared& s, Lanes<W>& z, const VecD<W>& w_ref, const VecM<W>& ramping,
                                            const VecD<W>& ramp_rate) {
    using D = typename Vec<W>::D;
    const D i_pos = vclamp(s.k_w * (w_ref - z.w), -s.i_max, s.i_max);
    const D i_ref = sel(ramping, vclamp(z.ramp_i, -s.i_max, s.i_max), i_pos);
    z.ramp_i = sel(ramping, z.ramp_i + ramp_rate, z.ramp_i);
    z.last_iref = i_ref;
    return i_ref;
}

/// Step 3, the motor's bang-bang voltage V = V_dc sgn(I_ref - I): v_up where +V_dc, v_down where -V_dc.
/// I += dt (V - k_t w - R I) / L with V = V_dc sgn(I_ref - I), arranged so that only the selects
/// follow the sign decision (the step's critical path): the three candidate currents are ready
/// before it. sgn(I_ref - I) compares I_ref with I directly (the same for every finite or infinite
/// pair: a difference of two different doubles is never zero), and I_base + (-dt V_dc / L) is
/// exactly I_base - dt V_dc / L.
template <int W>
EMADIAG_STEP_INLINE void voltage_decision(const detail::Shared& s, const VecD<W>& w_ref, const VecD<W>& i_ref, const VecD<W>& i0,
                                          const VecD<W>& w0, VecM<W>& v_up, VecM<W>& v_down) {
    using D = typename Vec<W>::D;
    if (s.sequence == Sequence::Brk) {
        v_up = i_ref > i0;
        v_down = i_ref < i0;
    } else if constexpr (W > 1) {
        // The batched step is limited by its instruction count, not by this latency: I_ref itself
        // (one max and one min) and two compares instead of six compares and four mask operations.
        // The two forms differ only where y is NaN; y is NaN only where w is (th is NaN only where
        // w is, every parameter is finite), and then I_base is NaN and every candidate below is
        // that same NaN.
        const D i_ref_c = vclamp(s.k_w * (w_ref - w0), -s.i_max, s.i_max);
        v_up = i_ref_c > i0;
        v_down = i_ref_c < i0;
    } else {
        // I_ref = clamp(y, +/-I_max) = min(max(y, -I_max), I_max) is compared with I without waiting
        // for the clamp: min(a, M) > I <=> a > I and M > I; max(y, -M) > I <=> y > I or -M > I
        // (and the mirror images for <).
        const D y = s.k_w * (w_ref - w0);
        v_up = ((y > i0) | (-s.i_max > i0)) & (s.i_max > i0);
        v_down = ((y < i0) & (-s.i_max < i0)) | (s.i_max < i0);
    }
}

/// kFull, step 5: the effects beyond the datasheet (ripple on T_M, spall and Stribeck friction) use sin
/// and exp: lane by lane, the same library calls as the scalar path. Without ripple, spall and Stribeck
/// in any lane the loop below would leave T_M as it is and give +0 for both extras: the step skips it.
template <int W>
EMADIAG_STEP_INLINE void lane_effects(const detail::Shared& s, const Lanes<W>& z, const VecD<W>& th_load, const VecD<W>& w0,
                                      VecD<W>& t_m, VecD<W>& extra_dyn, VecD<W>& extra_stat) {
    using D = typename Vec<W>::D;
    double tm_a[W], th_a[W], thl_a[W], w0_a[W], dyn_a[W], stat_a[W];
    to_array(t_m, tm_a);
    to_array(z.th, th_a);
    to_array(th_load, thl_a);
    to_array(w0, w0_a);
    // Each lane has its own effect parameters (z.fx); an effect whose amplitude is zero adds
    // nothing and is skipped (a ripple of amplitude 0 would add +/-0 to T_M; Stribeck's 0 * exp
    // adds +0), so lanes without effects, such as a batch's padding, cost no library call.
    for (int l = 0; l < W; ++l) {
        const Effects& fx = z.fx[l];
        if (fx.ripple_amplitude_nm != 0.0) tm_a[l] += fx.ripple_amplitude_nm * std::sin(fx.ripple_periods_per_rev * th_a[l]);
        const double spall = fx.spall_amplitude_nm == 0.0 ? 0.0
            : fx.spall_amplitude_nm *
                  std::exp(-0.5 * std::pow((detail::rad2deg(thl_a[l] * s.inv_tau) - fx.spall_center_deg) /
                                               fx.spall_width_deg, 2));
        double stribeck = 0.0;
        if (fx.stribeck_amplitude_nm != 0.0) {
            const double wr = w0_a[l] / fx.stribeck_speed_rad_s;
            stribeck = fx.stribeck_amplitude_nm * std::exp(-wr * wr);
        }
        dyn_a[l] = spall + stribeck;
        stat_a[l] = spall;
    }
    t_m = self::from_array<D>(tm_a);
    extra_dyn = self::from_array<D>(dyn_a);
    extra_stat = self::from_array<D>(stat_a);
}

/// kFull: the extra torque T_x of the terms as data (term_hook.hpp), each lane its own terms,
/// evaluated for all lanes in one call that gives each lane the scalar path's value bit for bit.
template <int W>
EMADIAG_STEP_INLINE VecD<W> torque_terms_of(const detail::Shared& s, const Lanes<W>& z, long n, const VecD<W>& w0,
                                            const VecD<W>& th_load, const VecD<W>& f_r, const VecD<W>& i1) {
    using D = typename Vec<W>::D;
    const double dt = s.dt;
    double w_a[W], thm_a[W], thu_a[W], fr_a[W], i_a[W], tx_a[W];
    to_array(w0, w_a);
    to_array(z.th, thm_a);
    to_array(th_load * s.inv_tau, thu_a);
    to_array(f_r, fr_a);
    to_array(i1, i_a);
    detail::torque_terms_lanes(W, z.torque_terms, w_a, thm_a, thu_a, fr_a, static_cast<double>(n) * dt, i_a, tx_a);
    return self::from_array<D>(tx_a);
}

/// Step 5, the direction of friction d = +1 where d_pos, else -1: sgn(w) while moving, sgn(T_act)
/// (-1 at 0) while stuck; and the load coefficient c of eq. (3) that F_R d selects.
template <int W>
EMADIAG_STEP_INLINE VecD<W> friction_direction(const Lanes<W>& z, const VecD<W>& w0, const VecD<W>& t_act, const VecD<W>& f_r,
                                               const VecM<W>& still, const VecM<W>& w_pos, VecM<W>& d_pos, VecD<W>& d_sign) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    const D zero{};
    if constexpr (W == 1) {
        d_pos = w_pos | (still & (t_act > 0.0));
    } else {
        // The same mask in a blend and a compare (one op and one mask fewer), kept as a sign bit:
        // x d = x ^ d_sign (Neg flips the sign bit), so the mask dies here (AVX-512 has 8 mask
        // registers for K groups' masks).
        d_pos = sel(still, t_act, w0) > 0.0;
        d_sign = self::zero_if(d_pos, -zero);
    }
    // c_opp where F_R d > 0 (opposing: F_R > 0 for d = +1, F_R < 0 for d = -1), else c_aid.
    D c;
    if constexpr (W == 1) {
        const M opposing = (d_pos & (f_r > 0.0)) | (vnot(d_pos) & (f_r < 0.0));
        c = sel(opposing, z.c_opp, z.c_aid);
    } else {
        // The same choice in blends: fewer live masks (AVX-512 has 8 mask registers; K groups of
        // masks spill to general registers) and no mask logic. F_R d > 0 as (d_pos ? F_R : -F_R) > 0
        // (-(-0) = +0 is not > 0, NaN is not): one compare and one blend fewer.
        c = sel(self::vxor(f_r, d_sign) > 0.0, z.c_opp, z.c_aid);
    }
    return c;
}

/// Step 5's new speed w_new: 0 (stuck, or a moving shaft whose speed would change sign) or w_free.
/// The two forms below give the same value in every case; the faster one differs between the scalar
/// step (one decision, one select) and the vector step (blends). d_sign is read by the vector step
/// only (the scalar step leaves it unset).
template <int W>
EMADIAG_STEP_INLINE VecD<W> speed_after_friction(const VecD<W>& w_free, [[maybe_unused]] const VecD<W>& t_act,
                                                 [[maybe_unused]] const VecD<W>& stat, [[maybe_unused]] const VecD<W>& d_sign,
                                                 [[maybe_unused]] const VecM<W>& stuck, [[maybe_unused]] const VecM<W>& still,
                                                 [[maybe_unused]] const VecM<W>& moving, [[maybe_unused]] const VecM<W>& w_pos) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    D w1;
    if constexpr (W == 1) {
        const M to_zero = stuck | (w_pos & (w_free < 0.0)) | ((moving & vnot(w_pos)) & (w_free > 0.0));
        w1 = self::zero_if(to_zero, w_free);
    } else {
        // sel(w_free < 0, 0, w_free) and sel(w_free > 0, 0, w_free): one max / min with +0 each.
        // Moving, d_pos is w_pos (NaN w: both false), and min(+0, x) is -max(-0, -x) per lane (NaN and
        // signed zeros included), so with d_sign = +0 / -0: w_slip = max(d_sign, w_free d) d, and
        // neither w_pos nor stuck stays live as a mask (the static case tests |T_act| <= stat here).
        const D w_slip = self::vxor(self::vmax(d_sign, self::vxor(w_free, d_sign)), d_sign);
        // Most steps have every lane of a group moving: the static lanes' selects only when one is.
        w1 = w_slip;
        if (self::any(still)) w1 = sel(still, self::zero_if(vabs(t_act) <= stat, w_free), w_slip);
    }
    return w1;
}

/// kFull: the electrical energy accounts of one step, sum V I dt in and sum R I^2 dt of copper loss
/// (I the mean of the step's start and end currents).
template <int W>
EMADIAG_STEP_INLINE void electrical_energy(const detail::Shared& s, Lanes<W>& z, const VecM<W>& v_up, const VecM<W>& v_down,
                                           const VecD<W>& i0, const VecD<W>& i1) {
    using D = typename Vec<W>::D;
    const double dt = s.dt;
    const D v = sel(v_up, self::bcast<D>(s.v_dc), self::keep_if(v_down, self::bcast<D>(0.0 - s.v_dc)));
    const D i_avg = 0.5 * (i0 + i1);
    z.e_in = z.e_in + v * i_avg * dt;
    z.e_cu = z.e_cu + s.r * i0 * i_avg * dt;
}

/// BRK: the end of a ramp after the position update; the next hold starts on the next step.
template <int W>
EMADIAG_STEP_INLINE void brk_end_ramp(const detail::Shared& s, Lanes<W>& z, long n, const VecD<W>& th1, const VecD<W>& phase,
                                      const VecM<W>& ramping) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    using detail::kPhaseRampUp, detail::kPhaseHold1, detail::kPhaseHold2;
    const M moved = ramping & (vabs(th1 - z.ramp_start_th) >= kBrkMoveRad);
    const M up = phase == kPhaseRampUp;
    z.hold_end_n = sel(moved & up, self::bcast<D>(static_cast<double>(n) + static_cast<double>(s.brk_mid_hold_steps)),
                       z.hold_end_n);
    z.phase = sel(moved, sel(up, self::bcast<D>(kPhaseHold1), self::bcast<D>(kPhaseHold2)), phase);
}

/// One step with the command of step n, cmd_m = tau * radians(command_deg(t = n dt)), computed by
/// the caller (it is shared by every lane and group of a batch).
template <int W, bool kFull>
inline void step(const detail::Shared& shared, Lanes<W>& z, long n, double cmd_m) {
    using D = typename Vec<W>::D;
    using M = typename Vec<W>::M;
    const detail::Shared& s = shared;
    const double dt = s.dt;
    const double t = static_cast<double>(n) * dt;  // section 7: step n runs at t = n dt
    const D zero{};
    const D one = self::bcast<D>(1.0);

    // BRK: entering a ramp at the start of this step (sections 5 and 7).
    D phase = z.phase;
    M ramping = M{};
    D ramp_rate = zero;
    if (s.sequence == Sequence::Brk) self::brk_enter_ramp<W>(s, z, n, phase, ramping, ramp_rate);

    // 1. Command: cmd_m (shared by all lanes).
    // 2. Controller.
    const D w_ref = vclamp(s.k_theta * (cmd_m - z.th), -s.w_max, s.w_max);
    D i_ref = zero;  // BRK only: the other sequences compare with I_ref's clamp below without forming it
    if (s.sequence == Sequence::Brk) i_ref = self::brk_current_ref<W>(s, z, w_ref, ramping, ramp_rate);

    // 3. Motor: bang-bang voltage, R-L with BEMF (paper section 2.2).
    const D i0 = z.i;
    const D w0 = z.w;
    // I += dt (V - k_t w - R I) / L, the sign decision first (voltage_decision).
    M v_up, v_down;
    self::voltage_decision<W>(s, w_ref, i_ref, i0, w0, v_up, v_down);
    const D i_base = i0 - s.dt_over_l * (s.k_t * w0 + s.r * i0);
    const double di_v = s.dt_over_l * s.v_dc;
    D i1;
    if constexpr (W == 1) {
        i1 = sel(v_up, i_base + di_v, sel(v_down, i_base - di_v, i_base + zero));
    } else {
        // The same sums with the increment selected first (one add instead of three; x - y is
        // x + (-y) in IEEE arithmetic).
        i1 = i_base + sel(v_up, self::bcast<D>(di_v), self::keep_if(v_down, self::bcast<D>(0.0 - di_v)));
    }
    z.i = i1;
    D t_m = vclamp(s.k_t * i1, -s.t_max, s.t_max);

    // 4. Load (section 4). Case B: hinge moment from the trim deviations, theta_m at step start.
    D th_load = z.th;
    if constexpr (kFull) th_load = th_load - z.gap;
    D h;
    if (s.load_case == LoadCase::B) {
        const D delta_rad = th_load * s.inv_tau;
        // -(K x) written as (-K) x: the same double (rounding is symmetric in the sign), one sign flip
        // fewer on the step's critical path (theta -> F_R -> friction -> w -> theta).
        constexpr double kNegHingeGain = -(detail::kQbarPa * detail::kSeM2 * detail::kCeM);
        h = kNegHingeGain * (z.hinge_alpha + detail::kChDeltaPerRad * delta_rad);
    } else if (s.load_case == LoadCase::AExt) {
        h = self::bcast<D>(detail::kCaseAHingeNm + detail::kAExtHingeRateNmPerS * t);
    } else {
        h = self::bcast<D>(detail::kCaseAHingeNm);
    }
    D f_r = h * s.inv_tau;

    // 5. Friction: Borello (paper eqs. 2, 3, 5).
    D extra_dyn = zero, extra_stat = zero, viscous = zero;
    M in_gap = M{};
    if constexpr (kFull) {
        // Without ripple, spall and Stribeck in any lane: skipped (see lane_effects).
        if (z.any_lane_effects) self::lane_effects<W>(s, z, th_load, w0, t_m, extra_dyn, extra_stat);
        viscous = z.viscous * w0;
        // Backlash: inside the free play the load and the transmission friction are not felt.
        if (s.fx.backlash_rad > 0.0) in_gap = vabs(z.gap) < 0.5 * s.fx.backlash_rad;
        f_r = self::zero_if(in_gap, f_r);
    }
    // Terms as data (term_hook.hpp): an extra torque T_x (torque_terms_of).
    D t_x = zero;
    if constexpr (kFull) { if (z.any_torque_terms) t_x = self::torque_terms_of<W>(s, z, n, w0, th_load, f_r, i1); }
    D t_act = t_m - f_r;
    if constexpr (kFull) t_act = t_act - t_x;  // without terms x - (+0) = x: the fast step skips it
    const M still = w0 == 0.0;
    const M moving = vnot(still);
    const M w_pos = w0 > 0.0;
    M d_pos;
    D d_sign;  // vector step: -0 (the sign bit) where d = -1, +0 where d = +1
    const D c = self::friction_direction<W>(z, w0, t_act, f_r, still, w_pos, d_pos, d_sign);
    const D c_fr = c * vabs(f_r);
    D dyn = z.fdj + c_fr;
    D stat = z.fsj + c_fr;
    if constexpr (kFull) {
        dyn = self::zero_if(in_gap, dyn + extra_dyn);
        stat = self::zero_if(in_gap, stat + extra_stat);
    }
    const M stuck = still & (vabs(t_act) <= stat);
    D t_slip;  // d * dyn: friction while slipping (or breaking away)
    if constexpr (W == 1) {
        t_slip = sel(d_pos, dyn, -dyn);
    } else {
        t_slip = self::vxor(dyn, d_sign);
    }
    if constexpr (kFull) t_slip = t_slip + viscous;
    const D t_f = sel(stuck, t_act, t_slip);
    // w + dt (T_act - T_F) / J while slipping, arranged so T_act enters last (critical path). J is
    // per lane in the kFull step (a true inertia is an effect).
    D w_free;
    if constexpr (kFull) {
        w_free = (w0 - t_slip * z.dt_inv_j) + t_act * z.dt_inv_j;
    } else {
        w_free = (w0 - t_slip * s.dt_inv_j) + t_act * s.dt_inv_j;
    }
    // A moving shaft whose speed would change sign stops instead (max/min with 0 keep it one op deep).
    const M reversal_stop = moving & (w_free * w0 < 0.0);
    D w1 = self::speed_after_friction<W>(w_free, t_act, stat, d_sign, stuck, still, moving, w_pos);

    // 6. Position and end stops.
    D th1 = z.th + dt * w1;
    const M at_stop = vabs(th1) > s.stop_m;
    if constexpr (W == 1) {
        // Within the stops the clamp gives theta back unchanged (NaN too): the scalar step branches
        // around it (rarely taken), so its max and min leave the step's critical path.
        if (at_stop) [[unlikely]] th1 = vclamp(th1, -s.stop_m, s.stop_m);
    }
    const D w_before_stop = w1;
    if constexpr (W == 1) {
        w1 = self::zero_if(at_stop, w1);
    } else if (self::any(at_stop)) [[unlikely]] {  // the group's lanes within the stops keep theta and w
        th1 = vclamp(th1, -s.stop_m, s.stop_m);
        w1 = self::zero_if(at_stop, w1);
    }
    if constexpr (kFull) {
        const double half = 0.5 * s.fx.backlash_rad;
        z.gap = vclamp(z.gap + (th1 - z.th), -half, half);
        self::electrical_energy<W>(s, z, v_up, v_down, i0, i1);
        const D w_avg = 0.5 * (w0 + w1);
        z.e_fr = z.e_fr + t_f * w_avg * dt;
        z.e_load = z.e_load + (f_r + t_x) * w_avg * dt;
        z.e_sat = z.e_sat + (s.k_t * i1 - t_m) * w_avg * dt;
        // Kinetic energy removed by zeroing the speed (reversal stop and end stop).
        const D w_unclipped = sel(reversal_stop, w_free, w_before_stop);
        z.e_stop = z.e_stop + self::keep_if(reversal_stop | at_stop, 0.5 * z.j * (w_unclipped * w_unclipped - w1 * w1));
        z.sum_tf = z.sum_tf + t_f;
        z.sum_tm = z.sum_tm + t_m;
        z.sum_fr = z.sum_fr + f_r;
        z.stuck_count = z.stuck_count + self::keep_if(stuck, one);
    }
    z.th = th1;
    z.w = w1;

    // BRK: end of a ramp after the position update; the next hold starts on the next step.
    if (s.sequence == Sequence::Brk) self::brk_end_ramp<W>(s, z, n, th1, phase, ramping);

    // Period means (section 7): I after step 3, w after step 6, the H used in step 4.
    z.sum_i = z.sum_i + i1;
    z.sum_w = z.sum_w + w1;
    z.sum_h = z.sum_h + h;
}

/// One step n, computing the command itself.
template <int W, bool kFull>
inline void step(const detail::Shared& s, Lanes<W>& z, long n) {
    const double t = static_cast<double>(n) * s.dt;  // section 7: step n runs at t = n dt
    self::step<W, kFull>(s, z, n, s.tau * detail::deg2rad(detail::command_deg_inline(s.sequence, t)));
}

/// Case B: the part of the hinge moment's bracket that depends on the aircraft state only,
/// kChAlphaPerRad * alpha_t with alpha_t = x[1] + x[3] l_t / V (section 4); kept in Lanes::hinge_alpha
/// between aircraft updates (the same double the step would compute from x every step).
template <int W>
inline void update_hinge_alpha(Lanes<W>& z) {
    const auto alpha_t = z.x[1] + z.x[3] * (detail::kTailArmM / detail::kAirspeedMS);
    z.hinge_alpha = detail::kChAlphaPerRad * alpha_t;
}

/// Case B aircraft update every 1e-4 s (section 3 step 7), forward Euler, delta_e in degrees.
template <int W, bool kFull>
inline void aircraft_update(const detail::Shared& s, Lanes<W>& z) {
    using D = typename Vec<W>::D;
    D th_load = z.th;
    if constexpr (kFull) th_load = th_load - z.gap;
    const D de = th_load * s.inv_tau * (180.0 / std::numbers::pi);
    D dx[4];
    for (int r = 0; r < 4; ++r) {
        dx[r] = detail::kA[r][0] * z.x[0] + detail::kA[r][1] * z.x[1] + detail::kA[r][2] * z.x[2] +
                detail::kA[r][3] * z.x[3];
    }
    dx[3] = dx[3] + detail::kB3 * de;
    for (int r = 0; r < 4; ++r) z.x[r] = z.x[r] + kAircraftPeriodS * dx[r];
    self::update_hinge_alpha(z);
}

/// Runs G interleaved groups of W lanes from rest to the end; lane l of group g fills out[g * W + l].
/// Interleaving independent groups hides the latency of the step's dependency chain.
template <int W, int G, bool kFull>
inline void run_lanes(const detail::Shared& shared, Lanes<W>* z, SimResult* const* out, bool record_truth) {
    const detail::Shared s = shared;  // a local copy: the lane stores cannot alias it, so its fields stay in registers
    for (int l = 0; l < W * G; ++l) {
        out[l]->samples.resize(static_cast<std::size_t>(s.total_samples));
        if (record_truth) out[l]->truth.resize(static_cast<std::size_t>(s.total_samples));
    }
    const long aircraft_per_sample = s.steps_per_sample / s.steps_per_aircraft;
    const double inv_steps = 1.0 / static_cast<double>(s.steps_per_sample);
    const bool case_b = s.load_case == LoadCase::B;
    using D = typename Vec<W>::D;
    long n = 0;
    for (long k = 0; k < s.total_samples; ++k) {
        for (int g = 0; g < G; ++g) {
            z[g].sum_i = z[g].sum_w = z[g].sum_h = z[g].sum_tf = z[g].sum_tm = z[g].sum_fr = z[g].stuck_count = D{};
        }
        for (long a = 0; a < aircraft_per_sample; ++a) {
            for (long j = 0; j < s.steps_per_aircraft; ++j) {
                ++n;
                const double t_step = static_cast<double>(n) * s.dt;  // section 7: step n runs at t = n dt
                const double cmd_m = s.tau * detail::deg2rad(detail::command_deg_inline(s.sequence, t_step));
                for (int g = 0; g < G; ++g) self::step<W, kFull>(s, z[g], n, cmd_m);
            }
            if (case_b) {
                for (int g = 0; g < G; ++g) self::aircraft_update<W, kFull>(s, z[g]);
            }
        }
        const double t = static_cast<double>(n) * s.dt;
        const double cmd = detail::command_deg_inline(s.sequence, t);
        for (int g = 0; g < G; ++g) {
            Lanes<W>& zg = z[g];
            double sum_i[W], sum_w[W], th[W], sum_h[W];
            double sum_tf[W]{}, sum_tm[W]{}, sum_fr[W]{}, stuck[W]{};  // filled when record_truth
            to_array(zg.sum_i, sum_i);
            to_array(zg.sum_w, sum_w);
            to_array(zg.th, th);
            to_array(zg.sum_h, sum_h);
            if (record_truth) {
                to_array(zg.sum_tf, sum_tf);
                to_array(zg.sum_tm, sum_tm);
                to_array(zg.sum_fr, sum_fr);
                to_array(zg.stuck_count, stuck);
            }
            for (int l = 0; l < W; ++l) {
                SimResult& r = *out[g * W + l];
                Sample& smp = r.samples[static_cast<std::size_t>(k)];
                smp.t_s = t;
                smp.current_a = sum_i[l] * inv_steps;
                smp.speed_rad_s = sum_w[l] * inv_steps;
                smp.theta_m_rad = th[l];
                smp.hinge_moment_nm = sum_h[l] * inv_steps;
                smp.command_deg = cmd;
                if (!std::isfinite(smp.current_a) || !std::isfinite(smp.speed_rad_s) ||
                    !std::isfinite(smp.theta_m_rad) || !std::isfinite(smp.hinge_moment_nm)) {
                    r.finite = false;
                }
                if (record_truth) {
                    SampleTruth& tr = r.truth[static_cast<std::size_t>(k)];
                    tr.friction_torque_nm = sum_tf[l] * inv_steps;
                    tr.motor_torque_nm = sum_tm[l] * inv_steps;
                    tr.load_torque_nm = sum_fr[l] * inv_steps;
                    tr.stuck_all_period = stuck[l] == static_cast<double>(s.steps_per_sample);
                }
            }
        }
    }
    if constexpr (kFull) {
        for (int g = 0; g < G; ++g) {
            Lanes<W>& zg = z[g];
            double e_in[W], e_cu[W], e_fr[W], e_load[W], e_sat[W], e_stop[W], i[W], w[W], j[W];
            to_array(zg.e_in, e_in);
            to_array(zg.e_cu, e_cu);
            to_array(zg.e_fr, e_fr);
            to_array(zg.e_load, e_load);
            to_array(zg.e_sat, e_sat);
            to_array(zg.e_stop, e_stop);
            to_array(zg.i, i);
            to_array(zg.w, w);
            to_array(zg.j, j);
            for (int l = 0; l < W; ++l) {
                EnergyAccount& e = out[g * W + l]->energy;
                e.electrical_in_j = e_in[l];
                e.copper_loss_j = e_cu[l];
                e.friction_work_j = e_fr[l];
                e.load_work_j = e_load[l];
                e.saturation_loss_j = e_sat[l];
                e.stop_loss_j = e_stop[l];
                e.stored_start_j = 0.0;
                e.stored_end_j = 0.5 * s.l * i[l] * i[l] + 0.5 * j[l] * w[l] * w[l];
            }
        }
    }
}

/// Runs W * G simulations on G groups of W lanes, then finishes each run (truth, sensor effects and
/// terms, noise). They may differ in health, in the effects other than backlash, in the plant
/// inertia and in their terms (checked by the caller); everything else is configs[0]'s.
template <int W, int G>
inline void run_group(const SimConfig* const* configs, SimResult* const* out) {
    using D = typename Vec<W>::D;
    const detail::Shared s = detail::make_shared(*configs[0]);
    auto z = std::make_unique<Lanes<W>[]>(G);
    for (int g = 0; g < G; ++g) {
        double fdj[W], fsj[W], c_opp[W], c_aid[W], j[W], dt_inv_j[W], viscous[W];
        z[g].any_torque_terms = false;
        z[g].any_lane_effects = false;
        for (int l = 0; l < W; ++l) {
            const EmaParams& p = configs[g * W + l]->params;
            fdj[l] = p.fdj_nm;
            fsj[l] = p.fsj_nm;
            c_opp[l] = ::emadiag::sim::load_coefficient_opposing(p.eta_o);  // eq. (3), opposing
            c_aid[l] = ::emadiag::sim::load_coefficient_aiding(p.eta_a);    // eq. (3), aiding
            // As make_shared computes them for the lane's own parameters.
            j[l] = p.plant_inertia_kgm2();
            dt_inv_j[l] = p.dt_s * (1.0 / j[l]);
            viscous[l] = p.effects.viscous_nm_s_rad;
            z[g].fx[l] = p.effects;
            z[g].torque_terms[l] = detail::has_torque_terms(p.terms) ? &p.terms : nullptr;
            z[g].any_torque_terms = z[g].any_torque_terms || z[g].torque_terms[l] != nullptr;
            z[g].any_lane_effects = z[g].any_lane_effects || p.effects.ripple_amplitude_nm != 0.0 ||
                                    p.effects.spall_amplitude_nm != 0.0 || p.effects.stribeck_amplitude_nm != 0.0;
        }
        z[g].j = self::from_array<D>(j);
        z[g].dt_inv_j = self::from_array<D>(dt_inv_j);
        z[g].viscous = self::from_array<D>(viscous);
        z[g].fdj = self::from_array<D>(fdj);
        z[g].fsj = self::from_array<D>(fsj);
        z[g].c_opp = self::from_array<D>(c_opp);
        z[g].c_aid = self::from_array<D>(c_aid);
        self::update_hinge_alpha(z[g]);  // from the state at rest
    }
    bool full = false;
    bool truth = false;
    for (int l = 0; l < W * G; ++l) {
        full = full || configs[l]->record_truth || configs[l]->params.effects.any() || !configs[l]->params.terms.empty();
        truth = truth || configs[l]->record_truth;
    }
    if (full) {
        self::run_lanes<W, G, true>(s, z.get(), out, truth);
    } else {
        self::run_lanes<W, G, false>(s, z.get(), out, false);
    }
    for (int l = 0; l < W * G; ++l) detail::finish_run(*configs[l], *out[l]);
}
