#include "discovery/fits/linearisation.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery::pipeline {

TrajectoryLinearisation linearise_trajectory(const Run& run, const RunSignals& s, const NoiseFloor& floor, double fsj_base_nm,
                                             const std::vector<FitParameter>& model_parameters, const sim::EmaParams& p,
                                             const RunSignals& model_sim, const std::vector<sim::EmaParams>& probes,
                                             const std::vector<double>& probe_steps) {
    TrajectoryLinearisation lin;
    const std::vector<double> e_rows = trajectory_rows(s, model_sim, floor);
    const auto n_rows = static_cast<Eigen::Index>(e_rows.size());
    std::vector<sim::EmaParams> batch;
    std::vector<double> steps;
    for (const FitParameter& name : model_parameters) {
        const double v = get_parameter(p, name);
        const bool health = name.is_health();
        double h = health || v == 0.0 ? std::max(kSensitivityStepRel * std::abs(v), kSensitivityStepMin)
                                      : kSensitivityStepRel * std::abs(v);
        if (name == FitParameter::eta_o() && v + h > 1.0) h = -h;
        sim::EmaParams q = p;
        set_parameter(q, name, v + h);
        q.fsj_nm = std::max(fsj_base_nm, q.fdj_nm);
        steps.push_back(get_parameter(q, name) - v);
        batch.push_back(q);
    }
    for (std::size_t i = 0; i < probes.size(); ++i) {
        sim::EmaParams q = probes[i];
        q.fsj_nm = std::max(fsj_base_nm, q.fdj_nm);
        batch.push_back(q);
        steps.push_back(probe_steps[i]);
    }
    const std::vector<Run> runs = resimulate_many(run, batch);
    lin.simulations = static_cast<int>(runs.size());
    lin.e = Eigen::Map<const Eigen::VectorXd>(e_rows.data(), n_rows);
    // Column j: d(model) / d(parameter), in noise floors (e = measured - model).
    auto column = [&](std::size_t j) {
        const std::vector<double> r = trajectory_rows(s, run_signals(runs[j]), floor);
        Eigen::VectorXd c(n_rows);
        for (Eigen::Index i = 0; i < n_rows; ++i) c(i) = (lin.e(i) - r[static_cast<std::size_t>(i)]) / steps[j];
        return c;
    };
    const auto nh = static_cast<Eigen::Index>(model_parameters.size());
    lin.hcols.resize(n_rows, nh);
    for (Eigen::Index j = 0; j < nh; ++j) lin.hcols.col(j) = column(static_cast<std::size_t>(j));
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(lin.hcols);
    lin.q = qr.householderQ() * Eigen::MatrixXd::Identity(n_rows, nh);
    lin.e0 = lin.e - lin.q * (lin.q.transpose() * lin.e);
    lin.rss0 = lin.e0.squaredNorm();
    for (std::size_t i = 0; i < probes.size(); ++i) lin.probes.push_back(column(model_parameters.size() + i));
    return lin;
}

double torque_window_chi2_rise(const RunSignals& s, const std::vector<char>& mask, const NoiseFloor& floor, const RunSignals& before,
                               const RunSignals& after) {
    const ErrorMetrics e_old = model_error(s, before, mask), e_new = model_error(s, after, mask);
    const double windows = static_cast<double>(e_old.torque_samples) / static_cast<double>(kMetricWindowSamples);
    return windows * (std::pow(e_new.residual_torque_window_rms_nm, 2) - std::pow(e_old.residual_torque_window_rms_nm, 2)) /
           std::pow(std::max(floor.torque_window_nm, 1e-300), 2);
}

}  // namespace emadiag::discovery::pipeline
