#include "prognostics/degradation_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

namespace emadiag::prognostics {
namespace {

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os.precision(digits);
    os << v;
    return os.str();
}

/// Below this relative size of the normal equations' determinant the times do not separate a
/// from b (all sessions at one time).
constexpr double kDegenerateDeterminantRel = 1e-12;

/// Weighted least squares of z = a + b t with standard errors s (Numerical Recipes, 3rd ed.,
/// section 15.2 "Fitting data to a straight line"): with w = 1/s^2, S = sum w, St = sum w t,
/// Stt = sum w t^2, Sz = sum w z, Stz = sum w t z and D = S Stt - St^2:
///   a = (Stt Sz - St Stz) / D,  b = (S Stz - St Sz) / D,
///   var(a) = Stt / D,  var(b) = S / D,  cov(a, b) = -St / D   (the inverse of the normal matrix).
DegradationFit wls(DegradationModel model, const std::vector<double>& t, const std::vector<double>& z, const std::vector<double>& s) {
    DegradationFit f;
    f.model = model;
    const auto n = static_cast<int>(t.size());
    f.points = n;
    double sw = 0, st = 0, stt = 0, sz = 0, stz = 0;
    for (int i = 0; i < n; ++i) {
        const double w = 1.0 / (s[i] * s[i]);
        sw += w;
        st += w * t[i];
        stt += w * t[i] * t[i];
        sz += w * z[i];
        stz += w * t[i] * z[i];
    }
    const double d = sw * stt - st * st;
    if (!(d > kDegenerateDeterminantRel * sw * stt)) {
        f.note = "all " + std::to_string(n) + " points are at the same time; no trend can be fitted";
        return f;
    }
    f.a = (stt * sz - st * stz) / d;
    f.b = (sw * stz - st * sz) / d;
    for (int i = 0; i < n; ++i) {
        const double r = (z[i] - f.a - f.b * t[i]) / s[i];
        f.chi2 += r * r;
    }
    const int dof = n - kModelParameters;
    f.reduced_chi2 = dof > 0 ? f.chi2 / dof : 0.0;
    f.covariance_scale = std::max(1.0, f.reduced_chi2);
    f.covariance << stt / d, -st / d, -st / d, sw / d;
    f.covariance *= f.covariance_scale;
    f.fitted = true;
    return f;
}

/// AICc on the measurement scale with the standard errors as the known sigma of each point
/// (Burnham & Anderson 2002, eqs. for AIC and its small-sample correction):
///   -2 ln L = chi2_y / c + sum ln(2 pi se_i^2),  AIC = -2 ln L + 2k,  AICc = AIC + 2k(k+1)/(n-k-1)
/// with c the overdispersion factor (QAICc; c = 1 when the points scatter as their ses claim).
std::optional<double> aicc(const DegradationFit& f, const std::vector<TrendPoint>& points, double overdispersion) {
    const int n = static_cast<int>(points.size());
    const int k = kModelParameters;
    if (!f.fitted || n - k - 1 <= 0) return std::nullopt;
    double log_term = 0;
    for (const auto& p : points) log_term += std::log(2.0 * std::numbers::pi * p.std_error * p.std_error);
    return f.chi2_y / overdispersion + log_term + 2.0 * k + 2.0 * k * (k + 1) / static_cast<double>(n - k - 1);
}

void measure_on_y_scale(DegradationFit& f, const std::vector<TrendPoint>& points) {
    if (!f.fitted) return;
    f.chi2_y = 0;
    for (const auto& p : points) {
        const double r = (p.value - f.mean_at(p.t_days)) / p.std_error;
        f.chi2_y += r * r;
    }
}

std::optional<std::string> too_few(const std::vector<TrendPoint>& points) {
    if (static_cast<int>(points.size()) >= kMinTrendPoints) return std::nullopt;
    return "insufficient data (" + std::to_string(points.size()) + " sessions; need >= " + std::to_string(kMinTrendPoints) + ")";
}

}  // namespace

const char* to_string(DegradationModel m) { return m == DegradationModel::Linear ? "linear" : "log-linear"; }

double DegradationFit::mean_at(double t_days) const {
    const double eta = a + b * t_days;
    return model == DegradationModel::Linear ? eta : std::exp(eta);
}

