#pragma once
// The signals discovery works on (docs/discovery.md "Residual"), computed from a Run's samples and
// constants only (never its true_* / effect_* metadata): the same for the measurement and for a
// re-simulation, so that T_R (eq. 7, core/residual_torque.hpp) of both is computed the same way
// and its known biases (the differentiator at kinks, the torque clipped at T_max, section 7 of
// ema-reference.md) appear in both and cancel in their difference.
// The friction law T_F,law = d (FDJ + c(d) |F_R|), d = sgn(w), c = 1/eta_O - 1 when the load
// opposes (F_R d > 0), else 1 - eta_A (eqs. 3 to 5; section 3 step 5) is given for reference.
#include "core/run.hpp"
#include "estimation/run_checks.hpp"

#include <cstddef>
#include <vector>

namespace emadiag::discovery {

/// Slipping samples: |w| at least this for the sample and both neighbours, one sign.
inline constexpr double kScreenMinSpeedRadS = 2.0;

struct RunSignals {
    double k_t_nm_per_a = 0, j_kgm2 = 0, tau = 0, sample_period_s = 0;
    std::vector<double> t_s;
    std::vector<double> current_a;
    std::vector<double> speed_rad_s;        ///< period mean
    std::vector<double> theta_m_rad;        ///< end of period
    std::vector<double> theta_start_rad;    ///< start of period (previous row; theta - w T on the first)
    std::vector<double> load_torque_nm;     ///< F_R = H / tau, motor side
    std::vector<double> accel_rad_s2;       ///< dw/dt of core/residual_torque.hpp
    std::vector<double> residual_torque_nm; ///< T_R, eq. 7
    std::vector<char> slipping;             ///< |w| >= kScreenMinSpeedRadS here and at both neighbours, one sign

    [[nodiscard]] std::size_t size() const { return t_s.size(); }
    [[nodiscard]] std::size_t slipping_count() const;
};

/// The signals of a run checked where it entered (estimation/run_checks.hpp).
[[nodiscard]] RunSignals run_signals(const CheckedRun& run);
/// The signals of a run the simulator just made (a re-simulation): it enters here, so it is checked
/// here (check_run throws EmadiagError on NaN, too few samples, bad constants).
[[nodiscard]] RunSignals run_signals(const Run& run);
/// run_signals without check_run, for samples that need no check: a re-simulation's
/// (resimulation.hpp), made by the simulator (finite, evenly spaced) with the constants and length of
/// a run that run_signals checked. Reads only the constants and samples of `run`.
[[nodiscard]] RunSignals unchecked_run_signals(const Run& run);

/// eq. (5) with eq. (3): the friction law's torque at sample k, signed like T_R.
[[nodiscard]] double friction_law_nm(const RunSignals& s, std::size_t k, double fdj_nm, double eta_o);
/// d T_F,law / d eta_O at sample k (eta_A follows eta_O by eq. 4).
[[nodiscard]] double friction_law_eta_slope_nm(const RunSignals& s, std::size_t k, double eta_o);

}  // namespace emadiag::discovery
