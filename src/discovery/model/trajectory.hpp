#pragma once
// The run's own noise floor, the error of a re-simulated trajectory in units of it, and the
// analysis of structure left in the residual (issue 10 parts 3 and 4; docs/discovery.md).
//
// Noise floor of a channel (current, speed, theta, load torque F_R = H/tau): the measurement minus
// the baseline re-simulation varies smoothly where the model is wrong and by the sensor noise from
// sample to sample, so sigma = MAD(first differences) / (0.6745 sqrt 2), at least the quantisation
// (resolution / sqrt 12). For the torque residual the same is done on the means of windows of
// kScreenWindowSamples comparison samples.
//
// Significance: chi^2 = sum (e / sigma)^2 over the n values of a channel but its largest single value
// (one glitch is not structure: a window across a kink once gave 17 floors on a clean run),
// z = (chi^2 - n) / sqrt(2n)
// (the normal approximation of the chi-square test). A channel is significantly above its floor when
// z > kStructureMinZ and its RMS is at least kStructureMinExcess (torque window means) or
// kStructureMinExcessTrajectory (current, speed, theta, load) times the floor. The trajectory channels
// need more: a health value fitted within its uncertainty still moves the closed-loop trajectory by
// about the sensor noise (an FDJ error of 1e-3 N m needs 0.005 A more current and leaves 0.7 mrad of
// position error through the speed and position loops), so clean runs show 1.0 to 1.3 x the floor there.
#include "discovery/model/run_signals.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag::discovery {

inline constexpr double kStructureMinZ = 5.0;
inline constexpr double kStructureMinExcess = 1.25;
inline constexpr double kStructureMinExcessTrajectory = 1.5;
/// The angle integrates every torque error through the position loop (a fitted health value leaves
/// 1 to 2 x its floor, and a term fitted on the torque residual up to 4 x): structure in the angle
/// alone counts from this many floors, the size of the smallest sensor offset the sensor stage adds.
inline constexpr double kStructureMinExcessTheta = 5.0;
/// Bins of the binned variance explained (equal counts).
inline constexpr int kStructureBins = 10;

/// Channels of the trajectory cost: current, speed, theta, load.
inline constexpr std::size_t kTrajectoryChannels = 4;

struct NoiseFloor {
    double current_a = 0, speed_rad_s = 0, theta_rad = 0, load_nm = 0;
    double torque_window_nm = 0;  ///< of the window means of the torque residual
};

/// The floor from a run and a model of it (normally the baseline), over the comparison mask.
[[nodiscard]] NoiseFloor noise_floor(const RunSignals& measured, const RunSignals& model, const std::vector<char>& mask);

/// RMS per channel of measured - model, and cost = mean over the channels of (RMS / floor)^2
/// (1 when the model is right and the floor is the noise).
struct TrajectoryError {
    double current_a = 0, speed_rad_s = 0, theta_rad = 0, load_nm = 0;
    double cost = 0;
};
[[nodiscard]] TrajectoryError trajectory_error(const RunSignals& measured, const RunSignals& model,
                                               const NoiseFloor& floor);

/// Dependence of a residual on one variable: binned variance explained (eta^2, adjusted for the bins).
struct Dependence {
    std::string variable;
    double variance_explained = 0;
};

/// A channel's residual against the floor, and what it depends on.
struct StructureReport {
    std::string channel;            ///< "torque" (window means), "current", "speed", "theta", "load"
    std::string unit;
    double rms = 0, floor = 0;      ///< RMS of the residual, and the noise floor
    double chi2 = 0, z = 0;
    std::size_t n = 0;                  ///< values tested (the largest single one is left out)
    std::optional<std::size_t> excluded_index;  ///< that value's index in y
    double excluded_value = 0;
    bool significant = false;
    std::vector<Dependence> dependence;  ///< strongest first
    std::vector<double> x, y;            ///< the residual (y) against the strongest variable (x)
};

/// Every channel's structure report (torque first), each with its dependence on the run's variables
/// (w, |w|, theta_u, |theta_u|, F_R, |F_R|, t, I, dw/dt).
[[nodiscard]] std::vector<StructureReport> structure_reports(const RunSignals& measured, const RunSignals& model,
                                                             const std::vector<char>& mask, const NoiseFloor& floor);
/// The test used, as text for reports.
[[nodiscard]] std::string structure_test_text(const StructureReport& r);

}  // namespace emadiag::discovery
