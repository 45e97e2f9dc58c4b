#pragma once
// Scaled Conjugate Gradient (Moller 1993, "A scaled conjugate gradient algorithm for fast supervised
// learning", Neural Networks 6:525-533), step for step as MATLAB's trainscg: sigma = 5e-5,
// lambda = 5e-7, restart every (number of weights) iterations, stop on the performance goal, the
// minimum gradient, the epoch limit or after max_fail consecutive validation failures, returning
// the weights of the best validation performance.
#include <Eigen/Dense>

#include <functional>
#include <string>
#include <vector>

namespace emadiag {

struct ScgOptions {
    int max_epochs = 1000;     ///< trainParam.epochs
    double goal = 1e-6;        ///< trainParam.goal, in the objective's units
    int max_fail = 12;         ///< trainParam.max_fail (the paper: 12; MATLAB's default: 6)
    double min_grad = 1e-6;    ///< trainParam.min_grad
    double sigma = 5e-5;       ///< trainParam.sigma: step for the second-derivative estimate
    double lambda = 5e-7;      ///< trainParam.lambda: initial scale (Levenberg-Marquardt-like)
};

/// The objective: value at x, and its gradient into grad when grad is not null.
using ScgObjective = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd* grad)>;
/// Validation performance at x (no gradient).
using ScgValidation = std::function<double(const Eigen::VectorXd& x)>;

struct ScgResult {
    Eigen::VectorXd x;            ///< best weights (best validation performance when validating)
    double perf = 0;              ///< objective at x
    double validation_perf = 0;   ///< validation performance at x (0 without validation)
    int epochs = 0;               ///< epochs run
    int best_epoch = 0;
    std::string stop_reason;      ///< "goal", "min_grad", "max_epochs", "validation", "no_step"
    std::vector<double> perf_history;        ///< objective at the start of each epoch
    std::vector<double> validation_history;  ///< validation at the start of each epoch
};

[[nodiscard]] ScgResult train_scg(const ScgObjective& objective, Eigen::VectorXd x0, const ScgOptions& options = {},
                                  const ScgValidation& validation = {});

}  // namespace emadiag
