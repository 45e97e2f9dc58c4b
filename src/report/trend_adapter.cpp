#include "report/trend_adapter.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/utc_time.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace emadiag::report {
namespace {

namespace pg = emadiag::prognostics;

std::string whole(double v) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(0);
    os << v;
    return os.str();
}

}  // namespace

double datasheet_nominal(const std::string& parameter) {
    const sim::EmaParams datasheet;
    if (parameter == kParamFdj) return datasheet.fdj_nm;
    if (parameter == kParamFsj) return datasheet.fsj_nm;
    if (parameter == kParamEtaO) return datasheet.eta_o;
    if (parameter == kParamEtaA) return datasheet.eta_a;
    throw EmadiagError("no datasheet nominal for parameter \"" + parameter + "\" (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
}

std::string parameter_unit(const std::string& parameter) {
    if (parameter == kParamFdj || parameter == kParamFsj) return "N m";
    if (parameter == kParamEtaO || parameter == kParamEtaA) return "";
    throw EmadiagError("no unit known for parameter \"" + parameter + "\" (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
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

ReportDocument from_trend_report(const pg::TrendReport& trend, const std::vector<db::StoredTestSession>& sessions,
                                 const TrendAdapterOptions& options) {
    ReportDocument d;
    d.tail_number = trend.tail_number;
    d.generated_utc = options.generated_utc;
    d.tool_version = options.tool_version;
    d.data_source = options.data_source;
    d.time_axis = TimeAxis::Date;
    {
        std::ostringstream os;
        os << "Phase " << trend.phase << ": " << trend.sessions_in_phase << " of " << trend.sessions_total
           << " test sessions. Each session's measurement is the inverse-variance mean of its physics findings; each parameter is fitted "
              "by weighted least squares, linear or log-linear chosen by AICc; the RUL is the time from the last session until the fitted "
              "mean reaches the limit, its 90 % interval from "
           << trend.rul_options.draws << " Monte Carlo draws of the fit (seed " << trend.rul_options.seed << "), horizon "
           << whole(trend.rul_options.horizon_days) << " days (docs/trend-report.md). The band drawn around the fit is its 90 % band.";
        d.method_note = os.str();
    }
    d.notes = trend.notes;
    d.notes.push_back("One position (" + std::string(kAllPositions) +
                      ") holds every session of the tail: the sessions carry no position in this database.");

    ReportSection s;
    s.name = kAllPositions;
    s.kind = "position";
    s.ata_reference = kAta27;
    const double origin = trend.origin_days_since_epoch.value_or(0.0);

    for (const auto& x : sessions) {
        ReportSession r;
        r.id = std::to_string(x.session_id);
        r.started_utc = x.started_utc;
        r.tail_number = x.tail_number;
        r.position = kAllPositions;
        r.serial = x.actuator_serial;
        r.phase = x.phase;
        r.kind = "test session";
        r.verdict = x.verdict;
        r.note = x.verdict_note;
        s.sessions.push_back(std::move(r));
        // Installations from the serials the sessions saw, in session order (sessions without one are skipped).
        if (!x.actuator_serial.empty() && (s.installations.empty() || s.installations.back().serial != x.actuator_serial)) {
            if (!s.installations.empty()) s.installations.back().to_utc = x.started_utc;
            s.installations.push_back({x.actuator_serial, x.tail_number, kAllPositions, x.started_utc, "", "first seen in session " + r.id});
        }
    }
    if (!s.installations.empty()) s.current = s.installations.back().serial;

    std::vector<ParameterHealthInput> inputs;
    for (const pg::ParameterTrend& p : trend.parameters) {
        ReportParameter q;
        q.name = p.series.parameter;
        q.unit = parameter_unit(q.name);
        q.nominal = datasheet_nominal(q.name);
        q.limit = p.series.limit;
        for (const auto& pt : p.series.points) q.points.push_back({origin + pt.t_days, pt.value, pt.std_error, std::to_string(pt.session_id)});
        q.fit = sample_fit(p, origin);
        q.model_note = p.has_fit ? p.fits.choice.reason : p.fits.chosen().note;
        if (p.rul.status == pg::RulStatus::Predicted && p.crossing_days_since_epoch) {
            q.crossing_x = *p.crossing_days_since_epoch;
            q.crossing_label = pg::format_utc_date(*p.crossing_days_since_epoch);
        }
        q.trend_per_period = p.trend_per_period;
        q.trend_per_period_se = p.trend_per_period_se;
        q.trend_period = whole(pg::kTrendPeriodDays) + " days";
        ReportRul r;
        r.unit = "days";
        r.status = pg::to_string(p.rul.status);
        r.summary = p.rul.summary;
        r.estimate = p.rul.rul_days;
        r.interval_computed = p.rul.interval_computed && p.rul.status != pg::RulStatus::AlreadyExceeded;
        if (r.interval_computed) {
            r.lower = p.rul.rul_lower_days;
            r.upper = p.rul.rul_upper_days;
        }
        r.horizon = p.rul.horizon_days;
        q.rul.push_back(r);
        q.notes = p.series.notes;

        ParameterHealthInput in;
        in.parameter = q.name;
        if (!p.series.points.empty()) {
            in.value = p.series.points.back().value;
            in.std_error = p.series.points.back().std_error;
        }
        in.nominal = q.nominal;
        in.limit = q.limit;
        in.limit_already_exceeded = p.rul.status == pg::RulStatus::AlreadyExceeded;
        if (r.interval_computed) in.rul_lower_days = p.rul.rul_lower_days;
        q.health = assess_parameter(in);
        inputs.push_back(in);
        s.parameters.push_back(std::move(q));
    }
    s.health = assess_position(inputs);
    s.notes.push_back("Discovery findings are not stored in this database: none to show.");
    d.positions.push_back(std::move(s));
    return d;
}

}  // namespace emadiag::report
