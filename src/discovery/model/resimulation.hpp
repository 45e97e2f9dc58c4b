#pragma once
// Re-simulating a run with a candidate model, the model error, and the fit of model parameters by
// re-simulation (docs/discovery.md "Fit"). The run's case, sequence, length and constants (k_t,
// J, tau) come from the Run; noise is none; nothing is read from true_* / effect_* metadata.
#include "core/run.hpp"
#include "discovery/model/run_signals.hpp"
#include "discovery/model/trajectory.hpp"
#include "discovery/model/fit_parameter.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/simulator.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace emadiag::discovery {

/// Consecutive torque-residual samples averaged for the window metric (the telescoped mean of
/// residual_torque.hpp: its derivative noise falls as 1/n).
inline constexpr std::size_t kMetricWindowSamples = 8;
/// Consecutive masked samples summed into one row of the fit.
inline constexpr std::size_t kFitWindowSamples = 8;
/// Levenberg-Marquardt iterations of a re-simulation fit, and the starting damping.
inline constexpr int kMaxFitIterations = 12;
inline constexpr double kFitStartDamping = 1e-3;
/// Trial points per iteration (damping lambda, 10 lambda, ...) before the fit stops.
inline constexpr int kFitTriesPerIteration = 4;
/// The fit stops when an accepted step lowers the cost by less than this fraction.
inline constexpr double kFitRelativeTolerance = 1e-4;

/// The error of a model against the measurement (the same samples before and after).
struct ErrorMetrics {
    double current_rms_a = 0;                  ///< all samples
    double residual_torque_rms_nm = 0;         ///< measured T_R - model T_R, over the torque samples
    double residual_torque_window_rms_nm = 0;  ///< the same, means of kMetricWindowSamples samples
    double speed_rms_rad_s = 0;                ///< all samples
    double theta_rms_rad = 0;                  ///< all samples
    std::size_t samples = 0;
    std::size_t torque_samples = 0;
};

/// What a re-simulation takes from the measured run, typed once: its case and sequence as the
/// simulator's enums, its length and its constants (k_t, J, tau, sample period). The run must have
/// been checked (run_signals); the re-simulation's samples are then not checked again.
struct ResimTarget {
    sim::LoadCase load_case = sim::LoadCase::B;
    sim::Sequence sequence = sim::Sequence::Dyn;
    std::size_t samples = 0;
    RunConstants constants;
};
/// The run's ResimTarget. Throws EmadiagError when its sample period is not the simulator's (within
/// kSamplePeriodTolerance of run_checks.hpp): the re-simulation would not line up with its samples.
[[nodiscard]] ResimTarget resim_target(const Run& run);
/// The simulation of the target's case and sequence with `params`, noise none.
[[nodiscard]] sim::SimConfig resim_config(const ResimTarget& target, const sim::EmaParams& params);
[[nodiscard]] sim::SimConfig resim_config(const Run& run, const sim::EmaParams& params);
/// The signals of the re-simulation (run_signals of resimulate's Run, computed from the simulator's
/// samples and the target's constants without a Run's metadata or a second check_run).
[[nodiscard]] RunSignals resimulate_signals(const ResimTarget& target, const sim::EmaParams& params);
/// resimulate_signals for each of `params` at once, as resimulate_many.
[[nodiscard]] std::vector<RunSignals> resimulate_signals_many(const ResimTarget& target,
                                                              const std::vector<sim::EmaParams>& params);
/// The re-simulated run (make_run), with the measured run's constants so eq. 7 is the same.
[[nodiscard]] Run resimulate(const Run& run, const sim::EmaParams& params);
/// resimulate for each of `params` at once: one sim::simulate_batch on two threads, whose SIMD lanes
/// each carry their own health, effects and terms (a fit's Jacobian columns), with the same results
/// bit for bit. Params that differ in backlash, which lanes share, run one at a time.
[[nodiscard]] std::vector<Run> resimulate_many(const Run& run, const std::vector<sim::EmaParams>& params);

/// Comparison samples are slipping in both runs and away from kinks of either speed (second
/// difference above this at the sample or a neighbour: the differentiator of eq. 7 fails there,
/// residual_torque.hpp "Limits"). 3 rad/s is 6 sd of the second difference of `typical` speed
/// noise (sqrt(6) 0.2 rad/s); a kink at I_max changes the speed step by about 12 rad/s.
/// Speeds are NOT required to agree: T_R is the friction torque in both runs whatever their
/// trajectories, and an inertia error shows precisely where they disagree.
inline constexpr double kKinkSecondDifferenceRadS = 3.0;

/// The comparison samples of `measured` and `model` (see the constants above).
[[nodiscard]] std::vector<char> comparison_mask(const RunSignals& measured, const RunSignals& model);
/// Error of `model` against `measured` (same length; throws EmadiagError otherwise).
[[nodiscard]] ErrorMetrics model_error(const RunSignals& measured, const RunSignals& model,
                                       const std::vector<char>& mask);

/// A fitted parameter's value and standard error.
struct FittedValue {
    FittedValue() = default;
    FittedValue(const FitParameter& fitted, double v, double se)
        : parameter(fitted), name(fit_parameter_name(fitted)), value(v), std_error(se) {}

    FitParameter parameter = FitParameter::fdj();
    std::string name;  ///< fit_parameter_name(parameter): what reports and JSON show
    double value = 0;
    double std_error = 0;
};

struct FitResult {
    sim::EmaParams params;
    std::vector<FittedValue> values;
    double cost_start = 0, cost_end = 0;  ///< sum of squared rows (window sums of the torque residual, or
                                          ///< the trajectory rows in noise floors)
    double cost_reference = 0;            ///< the same for `reference` (when given)
    std::size_t rows = 0;                 ///< window sums in the cost
    int iterations = 0;
    int simulations = 0;
    RunSignals signals;  ///< the re-simulated run at params (no need to simulate it again)
};

/// Levenberg-Marquardt on the torque residual (measured T_R - re-simulated T_R over `mask`, summed
/// over windows of kFitWindowSamples consecutive samples),
/// varying `parameters` of `start` (finite-difference Jacobian on the real simulator).
/// Parameters stay inside the simulator's allowed ranges; FSJ is max(fsj_base_nm, FDJ) at every
/// trial point (the simulator needs FSJ >= FDJ; a DYN run does not identify FSJ).
/// `window_samples` = 1 fits per sample (for a signature that changes within a window: ripple).
/// With `trajectory_floor`, the rows are instead the trajectory of every sample, each channel in units
/// of its noise floor (current, speed, theta, load: (measured - model) / floor), so the cost / rows is
/// the trajectory cost of trajectory.hpp; `mask` and `window_samples` are then not used. That is the
/// objective for an effect the torque residual barely sees (a friction impulse while the speed
/// crosses zero, docs/discovery.md "Low-speed friction by the trajectory").
[[nodiscard]] FitResult fit_by_resimulation(const Run& run, const RunSignals& measured, const sim::EmaParams& start,
                                            const std::vector<FitParameter>& parameters, const std::vector<char>& mask,
                                            double fsj_base_nm, std::size_t window_samples = kFitWindowSamples,
                                            const sim::EmaParams* reference = nullptr,
                                            int max_iterations = kMaxFitIterations,
                                            const NoiseFloor* trajectory_floor = nullptr);
/// The trajectory rows of a model's signals: per channel (current, speed, theta, load) and sample,
/// (measured - model) / floor (a floor of 0 gives rows of 0).
[[nodiscard]] std::vector<double> trajectory_rows(const RunSignals& measured, const RunSignals& model,
                                                  const NoiseFloor& floor);

}  // namespace emadiag::discovery
