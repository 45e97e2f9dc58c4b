#pragma once
// Step 2 of a trend: the degradation model, fitted by weighted least squares to a parameter's
// series, and the choice between the two models by AICc.
//   linear      y(t)    = a + b t
//   log-linear  ln y(t) = a + b t   (y = e^a e^(b t): exponential growth of friction, decay of
//                                    efficiency; fitted to ln y with se(ln y) = se(y) / y)
// t in days since the tail's first session. Weights w_i = 1/se_i^2; the parameter covariance
// (X' W X)^-1 is scaled by max(1, chi^2 / (n - 2)): when the points scatter more than their
// standard errors claim, the intervals widen with it; when less, they are not narrowed.
#include "prognostics/trend_series.hpp"

#include <Eigen/Dense>

#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

enum class DegradationModel { Linear, LogLinear };
/// "linear" or "log-linear".
[[nodiscard]] const char* to_string(DegradationModel m);

/// Two parameters (a, b) per model.
inline constexpr int kModelParameters = 2;
/// The fewest points a trend is fitted to: a line through 2 points leaves no residual to check.
inline constexpr int kMinTrendPoints = 3;
/// Log-linear replaces the linear model only when its AICc is lower by at least this much
/// (Burnham & Anderson 2002, section 2.6: a difference below 2 leaves both models well supported).
inline constexpr double kAiccPreferenceMargin = 2.0;

struct DegradationFit {
    DegradationModel model = DegradationModel::Linear;
    bool fitted = false;
    std::string note;  ///< why it was not fitted, when not
    double a = 0, b = 0;  ///< b per day (ln units per day for log-linear)
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  ///< of (a, b), already scaled
    int points = 0;
    double chi2 = 0;              ///< weighted residual sum of squares on the fitted scale (y or ln y)
    double reduced_chi2 = 0;      ///< chi2 / (n - 2)
    double covariance_scale = 1;  ///< max(1, reduced_chi2)
    double chi2_y = 0;            ///< sum ((y_i - mean(t_i)) / se_i)^2 on the measurement scale
    std::optional<double> aicc;   ///< on the measurement scale; empty when n <= 3 (AICc needs n > k + 1)

    /// The fitted mean of y at t.
    [[nodiscard]] double mean_at(double t_days) const;
    /// d mean / dt at t and its standard error (delta method with `covariance`), per day.
    [[nodiscard]] std::pair<double, double> slope_at(double t_days) const;
    /// The t at which the fitted mean equals `level`; empty when the slope is zero, or for
    /// log-linear when level <= 0.
    [[nodiscard]] std::optional<double> time_of(double level) const;
};

struct ModelChoice {
    DegradationModel model = DegradationModel::Linear;
    std::string reason;
};

/// Weighted least squares of y = a + b t. Fewer than kMinTrendPoints points: not fitted, with a note.
[[nodiscard]] DegradationFit fit_linear(const std::vector<TrendPoint>& points);
/// Weighted least squares of ln y = a + b t. Not fitted (with a note) when a value is not positive.
[[nodiscard]] DegradationFit fit_log_linear(const std::vector<TrendPoint>& points);
/// Linear unless log-linear is fitted and its AICc is lower by kAiccPreferenceMargin or more
/// (fits as fit_models leaves them, with aicc filled).
[[nodiscard]] ModelChoice choose_model(const DegradationFit& linear, const DegradationFit& log_linear);

/// Both models fitted, compared and one chosen.
struct ModelFits {
    DegradationFit linear, log_linear;
    /// The overdispersion factor of both AICcs (QAICc): the better fit's chi2_y / (n - 2), at least 1,
    /// so that points scattering more than their ses claim do not exaggerate the AICc difference.
    double overdispersion = 1;
    ModelChoice choice;
    [[nodiscard]] const DegradationFit& chosen() const { return choice.model == DegradationModel::Linear ? linear : log_linear; }
};

[[nodiscard]] ModelFits fit_models(const std::vector<TrendPoint>& points);

}  // namespace emadiag::prognostics
