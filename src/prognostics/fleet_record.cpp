#include "prognostics/fleet_record.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/utc_time.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <tuple>

namespace emadiag::prognostics {
namespace {

using json = nlohmann::ordered_json;

/// estimate_rul words its summary in days; on the cycles axis the same numbers are cycles.
std::string in_cycles(std::string s) {
    for (const auto& [from, to] : {std::pair<std::string, std::string>{" days", " cycles"}, {"at day ", "at cycle "}, {"(day ", "(cycle "}}) {
        for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
    }
    return s;
}

/// The sessions of a view on both axes, prepared once for its four parameters (pointers into the
/// report's lists: no copies).
struct ViewAxes {
    std::vector<const db::StoredTestSession*> sessions, with_cycles;
    std::vector<double> days, cycle_axis;
    double origin_days = 0;
};

ParameterHistory analyse(const ViewAxes& v, const std::string& parameter, const FleetRecordOptions& o) {
    ParameterHistory h;
    h.parameter = parameter;
    if (!v.with_cycles.empty()) {
        RulOptions r = o.rul;
        r.horizon_days = o.horizon_cycles;
        AxisTrend a{kAxisCycles, analyse_parameter(build_series(v.with_cycles, v.cycle_axis, parameter, 0.0), r)};
        a.trend.rul.summary = in_cycles(a.trend.rul.summary);
        if (v.with_cycles.size() < v.sessions.size())
            a.trend.series.notes.push_back(std::to_string(v.sessions.size() - v.with_cycles.size()) +
                                           " session(s) without cycles left out of the cycles axis");
        h.axes.push_back(std::move(a));
    }
    AxisTrend d{kAxisDays, analyse_parameter(build_series(v.sessions, v.days, parameter, v.origin_days), o.rul)};
    if (d.trend.rul.crossing_t_days) d.trend.crossing_days_since_epoch = v.origin_days + *d.trend.rul.crossing_t_days;
    h.axes.push_back(std::move(d));
    h.preferred_axis = !v.with_cycles.empty() && v.with_cycles.size() == v.sessions.size() ? kAxisCycles : kAxisDays;
    return h;
}

/// The view's trends over `trend_sessions` (which must outlive the call).
void fill_trends(HistoryView& v, const std::vector<const db::StoredTestSession*>& trend_sessions, const FleetRecordOptions& o) {
    std::vector<const db::StoredTestSession*> picked;
    picked.reserve(trend_sessions.size());
    for (const auto* s : trend_sessions) {
        if (o.phase != kPhaseAll && s->phase != o.phase) continue;
        picked.push_back(s);
        v.trend_session_ids.push_back(s->session_id);
    }
    if (picked.size() < trend_sessions.size())
        v.notes.push_back(std::to_string(trend_sessions.size() - picked.size()) + " session(s) of another phase than " + o.phase +
                          " left out of the trends");
    ViewAxes axes;
    axes.days = session_days(picked);
    axes.origin_days = axes.days.empty() ? 0.0 : *std::min_element(axes.days.begin(), axes.days.end());
    if (!axes.days.empty()) {
        v.trend_first_days = axes.origin_days;
        v.trend_last_days = *std::max_element(axes.days.begin(), axes.days.end());
    }
    // The actuator's cycles: aircraft cycles since the view's first session, summed over the tails it
    // was on (the cycles between a removal and the next installation are not known: none).
    double total = 0;
    const db::StoredTestSession* prev = nullptr;
    for (const auto* s : picked) {
        if (!s->cycles) continue;
        if (prev != nullptr && prev->tail_number == s->tail_number) total += static_cast<double>(*s->cycles - *prev->cycles);
        prev = s;
        axes.with_cycles.push_back(s);
        axes.cycle_axis.push_back(total);
    }
    axes.sessions = std::move(picked);
    std::vector<ParameterHistory> parameters;
    for (const char* p : kHealthParameterNames) parameters.push_back(analyse(axes, p, o));
    v.parameters = SharedList<ParameterHistory>(std::move(parameters));
}

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

json session_json(const db::StoredTestSession& s) {
    json j;
    j["session_id"] = s.session_id;
    j["started_utc"] = s.started_utc;
    j["tail_number"] = s.tail_number;
    j["position"] = s.position ? json(*s.position) : json(nullptr);
    j["actuator_serial"] = s.actuator_serial;
    j["phase"] = s.phase;
    j["source"] = s.source;
    j["cycles"] = s.cycles ? json(*s.cycles) : json(nullptr);
    j["hours"] = optional_number(s.hours_h);
    j["operator_id"] = s.operator_id;
    j["technician_name"] = s.technician_name;
    j["technician_certificate"] = s.technician_certificate;
    j["work_performed"] = s.work_performed;
    j["verdict"] = s.verdict;
    j["verdict_note"] = s.verdict_note;
    j["amends_session_id"] = s.amends_session_id ? json(*s.amends_session_id) : json(nullptr);
    j["content_sha256"] = s.content_sha256;
    return j;
}

json installation_json(const db::StoredInstallation& i) {
    return {{"installation_id", i.installation_id}, {"tail_number", i.tail_number}, {"position", i.position}, {"from_serial", i.from_serial},
            {"to_serial", i.to_serial},           {"detected_utc", i.detected_utc}, {"cycles", i.cycles ? json(*i.cycles) : json(nullptr)},
            {"hours", optional_number(i.hours_h)}, {"session_id", i.session_id}};
}

json axis_json(const AxisTrend& a) {
    const ParameterTrend& p = a.trend;
    json q;
    q["axis"] = a.axis;
    q["status"] = to_string(p.rul.status);
    q["summary"] = p.rul.summary;
    q["points"] = json::array();
    for (const auto& pt : p.series.points)
        q["points"].push_back({{"session_id", pt.session_id}, {"started_utc", pt.started_utc}, {"t", pt.t_days}, {"value", pt.value},
                               {"std_error", pt.std_error}});
    q["limit"] = p.series.limit ? json{{"kind", to_string(p.series.limit->side)}, {"value", p.series.limit->value}} : json(nullptr);
    if (p.has_fit) {
        const DegradationFit& f = p.fits.chosen();
        q["model"] = {{"chosen", to_string(f.model)},
                      {"reason", p.fits.choice.reason},
                      {"a", f.a},
                      {"b_per_unit", f.b},
                      {"covariance", {{f.covariance(0, 0), f.covariance(0, 1)}, {f.covariance(1, 0), f.covariance(1, 1)}}}};
    } else {
        q["model"] = nullptr;
    }
    q["trend_per_100"] = p.trend_per_period ? json{{"value", *p.trend_per_period}, {"std_error", *p.trend_per_period_se}} : json(nullptr);
    q["crossing_t"] = optional_number(p.rul.crossing_t_days);
    q["crossing_date_utc"] = p.crossing_days_since_epoch ? json(format_utc_date(*p.crossing_days_since_epoch)) : json(nullptr);
    q["rul"] = {{"estimate", optional_number(p.rul.rul_days)},
                {"ci90", p.rul.interval_computed ? json{optional_number(p.rul.rul_lower_days), optional_number(p.rul.rul_upper_days)}
                                                 : json(nullptr)},
                {"horizon", p.rul.horizon_days},
                {"t_last", p.rul.t_last_days}};
    q["notes"] = p.series.notes;
    return q;
}

json view_json(const HistoryView& v) {
    json j;
    j["kind"] = v.kind;
    j["key"] = v.key;
    if (v.kind == "position") {
        j["ata_reference"] = v.ata_reference;
        j["description"] = v.description;
        j["current_serial"] = v.current_serial;
    } else {
        j["current_place"] = v.current_place;
    }
    j["last_verdict"] = v.last_verdict;
    j["sessions"] = json::array();
    for (const auto& s : v.sessions) j["sessions"].push_back(session_json(s));
    j["trend_session_ids"] = v.trend_session_ids;
    j["installations"] = json::array();
    for (const auto& i : v.installations) j["installations"].push_back(installation_json(i));
    j["parameters"] = json::array();
    for (const auto& p : v.parameters) {
        json q;
        q["parameter"] = p.parameter;
        q["preferred_axis"] = p.preferred_axis;
        q["axes"] = json::array();
        for (const auto& a : p.axes) q["axes"].push_back(axis_json(a));
        j["parameters"].push_back(std::move(q));
    }
    j["notes"] = v.notes;
    return j;
}

/// The view of one serial seen on the tail: its whole history on every tail (from the positions'
/// sessions when it never left this tail), and its trends (a position's when they are the same sessions).
HistoryView serial_view(db::RecordSource& database, const FleetRecord& r, const std::string& serial, const std::string& tail_number,
                        const db::SessionListParts& rows_and_findings, const FleetRecordOptions& options) {
    HistoryView v;
    v.kind = "serial";
    v.key = serial;
    std::vector<db::StoredTestSession> sessions;
    std::set<std::int64_t> amended_here;
    v.installations = database.installations_of_serial(serial);
    const bool only_here = !database.serial_seen_elsewhere(serial, tail_number);
    if (only_here) {
        // From the positions' sessions: sorted as pointers; when they are one position's whole
        // history, in its order, that list is shared; otherwise each kept session is copied once.
        std::vector<const db::StoredTestSession*> of_serial;
        for (const auto& pv : r.positions)
            for (const auto& s : pv.sessions)
                if (s.actuator_serial == serial) of_serial.push_back(&s);
        std::sort(of_serial.begin(), of_serial.end(), [](const auto* a, const auto* b) {
            return std::tie(a->started_utc, a->session_id) < std::tie(b->started_utc, b->session_id);
        });
        for (const auto* s : of_serial)
            if (s->amends_session_id) amended_here.insert(*s->amends_session_id);
        std::erase_if(of_serial, [&amended_here](const db::StoredTestSession* s) { return amended_here.count(s->session_id) > 0; });
        for (const auto& pv : r.positions) {
            if (pv.sessions.size() != of_serial.size()) continue;
            bool whole = true;
            for (std::size_t i = 0; i < of_serial.size() && whole; ++i) whole = of_serial[i] == &pv.sessions[i];
            if (whole) {
                v.sessions = pv.sessions;
                break;
            }
        }
        if (v.sessions.empty()) {
            sessions.reserve(of_serial.size());
            for (const auto* s : of_serial) sessions.push_back(*s);
        }
    } else {
        std::vector<db::StoredTestSession> of_serial = database.sessions_of_serial(serial, rows_and_findings);
        for (const auto& s : of_serial)
            if (s.amends_session_id) amended_here.insert(*s.amends_session_id);
        sessions.reserve(of_serial.size());
        for (auto& s : of_serial)
            if (!amended_here.count(s.session_id)) sessions.push_back(std::move(s));
    }
    if (v.sessions.empty()) v.sessions = SharedList<db::StoredTestSession>(std::move(sessions));
    const auto& history = v.sessions;
    v.current_place = history.back().tail_number + " " + history.back().position.value_or(kNoPosition);
    v.last_verdict = history.back().verdict;
    std::set<std::string> places;
    for (const auto& s : history) places.insert(s.tail_number + " " + s.position.value_or(kNoPosition));
    if (places.size() > 1) {
        std::string list;
        for (const auto& p : places) list += (list.empty() ? "" : ", ") + p;
        v.notes.push_back("installed at " + std::to_string(places.size()) + " places: " + list);
    }
    // A serial that never left one position has that position's trends: computed once.
    const HistoryView* same = nullptr;
    std::vector<std::int64_t> ids;
    for (const auto& s : history)
        if (options.phase == kPhaseAll || s.phase == options.phase) ids.push_back(s.session_id);
    for (const auto& pv : r.positions)
        if (pv.trend_session_ids == ids) same = &pv;
    if (same != nullptr) {
        v.trend_session_ids = ids;
        v.trend_first_days = same->trend_first_days;
        v.trend_last_days = same->trend_last_days;
        v.parameters = same->parameters;
    } else {
        std::vector<const db::StoredTestSession*> ptrs;
        for (const auto& s : history) ptrs.push_back(&s);
        fill_trends(v, ptrs, options);
    }
    return v;
}

}  // namespace

const AxisTrend* ParameterHistory::preferred() const {
    for (const auto& a : axes)
        if (a.axis == preferred_axis) return &a;
    return axes.empty() ? nullptr : &axes.back();
}

FleetRecord build_fleet_record(db::Database& database, const std::string& tail_number, const FleetRecordOptions& options) {
    db::SqliteRecordSource source(database);
    return build_fleet_record(source, tail_number, options);
}

FleetRecord build_fleet_record(db::RecordSource& database, const std::string& tail_number, const FleetRecordOptions& options) {
    if (options.phase != kPhaseAll && options.phase != "pre-flight" && options.phase != "post-flight" && options.phase != "in-flight" &&
        options.phase != "load-rig")
        throw EmadiagError("phase \"" + options.phase + "\": expected pre-flight, post-flight, in-flight, load-rig or all");
    check(options.rul);
    if (!(options.horizon_cycles > 0) || !(options.horizon_cycles <= kMaxHorizonDays))
        throw EmadiagError("horizon_cycles " + std::to_string(options.horizon_cycles) + " is not in (0, " + std::to_string(kMaxHorizonDays) + "]");
    db::check_tail_number(tail_number);
    const auto tails = database.tail_numbers();
    if (std::find(tails.begin(), tails.end(), tail_number) == tails.end()) {
        std::string known;
        for (std::size_t i = 0; i < tails.size() && i < 20; ++i) known += (i ? ", " : "") + tails[i];
        if (tails.size() > 20) known += ", ... (" + std::to_string(tails.size()) + " in all)";
        throw EmadiagError("tail number \"" + tail_number + "\" is not in " + database.name() + " (" +
                           (tails.empty() ? std::string("it holds no aircraft") : "its tail numbers: " + known) + ")");
    }
    FleetRecord r;
    r.tail_number = tail_number;
    r.database = database.name();
    r.options = options;
    db::check_tail_number(tail_number);
    // Rows and findings: the report shows neither artifacts nor runs, nor the limits text and the
    // chain links of each session (only its content hash).
    const db::SessionListParts rows_and_findings{false, false, false};
    auto all = database.sessions_of_tail(tail_number, rows_and_findings);
    r.sessions_total = static_cast<std::int64_t>(all.size());
    std::set<std::int64_t> amended;
    for (const auto& s : all)
        if (s.amends_session_id) amended.insert(*s.amends_session_id);
    r.amended_session_ids.assign(amended.begin(), amended.end());
    {
        std::int64_t newest = -1;
        for (const auto& s : all)
            if (s.session_id > newest) {
                newest = s.session_id;
                r.chain_head_sha256 = s.content_sha256;
            }
    }
    // The sessions no correction replaces, in place (no second vector of every session).
    std::vector<db::StoredTestSession>& current = all;
    if (!amended.empty()) std::erase_if(current, [&amended](const db::StoredTestSession& s) { return amended.count(s.session_id) > 0; });
    r.installations = database.installations_of_tail(tail_number);
    r.open_findings = database.discovery_findings(tail_number, true);

    std::set<std::string> serials;
    for (const auto& s : current)
        if (!s.actuator_serial.empty()) serials.insert(s.actuator_serial);
    // Per position: the history across serials; the trends of the serial installed now. (Each
    // session is moved to its position: the serial views below copy from the positions.)
    std::map<std::string, std::vector<db::StoredTestSession>> by_position;
    {
        std::map<std::string, std::size_t> counts;
        for (const auto& s : current) ++counts[s.position.value_or(kNoPosition)];
        for (const auto& [position, n] : counts) by_position[position].reserve(n);
    }
    for (auto& s : current) {
        const std::string position = s.position.value_or(kNoPosition);
        by_position[position].push_back(std::move(s));
    }
    current.clear();
    for (auto& [position, sessions] : by_position) {
        HistoryView v;
        v.kind = "position";
        v.key = position;
        v.ata_reference = sessions.back().position_ata;
        v.description = sessions.back().position_description;
        v.current_serial = sessions.back().actuator_serial;
        v.last_verdict = sessions.back().verdict;
        for (const auto& i : r.installations)
            if (i.position == position) v.installations.push_back(i);
        std::vector<const db::StoredTestSession*> trend;
        std::vector<std::string> earlier;  // the other serials seen here, in order of first session
        for (const auto& s : sessions) {
            if (s.actuator_serial == v.current_serial)
                trend.push_back(&s);
            else if (std::find(earlier.begin(), earlier.end(), s.actuator_serial) == earlier.end())
                earlier.push_back(s.actuator_serial);
        }
        if (trend.size() < sessions.size()) {
            std::string names;
            for (const auto& e : earlier) names += (names.empty() ? "" : ", ") + (e.empty() ? std::string("(unknown)") : e);
            v.notes.push_back("trends are those of serial " + (v.current_serial.empty() ? std::string("(unknown)") : v.current_serial) +
                              ", installed now: " + std::to_string(sessions.size() - trend.size()) +
                              " session(s) of earlier serials (" + names + ") are in the history only; each serial has its own trend");
        }
        fill_trends(v, trend, options);
        v.sessions = SharedList<db::StoredTestSession>(std::move(sessions));
        r.positions.push_back(std::move(v));
    }
    // Per serial seen on this tail: its whole history on every tail.
    for (const auto& serial : serials) r.serials.push_back(serial_view(database, r, serial, tail_number, rows_and_findings, options));
    return r;
}

json to_json(const FleetRecord& r) {
    json j;
    j["schema"] = kReportSchema;
    j["version"] = kReportSchemaVersion;
    j["tail_number"] = r.tail_number;
    j["database"] = r.database;
    j["phase"] = r.options.phase;
    j["horizon"] = {{"days", r.options.rul.horizon_days}, {"cycles", r.options.horizon_cycles}};
    j["monte_carlo"] = {{"draws", r.options.rul.draws}, {"seed", r.options.rul.seed}, {"interval", kRulIntervalLevel}};
    j["sessions_total"] = r.sessions_total;
    j["amended_session_ids"] = r.amended_session_ids;
    j["chain_head_sha256"] = r.chain_head_sha256;
    j["positions"] = json::array();
    for (const auto& v : r.positions) j["positions"].push_back(view_json(v));
    j["serials"] = json::array();
    for (const auto& v : r.serials) j["serials"].push_back(view_json(v));
    j["installations"] = json::array();
    for (const auto& i : r.installations) j["installations"].push_back(installation_json(i));
    j["open_discovery_findings"] = json::array();
    for (const auto& f : r.open_findings)
        j["open_discovery_findings"].push_back({{"finding_id", f.finding_id},
                                                {"found_utc", f.found_utc},
                                                {"position", f.position ? json(*f.position) : json(nullptr)},
                                                {"actuator_serial", f.actuator_serial},
                                                {"summary", f.summary},
                                                {"status", f.status}});
    return j;
}

}  // namespace emadiag::prognostics
