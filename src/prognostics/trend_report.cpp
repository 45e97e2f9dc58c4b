#include "prognostics/trend_report.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/utc_time.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::prognostics {
namespace {

using json = nlohmann::ordered_json;

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

json fit_json(const DegradationFit& f) {
    json j;
    j["model"] = to_string(f.model);
    j["equation"] = f.model == DegradationModel::Linear ? "y = a + b t" : "ln y = a + b t";
    j["fitted"] = f.fitted;
    j["points"] = f.points;
    if (!f.fitted) {
        j["note"] = f.note;
        return j;
    }
    j["a"] = f.a;
    j["b_per_day"] = f.b;
    j["covariance"] = {{f.covariance(0, 0), f.covariance(0, 1)}, {f.covariance(1, 0), f.covariance(1, 1)}};
    j["chi2"] = f.chi2;
    j["reduced_chi2"] = f.reduced_chi2;
    j["covariance_scale"] = f.covariance_scale;
    j["chi2_measurement_scale"] = f.chi2_y;
    j["aicc"] = optional_number(f.aicc);
    return j;
}

}  // namespace

void check(const TrendOptions& o) {
    if (o.phase != "pre-flight" && o.phase != "post-flight" && o.phase != kPhaseAll)
        throw EmadiagError("phase \"" + o.phase + "\": expected pre-flight, post-flight or all");
    check(o.rul);
}

ParameterTrend analyse_parameter(ParameterSeries series, const RulOptions& options) {
    ParameterTrend p;
    p.series = std::move(series);
    p.fits = fit_models(p.series.points);
    const DegradationFit& chosen = p.fits.chosen();
    p.has_fit = chosen.fitted;
    if (p.has_fit) {
        const auto [slope, se] = chosen.slope_at(p.series.points.back().t_days);
        p.trend_per_period = slope * kTrendPeriodDays;
        p.trend_per_period_se = se * kTrendPeriodDays;
    }
    p.rul = estimate_rul(p.series.points, chosen, p.series.limit, options);
    return p;
}

TrendReport build_trend_report(const std::string& tail_number, const std::vector<db::StoredTestSession>& sessions,
                               const TrendOptions& options) {
    check(options);
    TrendReport r;
    r.tail_number = tail_number;
    r.phase = options.phase;
    r.rul_options = options.rul;
    r.sessions_total = static_cast<int>(sessions.size());
    const std::vector<double> all_days = session_days(sessions);
    std::vector<db::StoredTestSession> picked;
    std::vector<double> picked_days;
    for (std::size_t i = 0; i < sessions.size(); ++i) {
        if (options.phase != kPhaseAll && sessions[i].phase != options.phase) continue;
        picked.push_back(sessions[i]);
        picked_days.push_back(all_days[i]);
    }
    r.sessions_in_phase = static_cast<int>(picked.size());
    if (r.sessions_total == 0) {
        r.notes.push_back("the tail has no test sessions (runs stored on their own are not test sessions)");
    } else if (r.sessions_in_phase < r.sessions_total) {
        r.notes.push_back(std::to_string(r.sessions_total - r.sessions_in_phase) + " of the tail's " + std::to_string(r.sessions_total) +
                          " test sessions are of another phase and left out (--phase all keeps them)");
    }
    double origin = 0;
    if (!all_days.empty()) {
        origin = *std::min_element(all_days.begin(), all_days.end());
        r.origin_days_since_epoch = origin;
        r.origin_utc = format_utc_time(origin);
    }
    if (!picked_days.empty()) r.last_session_days_since_epoch = *std::max_element(picked_days.begin(), picked_days.end());
    for (const char* parameter : {kParamFdj, kParamFsj, kParamEtaO, kParamEtaA}) {
        ParameterTrend p = analyse_parameter(build_series(picked, picked_days, parameter, origin), options.rul);
        if (p.rul.crossing_t_days) p.crossing_days_since_epoch = origin + *p.rul.crossing_t_days;
        r.parameters.push_back(std::move(p));
    }
    return r;
}

std::vector<std::string> list_tail_numbers(db::Database& database) {
    db::Statement st(database, "SELECT tail_number FROM aircraft ORDER BY tail_number");
    std::vector<std::string> tails;
    while (st.step()) tails.push_back(st.column_text(0));
    return tails;
}

TrendReport load_trend_report(db::Database& database, const std::string& tail_number, const TrendOptions& options) {
    db::SqliteRecordSource source(database);
    return load_trend_report(source, tail_number, options);
}

