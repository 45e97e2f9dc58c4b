#include "report/record_adapter.hpp"

#include "prognostics/utc_time.hpp"

#include <cmath>
#include <sstream>

namespace emadiag::report {
namespace {

namespace pg = emadiag::prognostics;

/// A count of days or cycles, rounded.
std::string whole(double v) { return std::to_string(std::llround(v)); }

/// Every trend with data prefers flight cycles: the plots can all be drawn against cycles.
bool all_prefer_cycles(const pg::FleetRecord& r) {
    bool any = false;
    for (const auto* views : {&r.positions, &r.serials})
        for (const auto& v : *views)
            for (const auto& p : v.parameters) {
                const pg::AxisTrend* a = p.preferred();
                if (a == nullptr || a->trend.series.points.empty()) continue;
                if (p.preferred_axis != pg::kAxisCycles) return false;
                any = true;
            }
    return any;
}

const pg::AxisTrend* axis_of(const pg::ParameterHistory& p, const std::string& axis) {
    for (const auto& a : p.axes)
        if (a.axis == axis) return &a;
    return nullptr;
}

ReportRul rul_of(const pg::AxisTrend& a) {
    const pg::RulEstimate& e = a.trend.rul;
    ReportRul r;
    r.unit = a.axis;
    r.status = pg::to_string(e.status);
    r.summary = e.summary;
    r.estimate = e.rul_days;
    r.interval_computed = e.interval_computed && e.status != pg::RulStatus::AlreadyExceeded;
    if (r.interval_computed) {
        r.lower = e.rul_lower_days;
        r.upper = e.rul_upper_days;
    }
    r.horizon = e.horizon_days;
    return r;
}

/// Days since 1970 of the days axis' t = 0 (the series' first session).
double days_origin(const pg::ParameterTrend& t) {
    if (t.series.points.empty()) return 0.0;
    const auto& first = t.series.points.front();
    return pg::parse_utc_days_or_throw(first.started_utc, "session " + std::to_string(first.session_id) + " started_utc") - first.t_days;
}

ReportParameter parameter_of(const pg::ParameterHistory& h, TimeAxis axis, ParameterHealthInput& health_in) {
    ReportParameter q;
    q.name = h.parameter;
    q.unit = parameter_unit(q.name);
    q.nominal = datasheet_nominal(q.name);
    const pg::AxisTrend* days = axis_of(h, pg::kAxisDays);
    const pg::AxisTrend* cycles = axis_of(h, pg::kAxisCycles);
    const pg::AxisTrend* plotted = axis == TimeAxis::Cycles && cycles != nullptr ? cycles : days;
    if (plotted == nullptr) return q;
    const pg::ParameterTrend& t = plotted->trend;
    const double origin = plotted == days ? days_origin(t) : 0.0;
    q.limit = t.series.limit;
    for (const auto& pt : t.series.points) q.points.push_back({origin + pt.t_days, pt.value, pt.std_error, std::to_string(pt.session_id)});
    q.fit = sample_fit(t, origin);
    q.model_note = t.has_fit ? t.fits.choice.reason : t.fits.chosen().note;
    if (t.rul.status == pg::RulStatus::Predicted && t.rul.crossing_t_days) {
        q.crossing_x = origin + *t.rul.crossing_t_days;
        q.crossing_label = plotted == days ? pg::format_utc_date(q.crossing_x.value()) : "cycle " + whole(*t.rul.crossing_t_days);
    }
    q.trend_per_period = t.trend_per_period;
    q.trend_per_period_se = t.trend_per_period_se;
    q.trend_period = "100 " + plotted->axis;
    for (const auto& a : h.axes) q.rul.push_back(rul_of(a));  // cycles first, then days
    q.notes = t.series.notes;
    if (plotted != h.preferred()) q.notes.push_back("plotted against " + plotted->axis + "; the preferred axis is " + h.preferred_axis);

    // Health: the latest measurement of the preferred axis (the same sessions on both when every one
    // carries cycles); the RUL windows are in days, so the days axis' lower bound.
    health_in.parameter = q.name;
    const pg::AxisTrend* pref = h.preferred();
    if (pref != nullptr && !pref->trend.series.points.empty()) {
        health_in.value = pref->trend.series.points.back().value;
        health_in.std_error = pref->trend.series.points.back().std_error;
    }
    health_in.nominal = q.nominal;
    health_in.limit = pref != nullptr ? pref->trend.series.limit : q.limit;
    for (const auto& a : h.axes)
        if (a.trend.rul.status == pg::RulStatus::AlreadyExceeded) health_in.limit_already_exceeded = true;
    if (days != nullptr && days->trend.rul.interval_computed && days->trend.rul.status != pg::RulStatus::AlreadyExceeded)
        health_in.rul_lower_days = days->trend.rul.rul_lower_days;
    q.health = assess_parameter(health_in);
    return q;
}

ReportSession session_of(const db::StoredTestSession& x) {
    ReportSession r;
    r.id = std::to_string(x.session_id);
    r.started_utc = x.started_utc;
    r.tail_number = x.tail_number;
    r.position = x.position.value_or("");
    r.serial = x.actuator_serial;
    r.phase = x.phase;
    r.kind = x.source;
    r.operator_id = x.operator_id;
    if (x.cycles) r.cycles = static_cast<double>(*x.cycles);
    r.hours = x.hours_h;
    r.verdict = x.verdict;
    r.tool_version = x.tool_version;
    std::string who = x.technician_name;
    if (!x.technician_certificate.empty()) who += (who.empty() ? "" : " ") + ("(" + x.technician_certificate + ")");
    r.note = who;
    if (!x.verdict_note.empty()) r.note += (r.note.empty() ? "" : "; ") + x.verdict_note;
    if (x.amends_session_id) r.note += (r.note.empty() ? "" : "; ") + ("amends session " + std::to_string(*x.amends_session_id));
    return r;
}

/// The installations of a view, each with the time it ended: the next installation at the same
/// tail and position (for a serial: the one that removed it).
std::vector<ReportInstallation> installations_of(const pg::HistoryView& v, const std::vector<db::StoredInstallation>& all) {
    std::vector<ReportInstallation> out;
    for (const auto& i : v.installations) {
        if (v.kind == "serial" && i.to_serial != v.key) continue;  // its removal: closes the row below
        ReportInstallation r;
        r.serial = i.to_serial;
        r.tail_number = i.tail_number;
        r.position = i.position;
        r.from_utc = i.detected_utc;
        for (const auto* list : {&v.installations, &all})
            for (const auto& later : *list)
                if (r.to_utc.empty() && later.installation_id > i.installation_id && later.tail_number == i.tail_number &&
                    later.position == i.position)
                    r.to_utc = later.detected_utc;
        r.note = (i.from_serial.empty() ? std::string("first serial recorded at the position") : "replaced " + i.from_serial) +
                 (i.cycles ? " at " + std::to_string(*i.cycles) + " cycles" : "") + ", session " + std::to_string(i.session_id);
        out.push_back(std::move(r));
    }
    return out;
}

/// The section of `v`; `same`, when given, is the section of a view holding the same list of sessions
/// and the same trends (a serial that never left its position): its sessions, parameters and health
/// are copied instead of made again from the same data.
ReportSection section_of(const pg::HistoryView& v, const pg::FleetRecord& r, TimeAxis axis, const ReportSection* same = nullptr) {
    ReportSection s;
    s.name = v.key;
    s.kind = v.kind;
    if (!v.ata_reference.empty()) s.ata_reference = "ATA " + v.ata_reference + (v.description.empty() ? "" : " " + v.description);
    s.current = v.kind == "position" ? v.current_serial : v.current_place;
    s.installations = installations_of(v, r.installations);
    if (same != nullptr) {
        s.sessions = same->sessions;
        s.parameters = same->parameters;
        s.health = same->health;
    } else {
        for (const auto& x : v.sessions) s.sessions.push_back(session_of(x));
        std::vector<ParameterHealthInput> inputs;
        for (const auto& h : v.parameters) {
            ParameterHealthInput in;
            s.parameters.push_back(parameter_of(h, axis, in));
            inputs.push_back(in);
        }
        s.health = assess_position(inputs);
    }
    for (const auto& f : r.open_findings) {
        const bool here = v.kind == "position" ? f.position.value_or("(none)") == v.key : f.actuator_serial == v.key;
        if (!here) continue;
        s.findings.push_back({std::to_string(f.finding_id), "", f.found_utc, "effect the model lacks", f.summary, f.status});
    }
    s.notes = v.notes;
    return s;
}

}  // namespace

ReportDocument from_fleet_record(const pg::FleetRecord& r, const TrendAdapterOptions& options) {
    ReportDocument d;
    d.tail_number = r.tail_number;
    d.generated_utc = options.generated_utc;
    d.tool_version = options.tool_version;
    d.data_source = options.data_source;
    d.time_axis = all_prefer_cycles(r) ? TimeAxis::Cycles : TimeAxis::Date;
    {
        std::ostringstream os;
        os << "Phase " << r.options.phase << ", " << r.sessions_total << " sessions of the tail. A position's trends are those of the "
           << "serial installed now, since its installation; a serial's trends follow it across tails. Each session's measurement is the "
              "inverse-variance mean of its physics findings; each parameter is fitted by weighted least squares against flight cycles "
              "and against days, linear or log-linear chosen by AICc; the RUL is the time until the fitted mean reaches the limit, its "
              "90 % interval from "
           << r.options.rul.draws << " Monte Carlo draws of the fit (seed " << r.options.rul.seed << "), horizons "
           << whole(r.options.horizon_cycles) << " cycles and " << whole(r.options.rul.horizon_days)
           << " days (docs/fleet-record.md). The band drawn around the fit is its 90 % band. Plots are against "
           << (d.time_axis == TimeAxis::Cycles ? "flight cycles since the series' first session" : "the date") << ".";
        d.method_note = os.str();
    }
    if (!r.chain_head_sha256.empty()) d.notes.push_back("Hash chain head of the tail's record: " + r.chain_head_sha256 + ".");
    if (!r.amended_session_ids.empty()) {
        std::string ids;
        for (auto id : r.amended_session_ids) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
        d.notes.push_back("Sessions amended by a correction, left out: " + ids + ".");
    }
    for (const auto& v : r.positions) d.positions.push_back(section_of(v, r, d.time_axis));
    for (const auto& v : r.serials) {
        const ReportSection* same = nullptr;
        for (std::size_t k = 0; k < r.positions.size() && same == nullptr; ++k)
            if (v.sessions.shares_with(r.positions[k].sessions) && v.parameters.shares_with(r.positions[k].parameters)) same = &d.positions[k];
        d.serials.push_back(section_of(v, r, d.time_axis, same));
    }
    return d;
}

}  // namespace emadiag::report
