#pragma once
// Training the paper's network (section 2.8) on a dataset: features, the seeded 75/15/10 split,
// SCG with early stopping, the normalised MSE figures of the paper's tables, and the calibration
// of the per-output uncertainty on held-out (validation) runs.
#include "estimation/dataset.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/network_model.hpp"
#include "estimation/scg.hpp"

#include <Eigen/Dense>

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag {

/// Network inputs (raw, one run per column) and targets (normalised [0, 1], one run per column).
struct FeatureSet {
    Eigen::MatrixXd x;
    Eigen::MatrixXd u;
};

/// Features of the first `runs` runs of a dataset (all when runs <= 0), computed on `threads` threads.
[[nodiscard]] FeatureSet build_features(const Dataset& dataset, const NetworkSpec& spec, int runs = 0,
                                        unsigned threads = 1);

struct TrainOptions {
    NetworkSpec spec;
    std::uint64_t split_seed = 1;  ///< seed of the 75/15/10 split
    std::uint64_t init_seed = 1;   ///< seed of the Nguyen-Widrow initialisation
    ScgOptions scg;                ///< objective is the MSE in the [0, 1] space, so goal = 1e-6 as the paper
};

/// MSE figures in the normalised [0, 1] space of ema-reference.md section 8.
struct MseFigures {
    double train = 0, validation = 0, test = 0;
    std::vector<double> test_per_output;
};

struct TrainReport {
    NetworkModel model;
    Split split;
    MseFigures mse;
    ScgResult scg;          ///< x is the chosen weights
    double train_time_s = 0;
    /// Test runs: predictions and targets, normalised, outputs x test runs.
    Eigen::MatrixXd test_predicted;
    Eigen::MatrixXd test_target;
    /// Fraction of (test run, output) pairs whose 95 % interval covers the truth.
    double test_coverage95 = 0;
};

/// Bounds of the training options (issue 21 item 11), checked by check_train_options and used by
/// `emadiag train`'s option checks. Resampling needs two points; the paper uses N = 500 and 50
/// neurons; the upper bounds keep the weights (neurons x inputs) and the features (inputs x runs)
/// within a few hundred MB.
inline constexpr int kMinTimesteps = 2;
inline constexpr int kMaxTimesteps = 10'000;
inline constexpr int kMinHiddenNeurons = 1;
inline constexpr int kMaxHiddenNeurons = 1'000;
inline constexpr int kMinEpochs = 1;
inline constexpr int kMaxEpochs = 1'000'000;
inline constexpr int kMinMaxFail = 1;
inline constexpr int kMaxMaxFail = 1'000'000;
inline constexpr double kMaxGoal = 1.0;  ///< the MSE in the normalised [0, 1] space is at most 1

/// Throws EmadiagError naming the option, its value and the bound: timesteps, hidden neurons,
/// outputs (known names, no repeat, not eta_A), resample, epochs, max_fail and a finite goal.
void check_train_options(const TrainOptions& options);

/// The first non-finite number of a trained model ("std_error_normalised[0] = nan"), or "" when
/// every number is finite: a model is written only when this is empty.
[[nodiscard]] std::string non_finite_model_number(const NetworkModel& model);

/// Quantile level used for the calibrated half-width: the 95 % two-sided interval.
inline constexpr double kCoverageLevel = 0.95;  // half-width = kZ95 (health_estimate.hpp) std_error

/// Trains and calibrates. Throws EmadiagError when there are too few runs for the split.
[[nodiscard]] TrainReport train_network(const FeatureSet& features, const TrainOptions& options);

/// Standard error that makes +/-1.96 se cover `level` of the residuals (split-conformal quantile
/// with the finite-sample correction ceil((n + 1) level) / n), per output row.
[[nodiscard]] std::vector<double> calibrate_std_error(const Eigen::MatrixXd& residuals, double level = kCoverageLevel);

}  // namespace emadiag