TrendReport load_trend_report(db::RecordSource& database, const std::string& tail_number, const TrendOptions& options) {
    check(options);
    const auto tails = database.tail_numbers();
    if (std::find(tails.begin(), tails.end(), tail_number) == tails.end()) {
        std::string known;
        for (std::size_t i = 0; i < tails.size(); ++i) known += (i ? ", " : "") + tails[i];
        throw EmadiagError("tail number \"" + tail_number + "\" is not in " + database.name() + " (" +
                           (tails.empty() ? std::string("it holds no aircraft") : "its tail numbers: " + known) + ")");
    }
    return build_trend_report(tail_number, database.sessions_of_tail(tail_number), options);
}

json to_json(const TrendReport& r) {
    json j;
    j["schema"] = kTrendSchema;
    j["version"] = kTrendSchemaVersion;
    j["tail_number"] = r.tail_number;
    j["phase"] = r.phase;
    j["sessions"] = {{"total", r.sessions_total}, {"in_phase", r.sessions_in_phase}};
    j["origin_utc"] = r.origin_utc.empty() ? json(nullptr) : json(r.origin_utc);
    j["horizon_days"] = r.rul_options.horizon_days;
    j["monte_carlo"] = {{"draws", r.rul_options.draws}, {"seed", r.rul_options.seed}, {"interval", kRulIntervalLevel}};
    j["parameters"] = json::array();
    for (const auto& p : r.parameters) {
        json q;
        q["parameter"] = p.series.parameter;
        q["status"] = to_string(p.rul.status);
        q["summary"] = p.rul.summary;
        q["limit"] = p.series.limit ? json{{"kind", to_string(p.series.limit->side)},
                                           {"value", p.series.limit->value},
                                           {"session_id", p.series.limit->session_id}}
                                    : json(nullptr);
        q["points"] = json::array();
        for (const auto& pt : p.series.points) {
            q["points"].push_back({{"session_id", pt.session_id},
                                   {"started_utc", pt.started_utc},
                                   {"t_days", pt.t_days},
                                   {"value", pt.value},
                                   {"std_error", pt.std_error},
                                   {"estimators", pt.estimators}});
        }
        if (p.series.points.empty()) {
            q["latest"] = nullptr;
        } else {
            const TrendPoint& last = p.series.points.back();
            q["latest"] = {{"session_id", last.session_id},
                           {"t_days", last.t_days},
                           {"value", last.value},
                           {"std_error", last.std_error},
                           {"ci95", {last.value - kZ95 * last.std_error, last.value + kZ95 * last.std_error}}};
        }
        q["fits"] = {{"linear", fit_json(p.fits.linear)}, {"log_linear", fit_json(p.fits.log_linear)}};
        q["aicc_overdispersion"] = p.fits.overdispersion;
        q["model"] = p.has_fit ? json{{"chosen", to_string(p.fits.choice.model)}, {"reason", p.fits.choice.reason}} : json(nullptr);
        q["trend_per_100_days"] = p.trend_per_period ? json{{"value", *p.trend_per_period}, {"std_error", *p.trend_per_period_se}}
                                                     : json(nullptr);
        q["crossing"] = p.rul.crossing_t_days ? json{{"t_days", *p.rul.crossing_t_days},
                                                     {"date_utc", format_utc_date(*p.crossing_days_since_epoch)}}
                                              : json(nullptr);
        json rul;
        rul["t_last_days"] = p.rul.t_last_days;
        rul["estimate_days"] = optional_number(p.rul.rul_days);
        if (p.rul.interval_computed) {
            rul["ci90_days"] = {optional_number(p.rul.rul_lower_days), optional_number(p.rul.rul_upper_days)};
            rul["lower_beyond_horizon"] = !p.rul.rul_lower_days.has_value();
            rul["upper_beyond_horizon"] = !p.rul.rul_upper_days.has_value();
            rul["draws"] = p.rul.draws;
            rul["draws_beyond_horizon"] = p.rul.draws_beyond_horizon;
            rul["draws_already_crossed"] = p.rul.draws_already_crossed;
            rul["seed"] = p.rul.seed;
        } else {
            rul["ci90_days"] = nullptr;
        }
        rul["exceeded_session_id"] = p.rul.exceeded_session_id ? json(*p.rul.exceeded_session_id) : json(nullptr);
        q["rul"] = rul;
        q["notes"] = p.series.notes;
        j["parameters"].push_back(std::move(q));
    }
    j["notes"] = r.notes;
    return j;
}

}  // namespace emadiag::prognostics
