#pragma once
// The trajectory linearised around the model (one batch of re-simulations): the columns of the
// model's own parameters and of probes of one effect, for the trajectory screens of the low-speed and
// ripple stages; and how a change of the model moves the torque residual's window means.
#include "discovery/stages/context.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace emadiag::discovery::pipeline {

/// The trajectory linearised around the model `p`: its rows e = measured - model (trajectory_rows, in
/// noise floors), the columns of the model's own parameters `model_parameters` (forward differences) and of
/// each probe (the model with one candidate effect at a small amplitude, per unit of it), from one batch
/// of re-simulations.
struct TrajectoryLinearisation {
    Eigen::VectorXd e, e0;                ///< the rows; what the model's own parameters leave of them
    Eigen::MatrixXd hcols, q;             ///< the model's own parameters' columns; an orthonormal basis of them
    std::vector<Eigen::VectorXd> probes;  ///< each probe's column
    double rss0 = 0;                      ///< e0's sum of squares
    int simulations = 0;
    /// Probe i's column with the model's own parameters projected out.
    [[nodiscard]] Eigen::VectorXd projected(std::size_t i) const { return probes[i] - q * (q.transpose() * probes[i]); }
};

[[nodiscard]] TrajectoryLinearisation linearise_trajectory(const Run& run, const RunSignals& s, const NoiseFloor& floor, double fsj_base_nm,
                                             const std::vector<FitParameter>& model_parameters, const sim::EmaParams& p,
                                             const RunSignals& model_sim, const std::vector<sim::EmaParams>& probes,
                                             const std::vector<double>& probe_steps);

/// linearise_trajectory with one probe per scanned shape of an effect: `set` puts the effect at the
/// probe amplitude `probe` (its unit) and the shape into a copy of `p`.
template <class SetProbe>
TrajectoryLinearisation linearise_over_shapes(const Run& run, const RunSignals& s, const NoiseFloor& floor, double fsj_base_nm,
                                              const std::vector<FitParameter>& model_parameters, const sim::EmaParams& p,
                                              const RunSignals& model_sim, const std::vector<EffectShape>& grid, double probe,
                                              SetProbe set) {
    std::vector<sim::EmaParams> probes;
    for (const auto& shape : grid) {
        sim::EmaParams q = p;
        set(q, shape);
        probes.push_back(q);
    }
    return linearise_trajectory(run, s, floor, fsj_base_nm, model_parameters, p, model_sim, probes, std::vector<double>(probes.size(), probe));
}

/// How much the chi-square of the torque residual's window means (against their floor) rises from the
/// model re-simulated as `before` to the one re-simulated as `after`.
[[nodiscard]] double torque_window_chi2_rise(const RunSignals& s, const std::vector<char>& mask, const NoiseFloor& floor, const RunSignals& before,
                               const RunSignals& after);

}  // namespace emadiag::discovery::pipeline
