#pragma once
// What the two screens share (effect_screen.cpp over the candidate library, sparse_select.cpp over
// the generated term library): the comparison samples grouped into windows of up to
// kScreenWindowSamples consecutive samples, each regression row a window SUM, and the base columns
// projected out of the residual (effect_screen.hpp says why windows).
#include "discovery/screening/effect_screen.hpp"
#include "discovery/model/run_signals.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace emadiag::discovery {

/// A candidate column that is (numerically) inside the span of the base columns is skipped.
inline constexpr double kMinResidualColumnFraction = 1e-8;

struct WindowedBase {
    std::vector<std::size_t> rows;                  ///< the comparison samples (mask set), in order
    std::vector<std::vector<std::size_t>> windows;  ///< consecutive rows, kScreenWindowSamples at most
    double weight_sum = 0;                          ///< sum of n_i^2: RSS / weight_sum is a mean square of window means
    Eigen::VectorXd y;                              ///< window sums of the residual
    Eigen::MatrixXd x0;                             ///< window sums of the base columns
    Eigen::MatrixXd q;                              ///< orthonormal basis of x0's columns
    Eigen::VectorXd e0;                             ///< y with the base columns projected out
    double rss0 = 0;                                ///< |e0|^2

    /// Window sums of a per-sample signal.
    [[nodiscard]] Eigen::VectorXd window_sums(const std::vector<double>& full) const;
    /// x with the base columns projected out.
    [[nodiscard]] Eigen::MatrixXd project_out(const Eigen::MatrixXd& x) const { return x - q * (q.transpose() * x); }
};

/// Builds the windows and the base projection from `in`; throws EmadiagError when the mask holds
/// fewer than kMinScreenSamples comparison samples.
[[nodiscard]] WindowedBase windowed_base(const RunSignals& s, const ScreenInput& in);

/// A number in a reason text ("%.3g").
[[nodiscard]] std::string fmt3(double v);
/// A number in a summary or verdict ("%.4g").
[[nodiscard]] std::string fmt4(double v);

}  // namespace emadiag::discovery