std::pair<double, double> DegradationFit::slope_at(double t_days) const {
    // Linear: d/dt = b. Log-linear: d/dt e^(a + b t) = b e^(a + b t); gradient with respect to
    // (a, b): (b m, m (1 + b t)) with m = e^(a + b t).
    Eigen::Vector2d grad;
    double slope = 0;
    if (model == DegradationModel::Linear) {
        slope = b;
        grad << 0.0, 1.0;
    } else {
        const double m = std::exp(a + b * t_days);
        slope = b * m;
        grad << b * m, m * (1.0 + b * t_days);
    }
    const double var = grad.dot(covariance * grad);
    return {slope, std::sqrt(std::max(0.0, var))};
}

std::optional<double> DegradationFit::time_of(double level) const {
    if (!fitted || b == 0) return std::nullopt;
    if (model == DegradationModel::Linear) return (level - a) / b;
    if (!(level > 0)) return std::nullopt;
    return (std::log(level) - a) / b;
}

DegradationFit fit_linear(const std::vector<TrendPoint>& points) {
    if (auto why = too_few(points)) {
        DegradationFit f;
        f.points = static_cast<int>(points.size());
        f.note = *why;
        return f;
    }
    std::vector<double> t, y, s;
    for (const auto& p : points) {
        t.push_back(p.t_days);
        y.push_back(p.value);
        s.push_back(p.std_error);
    }
    DegradationFit f = wls(DegradationModel::Linear, t, y, s);
    measure_on_y_scale(f, points);
    return f;
}

DegradationFit fit_log_linear(const std::vector<TrendPoint>& points) {
    DegradationFit f;
    f.model = DegradationModel::LogLinear;
    f.points = static_cast<int>(points.size());
    if (auto why = too_few(points)) {
        f.note = *why;
        return f;
    }
    std::vector<double> t, z, s;
    for (const auto& p : points) {
        if (!(p.value > 0)) {
            f.note = "value " + num(p.value) + " of session " + std::to_string(p.session_id) + " is not positive; ln y is undefined";
            return f;
        }
        t.push_back(p.t_days);
        z.push_back(std::log(p.value));
        s.push_back(p.std_error / p.value);  // delta method: se(ln y) = se(y) / y
    }
    f = wls(DegradationModel::LogLinear, t, z, s);
    measure_on_y_scale(f, points);
    return f;
}

ModelChoice choose_model(const DegradationFit& linear, const DegradationFit& log_linear) {
    ModelChoice c;
    if (!log_linear.fitted) {
        c.reason = "linear: the log-linear model could not be fitted (" + log_linear.note + ")";
        return c;
    }
    if (!linear.fitted) {
        c.model = DegradationModel::LogLinear;
        c.reason = "log-linear: the linear model could not be fitted (" + linear.note + ")";
        return c;
    }
    if (!linear.aicc || !log_linear.aicc) {
        c.reason = "linear: with " + std::to_string(linear.points) + " sessions AICc is undefined (it needs n > " +
                   std::to_string(kModelParameters + 1) + "); linear is the reference model";
        return c;
    }
    const double delta = *linear.aicc - *log_linear.aicc;  // > 0: log-linear is better
    if (delta >= kAiccPreferenceMargin) {
        c.model = DegradationModel::LogLinear;
        c.reason = "log-linear: AICc " + num(*log_linear.aicc) + " vs linear " + num(*linear.aicc) + " (lower by " + num(delta, 3) +
                   " >= " + num(kAiccPreferenceMargin) + ")";
    } else if (delta > 0) {
        c.reason = "linear: AICc " + num(*linear.aicc) + " vs log-linear " + num(*log_linear.aicc) + " (log-linear lower by only " +
                   num(delta, 3) + " < " + num(kAiccPreferenceMargin) + "; linear is the reference model)";
    } else {
        c.reason = "linear: AICc " + num(*linear.aicc) + " vs log-linear " + num(*log_linear.aicc) + " (lower by " + num(-delta, 3) + ")";
    }
    return c;
}

ModelFits fit_models(const std::vector<TrendPoint>& points) {
    ModelFits m;
    m.linear = fit_linear(points);
    m.log_linear = fit_log_linear(points);
    const int dof = static_cast<int>(points.size()) - kModelParameters;
    double best = std::numeric_limits<double>::infinity();
    if (m.linear.fitted) best = std::min(best, m.linear.chi2_y);
    if (m.log_linear.fitted) best = std::min(best, m.log_linear.chi2_y);
    m.overdispersion = dof > 0 && std::isfinite(best) ? std::max(1.0, best / dof) : 1.0;
    m.linear.aicc = aicc(m.linear, points, m.overdispersion);
    m.log_linear.aicc = aicc(m.log_linear, points, m.overdispersion);
    m.choice = choose_model(m.linear, m.log_linear);
    return m;
}

}  // namespace emadiag::prognostics
