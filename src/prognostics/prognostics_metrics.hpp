#pragma once
// Prognostic performance metrics as NASA ProgPy computes them for a prediction profile (ToEPredictionProfile:
// alpha_lambda, relative accuracy, prognostic horizon), after Saxena et al., "Metrics for offline
// evaluation of prognostic performance", IJPHM 1(1), 2010. Used by bench/rul_bench.cpp; docs/trend-report.md
// states the choices. Times are in one unit (days here); a prediction is the distribution of the RUL
// made at time t (samples, e.g. the Monte Carlo draws of rul_estimate; +infinity for "never crosses").
//
//   alpha bounds       [(1 - alpha) r*, (1 + alpha) r*] around the true RUL r* = EoL* - t
//   alpha-lambda       at t_lambda = t_P + lambda (EoL* - t_P) (t_P the first prediction), the prediction
//                      made at t_lambda or the next one after it (ProgPy's rule) has at least a fraction
//                      beta of its distribution within the alpha bounds
//   relative accuracy  RA = 1 - |r* - r| / r*   (r: the point prediction)
//   prognostic horizon PH = EoL* - t_i, t_i the first prediction time whose distribution has at least
//                      beta within the alpha bounds (ProgPy: the first time the criterion is met)
#include <optional>
#include <vector>

namespace emadiag::prognostics {

/// One prediction of a profile.
struct RulPrediction {
    double t = 0;                      ///< when the prediction was made
    std::optional<double> rul_point;   ///< the point estimate; empty when none (e.g. no crossing predicted)
    std::vector<double> rul_samples;   ///< its distribution; +infinity allowed (beyond the horizon)
};

/// The fraction of `rul_samples` within [(1 - alpha) true_rul, (1 + alpha) true_rul] (bounds included).
/// Throws EmadiagError on an empty or NaN sample (naming the index), alpha outside (0, 1) or true_rul <= 0.
[[nodiscard]] double fraction_within_alpha(const std::vector<double>& rul_samples, double true_rul, double alpha);

struct AlphaLambdaResult {
    bool evaluated = false;   ///< false: no prediction at or after t_lambda before the end of life
    double t_lambda = 0;
    double t_evaluated = 0;   ///< the prediction used
    double true_rul = 0;
    double fraction_within = 0;
    bool met = false;         ///< fraction_within >= beta
};

/// Throws EmadiagError naming the field on an unsorted or non-finite profile, a prediction at or after
/// the end of life, or lambda outside [0, 1], alpha outside (0, 1), beta outside (0, 1].
[[nodiscard]] AlphaLambdaResult alpha_lambda(const std::vector<RulPrediction>& profile, double true_eol, double lambda, double alpha,
                                             double beta);

/// RA = 1 - |true_rul - predicted_rul| / true_rul. Throws EmadiagError when true_rul <= 0 or a value is not finite.
[[nodiscard]] double relative_accuracy(double predicted_rul, double true_rul);

/// PH = true_eol - t of the first prediction with at least beta of its distribution within the alpha
/// bounds; empty when none is. Checks as alpha_lambda.
[[nodiscard]] std::optional<double> prognostic_horizon(const std::vector<RulPrediction>& profile, double true_eol, double alpha, double beta);

}  // namespace emadiag::prognostics
