#pragma once
// The fits behind breakaway.cpp's analyse_breakaways, in their own file (issue 22): the slip
// trajectory of step 2 and its profile over the breakaway time t_b, and the small least-squares
// helpers both use. Internal to src/estimation (breakaway.cpp and breakaway_trajectory.cpp).
#include "estimation/breakaway.hpp"

#include <cmath>
#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

namespace emadiag::breakaway_detail {

inline constexpr double kTimeEpsS = 1e-9;
inline constexpr double kGridStepFraction = 0.02;    // trajectory grid step, fraction of a period

struct Stats {
    double mean = 0, sd = 0;
    std::size_t n = 0;
};
[[nodiscard]] Stats stats(const std::vector<double>& v);

/// y = a + b (t - t0) by least squares.
struct Line {
    double a = 0, b = 0, t0 = 0, sigma = 0, sxx = 0;
    std::size_t n = 0;
    [[nodiscard]] double at(double t) const { return a + b * (t - t0); }
    [[nodiscard]] double se_at(double t) const {
        if (n < 3 || sxx <= 0) return sigma;
        return sigma * std::sqrt(1.0 / static_cast<double>(n) + (t - t0) * (t - t0) / sxx);
    }
};
[[nodiscard]] Line fit_line(const std::vector<double>& t, const std::vector<double>& y);

/// Noisy data, after the move end: the position hold takes over (section 5) and brings the shaft
/// to rest. For a candidate slip this is fixed by its speed at the move end and its dynamic
/// friction, so the hold's first samples (speed, angle, and the current while the shaft still
/// moves: I = K_w (K_theta (theta_cmd - theta) - w), which reads the speed 2.5 times finer than the
/// speed channel) tell slips apart that the ramp alone cannot: a late, steep start ends faster than
/// an early, slow one. Left out: the current of a resting shaft (its chatter sawtooth is not
/// modelled) and the mean angle it rests at over the hold (that stopping distance is off by more
/// than its 8e-5 rad precision: with it, the calibration bench's BRK intervals covered 89-91 %).
struct PostMove {
    std::size_t first = 0;           ///< first sample wholly after the move end
    double sigma_w = 0, sigma_th = 0, sigma_i = 0, load_nm = 0;
    bool ok = false;
};

struct ProfileResult {
    double t_b = 0, se = 0, g0 = 0;
    bool ok = false;
};

/// Profile of a trajectory fit over a grid of breakaway times t_b in [t_lo, t_hi]: the best t_b, its
/// one-se half-width (where the SSE rises by one residual variance), and the whole profile.
/// `fit(t_b)` returns the TrajectoryFit at t_b; `fitted_params` is how many parameters it fits
/// besides t_b; `scale_by_fit` scales the SSE by max(1, SSE_min / dof).
struct GridProfile {
    ProfileResult best;
    std::vector<double> t_s, sse, g0;  ///< the profile (g0: the fitted J dw/dt just after t_b)
    double scale = 1;              ///< residual variance factor
};

/// Clean data: the profile of the free slip trajectory (theta0 and g0 fitted) over t_b.
[[nodiscard]] ProfileResult profile_breakaway(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi,
                                              double g1_nm_s, double sigma_w, double sigma_th, bool scale_by_fit);

/// Profile of fit_trajectory_to_end over t_b in [t_lo, t_hi] (physical: d g0 >= 0): the best t_b,
/// its one-se half-width, and the whole profile for the posterior of step 5.
using EndProfile = GridProfile;
[[nodiscard]] EndProfile profile_to_end(const Run& run, std::size_t a, std::size_t b, double t_lo, double t_hi,
                                        double g1_nm_s, double theta0_rad, double t_end_s, int d, double sigma_w,
                                        double sigma_th, const PostMove& post,
                                        const std::function<double(double, double)>& dyn_at);

}  // namespace emadiag::breakaway_detail
