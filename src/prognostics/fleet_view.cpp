#include "prognostics/fleet_view.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

namespace emadiag::prognostics {
namespace {

using json = nlohmann::ordered_json;
constexpr double kPer = 100.0;  // slopes per 100 days or 100 cycles

/// Order of the last verdict when urgencies tie: the worse first.
int verdict_rank(const std::string& v) {
    if (v == "UNSERVICEABLE") return 0;
    if (v == "INCONCLUSIVE") return 1;
    if (v == "NO_TEST") return 2;
    return 3;
}

}  // namespace

DegradationFit fit_from_stats(const db::SeriesStats& s, bool cycles) {
    DegradationFit f;
    f.model = DegradationModel::Linear;
    const std::int64_t n = cycles ? s.n_cycles : s.n;
    f.points = static_cast<int>(n);
    if (n < kMinTrendPoints) {
        f.note = "insufficient data (" + std::to_string(n) + " sessions; need >= " + std::to_string(kMinTrendPoints) + ")";
        return f;
    }
    // Weighted least squares of y = a + b t from its sums (Numerical Recipes 3rd ed., section 15.2).
    const double S = cycles ? s.c_w : s.s_w, Sx = cycles ? s.c_wt : s.s_wt, Sxx = cycles ? s.c_wtt : s.s_wtt;
    const double Sy = cycles ? s.c_wy : s.s_wy, Sxy = cycles ? s.c_wty : s.s_wty, Syy = cycles ? s.c_wyy : s.s_wyy;
    const double delta = S * Sxx - Sx * Sx;
    if (!(delta > 1e-12 * S * Sxx)) {
        f.note = "all sessions at the same time: no slope";
        return f;
    }
    f.b = (S * Sxy - Sx * Sy) / delta;
    f.a = (Sxx * Sy - Sx * Sxy) / delta;
    f.chi2 = std::max(0.0, Syy - 2 * f.a * Sy - 2 * f.b * Sxy + f.a * f.a * S + 2 * f.a * f.b * Sx + f.b * f.b * Sxx);
    f.reduced_chi2 = f.chi2 / static_cast<double>(n - kModelParameters);
    f.covariance_scale = std::max(1.0, f.reduced_chi2);
    f.covariance << Sxx / delta, -Sx / delta, -Sx / delta, S / delta;
    f.covariance *= f.covariance_scale;
    f.chi2_y = f.chi2;
    f.fitted = true;
    return f;
}

std::vector<FleetRow> build_fleet_view(db::Database& database, const FleetOptions& options) {
    db::SqliteRecordSource source(database);
    return build_fleet_view(source, options);
}

std::vector<FleetRow> build_fleet_view(db::RecordSource& database, const FleetOptions& options) {
    check(options.rul);
    std::map<std::string, std::string> ata;
    for (const auto& p : database.positions()) ata[p.position] = p.ata_reference;
    std::map<std::tuple<std::string, std::string, std::string>, std::vector<db::SeriesStats>> stats;
    for (auto& s : database.series_stats()) stats[{s.tail_number, s.position, s.actuator_serial}].push_back(std::move(s));
    std::vector<FleetRow> rows;
    for (const auto& ps : database.position_status()) {
        FleetRow row;
        row.tail_number = ps.tail_number;
        row.position = ps.position.empty() ? "(none)" : ps.position;
        row.ata_reference = ata.count(ps.position) ? ata[ps.position] : "";
        row.actuator_serial = ps.actuator_serial;
        row.sessions = ps.sessions;
        row.last_utc = ps.last_utc;
        row.last_verdict = ps.last_verdict;
        row.last_cycles = ps.last_cycles;
        bool exceeded = false, predicted = false, any_fit = false;
        const auto it = stats.find({ps.tail_number, ps.position, ps.actuator_serial});
        if (it != stats.end()) {
            for (const auto& s : it->second) {
                FleetParameter p;
                p.parameter = s.parameter;
                const bool cycles = s.n_cycles == s.n && s.n > 0 && s.first_cycles && s.last_cycles;
                p.axis = cycles ? "cycles" : "days";
                p.points = s.n;
                p.latest = s.last_value;
                p.latest_se = s.last_std_error;
                const DegradationFit fit = fit_from_stats(s, cycles);
                if (fit.fitted) {
                    p.slope_per_100 = fit.b * kPer;
                    any_fit = true;
                }
                TrendPoint last;
                last.session_id = s.last_session_id;
                last.value = s.last_value;
                last.std_error = s.last_std_error;
                last.t_days = cycles ? *s.last_cycles - *s.first_cycles : s.last_days - s.first_days;
                std::optional<TrendLimit> limit;
                if (s.limit_value && (s.limit_kind == "max" || s.limit_kind == "min"))
                    limit = TrendLimit{s.limit_kind == "max" ? LimitSide::Max : LimitSide::Min, *s.limit_value, s.last_session_id};
                RulOptions ro = options.rul;
                if (cycles) ro.horizon_days = options.horizon_cycles;
                p.rul = estimate_rul({last}, fit, limit, ro);
                // The lower bound in days: cycles at the position's own rate.
                double per_day = 1.0;
                if (cycles) {
                    const double span_days = s.last_days - s.first_days;
                    const double span_cycles = *s.last_cycles - *s.first_cycles;
                    per_day = span_days > 0 && span_cycles > 0 ? span_cycles / span_days : 0.0;
                }
                if (p.rul.status == RulStatus::AlreadyExceeded) {
                    p.rul_lower_days = 0.0;
                    exceeded = true;
                } else if (p.rul.interval_computed && p.rul.rul_lower_days && per_day > 0) {
                    p.rul_lower_days = *p.rul.rul_lower_days / per_day;
                }
                if (p.rul.status == RulStatus::Predicted) predicted = true;
                if (p.rul_lower_days && (!row.urgency_days || *p.rul_lower_days < *row.urgency_days)) {
                    row.urgency_days = p.rul_lower_days;
                    row.driving_parameter = p.parameter;
                }
                row.parameters.push_back(std::move(p));
            }
        }
        row.status = exceeded ? "limit exceeded" : predicted ? "crossing predicted" : any_fit ? "no crossing within the horizon" : "insufficient data";
        rows.push_back(std::move(row));
    }
    std::stable_sort(rows.begin(), rows.end(), [](const FleetRow& a, const FleetRow& b) {
        const double ua = a.urgency_days.value_or(std::numeric_limits<double>::infinity());
        const double ub = b.urgency_days.value_or(std::numeric_limits<double>::infinity());
        if (ua != ub) return ua < ub;
        return verdict_rank(a.last_verdict) < verdict_rank(b.last_verdict);
    });
    for (std::size_t i = 0; i < rows.size(); ++i) rows[i].rank = static_cast<int>(i + 1);
    return rows;
}

json to_json(const std::vector<FleetRow>& rows, const FleetOptions& options) {
    const auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
    json j;
    j["schema"] = kFleetSchema;
    j["version"] = kFleetSchemaVersion;
    j["horizon"] = {{"days", options.rul.horizon_days}, {"cycles", options.horizon_cycles}};
    j["monte_carlo"] = {{"draws", options.rul.draws}, {"seed", options.rul.seed}, {"interval", kRulIntervalLevel}};
    j["rows"] = json::array();
    for (const auto& r : rows) {
        json q;
        q["rank"] = r.rank;
        q["tail_number"] = r.tail_number;
        q["position"] = r.position;
        q["ata_reference"] = r.ata_reference;
        q["actuator_serial"] = r.actuator_serial;
        q["sessions"] = r.sessions;
        q["last_utc"] = r.last_utc;
        q["last_verdict"] = r.last_verdict;
        q["last_cycles"] = r.last_cycles ? json(*r.last_cycles) : json(nullptr);
        q["status"] = r.status;
        q["driving_parameter"] = r.driving_parameter.empty() ? json(nullptr) : json(r.driving_parameter);
        q["urgency_days"] = opt(r.urgency_days);
        q["parameters"] = json::array();
        for (const auto& p : r.parameters) {
            q["parameters"].push_back({{"parameter", p.parameter},
                                       {"axis", p.axis},
                                       {"points", p.points},
                                       {"latest", p.latest},
                                       {"latest_std_error", p.latest_se},
                                       {"slope_per_100", opt(p.slope_per_100)},
                                       {"rul_status", to_string(p.rul.status)},
                                       {"rul", opt(p.rul.rul_days)},
                                       {"rul_ci90", p.rul.interval_computed ? json{opt(p.rul.rul_lower_days), opt(p.rul.rul_upper_days)} : json(nullptr)},
                                       {"rul_lower_days", opt(p.rul_lower_days)}});
        }
        j["rows"].push_back(std::move(q));
    }
    return j;
}

}  // namespace emadiag::prognostics
