#include "prognostics/trend_report.hpp"

#include "prognostics/fleet_record.hpp"

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

json parameter_json(const ParameterTrend& p) {
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
    return q;
}

std::string listed(const std::vector<std::string>& names) {
    std::string out;
    for (std::size_t i = 0; i < names.size() && i < 20; ++i) out += (i ? ", " : "") + names[i];
    if (names.size() > 20) out += ", ... (" + std::to_string(names.size()) + " in all)";
    return names.empty() ? std::string("none") : out;
}

std::vector<std::string> keys_of(const std::vector<HistoryView>& views) {
    std::vector<std::string> keys;
    for (const auto& v : views) keys.push_back(v.key);
    return keys;
}

const HistoryView* find_view(const std::vector<HistoryView>& views, const std::string& key) {
    for (const auto& v : views)
        if (v.key == key) return &v;
    return nullptr;
}

TrendSeries series_of(const HistoryView& v) {
    TrendSeries t;
    t.kind = v.kind;
    if (v.kind == "position") {
        t.position = v.key;
        t.serial = v.current_serial;
    } else {
        t.serial = v.key;
        t.place = v.current_place;
        t.position = v.sessions.empty() ? std::string() : v.sessions.back().position.value_or(kNoPosition);
    }
    t.sessions_total = static_cast<int>(v.sessions.size());
    t.sessions_in_trend = static_cast<int>(v.trend_session_ids.size());
    t.trend_session_ids = v.trend_session_ids;
    t.origin_days_since_epoch = v.trend_first_days;
    if (v.trend_first_days) t.origin_utc = format_utc_time(*v.trend_first_days);
    t.last_session_days_since_epoch = v.trend_last_days;
    for (const auto& h : v.parameters) {
        // The calendar axis (days since the series' first session); the record also has it against cycles.
        const AxisTrend* days = nullptr;
        for (const auto& a : h.axes)
            if (a.axis == kAxisDays) days = &a;
        if (days == nullptr) throw EmadiagError(v.kind + " " + v.key + " " + h.parameter + ": the record has no trend against days");
        t.parameters.push_back(days->trend);
    }
    t.notes = v.notes;
    if (t.sessions_in_trend == 0) t.notes.push_back("no session of this actuator in the phase: nothing to trend");
    return t;
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

FleetRecord select_views(const FleetRecord& record, const std::string& position, const std::string& serial) {
    FleetRecord r = record;
    r.positions.clear();
    r.serials.clear();
    if (!position.empty()) {
        const HistoryView* p = find_view(record.positions, position);
        if (p == nullptr)
            throw EmadiagError("position \"" + position + "\" has no session of tail " + record.tail_number + " in " + record.database +
                               " (its positions: " + listed(keys_of(record.positions)) + ")");
        if (!serial.empty() && p->current_serial != serial) {
            const bool known = find_view(record.serials, serial) != nullptr;
            throw EmadiagError("serial \"" + serial + "\" is not the serial installed at " + record.tail_number + " " + position + " now (" +
                               (p->current_serial.empty() ? std::string("its sessions carry no serial") : "it holds " + p->current_serial) +
                               "): a position's trend is that of the serial installed there; " +
                               (known ? "--serial " + serial + " alone gives that actuator's own trend"
                                      : "the serials seen on the tail: " + listed(keys_of(record.serials))));
        }
        r.positions.push_back(*p);
        return r;
    }
    if (!serial.empty()) {
        const HistoryView* s = find_view(record.serials, serial);
        if (s == nullptr)
            throw EmadiagError("serial \"" + serial + "\" has no session on tail " + record.tail_number + " in " + record.database +
                               " (the serials seen on the tail: " + listed(keys_of(record.serials)) + ")");
        r.serials.push_back(*s);
        return r;
    }
    r.positions = record.positions;
    return r;
}

TrendReport trend_report_of(const FleetRecord& record, const TrendOptions& options) {
    check(options);
    const FleetRecord picked = select_views(record, options.position, options.serial);
    TrendReport r;
    r.tail_number = record.tail_number;
    r.phase = options.phase;
    r.sessions_total = static_cast<int>(record.sessions_total - static_cast<std::int64_t>(record.amended_session_ids.size()));
    r.position_filter = options.position;
    r.serial_filter = options.serial;
    r.rul_options = options.rul;
    if (record.sessions_total == 0) r.notes.push_back("the tail has no test sessions (runs stored on their own are not test sessions)");
    if (!record.amended_session_ids.empty()) {
        std::string ids;
        for (auto id : record.amended_session_ids) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
        r.notes.push_back("sessions amended by a correction, left out: " + ids);
    }
    for (const auto* views : {&picked.positions, &picked.serials})
        for (const auto& v : *views) r.series.push_back(series_of(v));
    return r;
}

std::vector<std::string> list_tail_numbers(db::Database& database) {
    db::Statement st(database, "SELECT tail_number FROM aircraft ORDER BY tail_number");
    std::vector<std::string> tails;
    while (st.step()) tails.push_back(st.column_text(0));
    return tails;
}

FleetRecord load_trend_record(db::RecordSource& source, const std::string& tail_number, const TrendOptions& options) {
    check(options);
    FleetRecordOptions o;
    o.phase = options.phase;
    o.rul = options.rul;
    return build_fleet_record(source, tail_number, o);
}

TrendReport load_trend_report(db::Database& database, const std::string& tail_number, const TrendOptions& options) {
    db::SqliteRecordSource source(database);
    return load_trend_report(source, tail_number, options);
}

TrendReport load_trend_report(db::RecordSource& source, const std::string& tail_number, const TrendOptions& options) {
    return trend_report_of(load_trend_record(source, tail_number, options), options);
}

json to_json(const TrendReport& r) {
    json j;
    j["schema"] = kTrendSchema;
    j["version"] = kTrendSchemaVersion;
    j["tail_number"] = r.tail_number;
    j["phase"] = r.phase;
    j["sessions_total"] = r.sessions_total;
    j["filter"] = {{"position", r.position_filter.empty() ? json(nullptr) : json(r.position_filter)},
                   {"serial", r.serial_filter.empty() ? json(nullptr) : json(r.serial_filter)}};
    j["horizon_days"] = r.rul_options.horizon_days;
    j["monte_carlo"] = {{"draws", r.rul_options.draws}, {"seed", r.rul_options.seed}, {"interval", kRulIntervalLevel}};
    j["series"] = json::array();
    for (const auto& t : r.series) {
        json v;
        v["kind"] = t.kind;
        v["position"] = t.position;
        v["serial"] = t.serial;
        if (t.kind == "serial") v["place"] = t.place;
        v["sessions"] = {{"total", t.sessions_total}, {"in_trend", t.sessions_in_trend}};
        v["trend_session_ids"] = t.trend_session_ids;
        v["origin_utc"] = t.origin_utc.empty() ? json(nullptr) : json(t.origin_utc);
        v["last_session_utc"] = t.last_session_days_since_epoch ? json(format_utc_time(*t.last_session_days_since_epoch)) : json(nullptr);
        v["parameters"] = json::array();
        for (const auto& p : t.parameters) v["parameters"].push_back(parameter_json(p));
        v["notes"] = t.notes;
        j["series"].push_back(std::move(v));
    }
    j["notes"] = r.notes;
    return j;
}

}  // namespace emadiag::prognostics
