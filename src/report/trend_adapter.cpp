#include "report/trend_adapter.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::report {

namespace pg = emadiag::prognostics;

double datasheet_nominal(const std::string& parameter) {
    const sim::EmaParams datasheet;
    const auto p = parse_health_parameter(parameter);
    if (!p) throw EmadiagError("no datasheet nominal for parameter \"" + parameter + "\" (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
    switch (*p) {
        case HealthParameter::Fdj: return datasheet.fdj_nm;
        case HealthParameter::Fsj: return datasheet.fsj_nm;
        case HealthParameter::EtaO: return datasheet.eta_o;
        case HealthParameter::EtaA: return datasheet.eta_a;
    }
    return 0.0;
}

std::string parameter_unit(const std::string& parameter) {
    const auto p = parse_health_parameter(parameter);
    if (!p) throw EmadiagError("no unit known for parameter \"" + parameter + "\" (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
    return *p == HealthParameter::Fdj || *p == HealthParameter::Fsj ? "N m" : "";
}

std::optional<ReportCurve> sample_fit(const pg::ParameterTrend& p, double origin_days) {
    if (!p.has_fit || p.series.points.empty()) return std::nullopt;
    const pg::DegradationFit& f = p.fits.chosen();
    const double t_first = p.series.points.front().t_days;
    const double t_last = p.series.points.back().t_days;
    const double span = std::max(t_last - t_first, kMinProjectionDays);
    double extension = std::max(kMinProjectionFraction * span, kMinProjectionDays);
    const pg::RulEstimate& r = p.rul;
    if (r.status == pg::RulStatus::Predicted && r.rul_days) {
        // Show the crossing and, when it is finite, the upper end of its interval.
        const double want = 1.1 * std::max(*r.rul_days, r.rul_upper_days.value_or(*r.rul_days));
        extension = std::max(extension, want);
    }
    extension = std::min(extension, kMaxProjectionSpans * span);
    const double t_end = t_last + extension;
    ReportCurve c;
    c.model = pg::to_string(f.model);
    c.band_label = "90 % band of the fit";
    for (int i = 0; i < kCurveSamples; ++i) {
        const double t = t_first + (t_end - t_first) * i / (kCurveSamples - 1);
        // Var(a + b t) = c_aa + 2 t c_ab + t^2 c_bb (delta method; on ln y for log-linear).
        const double var = f.covariance(0, 0) + 2 * t * f.covariance(0, 1) + t * t * f.covariance(1, 1);
        const double sd = std::sqrt(std::max(var, 0.0));
        const double eta = f.a + f.b * t;
        double mean = eta, lo = eta - kZ90 * sd, hi = eta + kZ90 * sd;
        if (f.model == pg::DegradationModel::LogLinear) {
            mean = std::exp(eta);
            lo = std::exp(lo);
            hi = std::exp(hi);
        }
        if (!std::isfinite(mean) || !std::isfinite(lo) || !std::isfinite(hi)) break;  // far out in an exponential: stop the curve there
        c.x.push_back(origin_days + t);
        c.mean.push_back(mean);
        c.lower.push_back(lo);
        c.upper.push_back(hi);
    }
    if (c.x.empty()) return std::nullopt;
    return c;
}

}  // namespace emadiag::report
