#pragma once
// The breakaway events of a BRK run (ema-reference.md section 5): FSJ made observable.
//
// In direction d the shaft breaks away when d (k_t I - F_R) = FSJ + c(d) |F_R|, with I the
// INSTANTANEOUS current. The bang-bang current loop chatters around the ramp demand I_ref: after
// each up-step of u = (V_dc - R |I|) dt / L (0.108 A) the current peaks above I_ref, and the
// peaks sweep the band (I_ref, I_ref + u] every u L / (R (|I| + ramp_rate L / R) dt) steps, during
// which I_ref rises by r = ramp_rate u L / (R |I| + ramp_rate L). So the shaft breaks away when I_ref + u - r/2 (+/- r/2, uniform)
// reaches the threshold, while the SAMPLE-MEAN current still tracks I_ref (section 5 note).
//
// Steps, per direction:
//  1. Noise levels from the first 50 ms position hold (stuck: the speed is exactly zero on clean
//     data, which selects the exact method below).
//  2. The breakaway time t_b:
//     - clean data: the first sample with d w > 0 brackets t_b to one period; inside it, t_b is
//       the best fit of the slip trajectory below (or the middle of the period if that fails);
//       when the fitted g0 is below half a chatter step k_t u / 2, the chatter troughs fall below
//       dynamic friction and the shaft stick-slips at first, which the smooth trajectory fits
//       with too early an onset: t_b is then uniform between the fitted onset and the period end;
//     - noisy data: a profile least-squares fit of the slip trajectory up to the ramp end: for
//       t > t_b, J dw/dt = g0 + g1 (t - t_b), g1 known from the ramp rate and the load slope;
//       the start angle is the hold angle and the sequence's end condition (the shaft has moved
//       kBrkMoveRad at the ramp end, timed from the current's switch to the hold demand inside
//       its sample) fixes g0, so t_b is the only unknown. Speeds are period means, angles
//       end-of-period values. The fit goes on past the move end: the position hold brings the
//       shaft to rest from the slip's end speed against its dynamic friction, and the hold's
//       first samples (speed, angle, and the current while the shaft moves, which reads the
//       speed through the speed loop) tell a late, steep slip from an early, slow one.
//  3. I_ref(t) = I_start + d ramp_rate (t - t_start): I_start is the hold demand from the
//     controller law (theta measured, w = 0), t_start the sequence's ramp start (the second ramp:
//     100 ms after the move end of the first). The ramp end is found where the sample-mean
//     current leaves the expected chatter mean of the ramp (a logarithmic mean: the 2-cycle
//     centre decays towards zero at R c / L between jumps of u).
//  4. F_R at t_b from a local linear fit of the hinge moment.
//  5. Threshold S_d = d (k_t (I_ref(t_b) + d u_eff) - F_R) = FSJ + c(d)|F_R|, with a standard
//     error from t_b, I_start, the chatter sweep and F_R. On noisy data the whole posterior of S
//     is kept as a Gaussian mixture (threshold_posterior): one component per point of the t_b
//     profile (a flat prior in S, which is linear in t_b), blurred by the other error terms; and,
//     when the data allow g0 = 0 (the torque only just overcame FDJ), FSJ - FDJ may be below one
//     chatter step k_t u: the shaft then stick-slips on the current peaks before it moves,
//     invisibly in noisy means, so the posterior also spreads uniformly over
//     [S(g0 = 0) - k_t u, S(g0 = 0)] with the likelihood of the zero-acceleration start. S_d is
//     its mean. The estimator multiplies the two directions' posteriors (product_posterior).
//  6. Also the dynamic friction D_d = FDJ + c(d)|F_R|. Clean data: the telescoped mean T_R over
//     the fully slipping samples (from two samples after one at 30 % of the final ramp speed, past
//     any stick-slip, to the ramp end), when there are at least kMinSlipSamples; its se includes
//     the chatter beat's wander of the mean current (it bends the speed between the period means
//     that stand for the window's end speeds). Noisy data: the posterior of step 5's slip
//     trajectories mapped to D_d = d (k_t I_mean(t_b) - F_R) - d g0 (dynamic_posterior).
#include "core/run.hpp"
#include "estimation/dataset.hpp"
#include "emadiag/sim/simulator.hpp"

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace emadiag {

/// Section 5, the BRK sequence: one definition, shared with the simulator.
using sim::kBrkFirstHoldS;
inline constexpr double kBrkHoldS = sim::kBrkMidHoldS;
using sim::kBrkRampAPerS;
using sim::kBrkMoveRad;
/// Section 1, the drive, for the chatter step of the section-5 note: the datasheet's values, as
/// the simulator's defaults hold them (a BRK run's header does not carry them).
inline constexpr double kDriveSupplyV = sim::EmaParams{}.v_dc_v;
inline constexpr double kStatorResistanceOhm = sim::EmaParams{}.r_ohm;
inline constexpr double kStatorInductanceH = sim::EmaParams{}.l_h;
inline constexpr double kCurrentLoopStepS = sim::EmaParams{}.dt_s;
/// Section 1, the controller: I_ref = K_w (K_theta (theta_cmd_m - theta_m) - w).
inline constexpr double kPositionLoopGainPerS = sim::EmaParams{}.k_theta_per_s;
inline constexpr double kSpeedLoopGainAsPerRad = sim::EmaParams{}.k_w_a_s_per_rad;
/// A drop of the current below the ramp line by this much marks the ramp end (hold takes over).
inline constexpr double kRampEndDropA = 0.15;
/// Fewest fully slipping samples for a dynamic-friction value from a breakaway slip.
inline constexpr std::size_t kMinSlipSamples = 3;
/// How far back before the ramp end the trajectory fit looks.
inline constexpr double kTrajectoryWindowS = 0.04;

/// One component of a Gaussian mixture (a posterior density on a line).
struct MixtureComponent {
    double mean = 0, sd = 0, weight = 0;
};

struct BreakawayEvent {
    int direction = 0;                  ///< +1 (first ramp) or -1 (second ramp)
    std::string method;                 ///< "exact-speed" (clean data) or "trajectory-fit"
    std::size_t ramp_first = 0;         ///< first sample fully inside the ramp
    std::size_t breakaway_sample = 0;   ///< sample whose period holds t_b
    std::size_t ramp_end_sample = 0;    ///< sample whose period holds the ramp end
    double t_breakaway_s = 0, t_breakaway_se_s = 0;
    double ramp_current_a = 0, ramp_current_se_a = 0;  ///< I_ref(t_b)
    double chatter_offset_a = 0, chatter_se_a = 0;     ///< u - r/2 and r/sqrt(12)
    double load_torque_nm = 0, load_torque_se_nm = 0;  ///< F_R at t_b (signed)
    double threshold_nm = 0, threshold_se_nm = 0;      ///< S_d = FSJ + c(d)|F_R|
    double slip_accel_torque_nm = 0;                   ///< fitted g0 (J dw/dt just after t_b)
    std::optional<double> dynamic_friction_nm;         ///< clean data: D_d = FDJ + c(d)|F_R| (step 6)
    double dynamic_friction_se_nm = 0;
    std::size_t slip_samples = 0;
    double t_move_end_s = 0;            ///< when the shaft had moved kBrkMoveRad (ramp end)
    double stick_slip_weight = 0;       ///< noisy data: posterior weight of a stick-slip start (step 5)
    /// Noisy data: the whole posterior of S_d (step 5) as a Gaussian mixture, weights summing to 1;
    /// empty on clean data. threshold_nm is its mean and threshold_se_nm its sd.
    std::vector<MixtureComponent> threshold_posterior;
    /// Noisy data: the posterior of D_d = FDJ + c(d)|F_R| from the same slip trajectory (step 6).
    std::vector<MixtureComponent> dynamic_posterior;
};

struct BreakawayAnalysis {
    bool clean = false;  ///< speeds exactly zero while stuck: noise-free data
    double sigma_speed_rad_s = 0, sigma_theta_rad = 0, sigma_current_a = 0, sigma_hinge_nm = 0;
    std::vector<BreakawayEvent> events;  ///< up to two, in time order
    std::vector<std::string> problems;   ///< why an event was not found
};

/// Expected sample-mean current of the bang-bang chatter around a demand I_ref that ramps at
/// `ramp_a_s` (away from zero) or holds (0): the 2-cycle centre c decays towards zero at R c / L
/// and jumps by u when it leaves the band I_ref +/- u/2, so the time average over the band is a
/// logarithmic mean (with the ramp, of the band shifted by ramp L / R). Zero inside +/- u/2.
[[nodiscard]] double chatter_mean_current_a(double i_ref_a, double ramp_a_s);

/// Mean and sd of a Gaussian mixture (weights need not be normalised). {0, 0} when empty.
[[nodiscard]] std::pair<double, double> mixture_moments(const std::vector<MixtureComponent>& mix);

/// A posterior on a line, summarised for a report: its mean, and the standard error that makes
/// mean +/- 1.96 se hold 95 % of it (the sd for a Gaussian; less for flat-topped shapes such as
/// the uniform stick-slip segment, which +/- 1.96 sd would over-cover).
struct PosteriorSummary {
    double mean = 0, se95 = 0, sd = 0;
};

/// Out-of-band prior density, relative to inside the band: a unit outside the section-8 band is
/// possible, only less likely; data that place it outside override this.
inline constexpr double kOutOfBandPrior = 0.01;

/// The normalised product of Gaussian-mixture densities (independent looks at one quantity),
/// convolved with a uniform error of +/- uniform_half_width (the eta confound of c|F_R|), with a
/// soft uniform prior on `band` (kOutOfBandPrior outside), evaluated on a fine grid.
[[nodiscard]] PosteriorSummary product_posterior(const std::vector<std::vector<MixtureComponent>>& mixes,
                                                 const HealthRange& band, double uniform_half_width = 0.0);

/// Finds and measures the breakaway events of a BRK run. Throws EmadiagError when the run is too
/// short to hold the first position hold.
[[nodiscard]] BreakawayAnalysis analyse_breakaways(const Run& run);

}  // namespace emadiag
