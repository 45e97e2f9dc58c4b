// The summary tables (series_stats, position_status, docs/record-format.md "Summary tables"):
// each stored session's measurements added to its series, kept in the batch and written once.
#include "session_store_detail.hpp"

#include "record_detail.hpp"

#include "emadiag/calc/civil_days.hpp"
#include "emadiag/calc/inverse_variance.hpp"
#include "emadiag/record/estimator_method.hpp"

#include <algorithm>
#include <string_view>

namespace emadiag::db {
using namespace detail;

namespace {

/// Days since 1970 of "YYYY-MM-DDThh:mm:ss..." (checked by check_session; fractions of a second ignored).
double utc_days(const std::string& iso) {
    // Read in place, no substrings (a session checked by check_session passes at once; one sealed
    // by the migration to version 3 was stored before these checks).
    const bool checked = is_iso_date_time(iso);
    const auto n = [&](std::size_t at, std::size_t len) {
        if (!checked) return std::stoi(iso.substr(at, len));
        int v = 0;
        for (std::size_t i = at; i < at + len; ++i) v = v * 10 + (iso[i] - '0');
        return v;
    };
    return calc::days_since_epoch(n(0, 4), n(5, 2), n(8, 2), n(11, 2) * 3600.0 + n(14, 2) * 60.0 + n(17, 2));
}

std::optional<SeriesStats>& series_row(Database& db, std::map<std::string, std::optional<SeriesStats>>& group, const std::string& tail,
                                       const std::string& position, const std::string& serial, const std::string& parameter) {
    auto [it, fresh] = group.try_emplace(parameter);
    if (fresh) {
        it->second = detail::find_series_stats(db, tail, position, serial, parameter);
    }
    return it->second;
}
}  // namespace

std::optional<PositionStatus>& detail::position_row(Database& db, Batch& b, const std::string& tail, const std::string& position) {
    auto [it, fresh] = b.positions.try_emplace({tail, position});
    if (fresh) it->second = detail::find_position_status(db, tail, position);
    return it->second;
}

/// Adds (sign +1) or removes (sign -1, for a session a correction amends) a session's measurements
/// in series_stats, and its place in position_status (docs/record-format.md, "Summary tables").
void detail::add_to_summaries(Database& db, Batch& b, const StoredTestSession& s, std::int64_t session_id, int sign) {
    const double days = utc_days(s.started_utc);
    const std::string position = s.position.value_or("");
    const auto measurements = session_measurements(s.findings);
    auto& group = measurements.empty() ? b.series[{}] : b.series[{s.tail_number, position, s.actuator_serial}];
    for (const auto& m : measurements) {
        const double w = sign / (m.std_error * m.std_error);
        // The session's own sums, t = 0 at its own time (days and cycles).
        const bool has_cycles = s.cycles.has_value();
        const double e_cycles = has_cycles ? static_cast<double>(*s.cycles) : 0.0;
        const double e_cw = has_cycles ? w : 0.0, e_cwy = has_cycles ? w * m.value : 0.0, e_cwyy = has_cycles ? w * m.value * m.value : 0.0;
        std::optional<SeriesStats>& row = series_row(db, group, s.tail_number, position, s.actuator_serial, m.parameter);
        if (!row) {
            SeriesStats r;
            r.tail_number = s.tail_number;
            r.position = position;
            r.actuator_serial = s.actuator_serial;
            r.parameter = m.parameter;
            r.n = sign;
            r.first_days = r.last_days = days;
            r.s_w = w;
            r.s_wy = w * m.value;
            r.s_wyy = w * m.value * m.value;
            r.n_cycles = has_cycles ? sign : 0;
            if (has_cycles) r.first_cycles = r.last_cycles = e_cycles;
            r.c_w = e_cw;
            r.c_wy = e_cwy;
            r.c_wyy = e_cwyy;
            r.last_session_id = session_id;
            r.last_value = m.value;
            r.last_std_error = m.std_error;
            r.limit_kind = m.limit_kind;
            r.limit_value = m.limit_value;
            row = std::move(r);
            continue;
        }
        SeriesStats& r = *row;
        r.n += sign;
        const double d = days - r.first_days;
        r.s_w += w;
        r.s_wt += w * d;
        r.s_wtt += w * d * d;
        r.s_wy += w * m.value;
        r.s_wty += w * m.value * d;
        r.s_wyy += w * m.value * m.value;
        if (has_cycles) {
            r.n_cycles += sign;
            const double dc = e_cycles - r.first_cycles.value_or(e_cycles);
            r.c_w += e_cw;
            r.c_wt += e_cw * dc;
            r.c_wtt += e_cw * dc * dc;
            r.c_wy += e_cwy;
            r.c_wty += e_cwy * dc;
            r.c_wyy += e_cwyy;
            if (!r.first_cycles) r.first_cycles = e_cycles;
        }
        if (sign > 0 && days >= r.last_days) {
            if (has_cycles) r.last_cycles = e_cycles;
            r.last_session_id = session_id;
            r.last_value = m.value;
            r.last_std_error = m.std_error;
            r.limit_kind = m.limit_kind;
            r.limit_value = m.limit_value;
            r.last_days = days;
        }
    }
    if (sign < 0) return;
    std::optional<PositionStatus>& ps = position_row(db, b, s.tail_number, position);
    if (!ps) {
        ps = PositionStatus{s.tail_number, position, s.actuator_serial, 1, session_id, s.started_utc, s.verdict, s.cycles};
        return;
    }
    ps->sessions += 1;
    if (s.started_utc >= ps->last_utc) {
        ps->actuator_serial = s.actuator_serial;
        ps->last_session_id = session_id;
        ps->last_verdict = s.verdict;
        if (s.cycles) ps->last_cycles = s.cycles;
        ps->last_utc = s.started_utc;
    }
}

void detail::flush(Database& db, Batch& b) {
    Statement& up = db.cached(std::string("INSERT OR REPLACE INTO series_stats(") + detail::kSeriesStatsColumns +
                              ") VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    for (const auto& [key, group] : b.series) {
        for (const auto& [parameter, row] : group) {
            if (!row) continue;
            const SeriesStats& r = *row;
            up.reset();
            up.bind(1, r.tail_number).bind(2, r.position).bind(3, r.actuator_serial).bind(4, r.parameter).bind(5, r.n);
            up.bind(6, r.first_days).bind(7, r.last_days);
            int c = 8;
            for (double v : {r.s_w, r.s_wt, r.s_wtt, r.s_wy, r.s_wty, r.s_wyy}) up.bind(c++, v);
            up.bind(14, r.n_cycles);
            bind_optional(up, 15, r.first_cycles);
            bind_optional(up, 16, r.last_cycles);
            c = 17;
            for (double v : {r.c_w, r.c_wt, r.c_wtt, r.c_wy, r.c_wty, r.c_wyy}) up.bind(c++, v);
            up.bind(23, r.last_session_id).bind(24, r.last_value).bind(25, r.last_std_error).bind(26, r.limit_kind);
            bind_optional(up, 27, r.limit_value);
            up.run();
        }
    }
    Statement& ps = db.cached(
        "INSERT OR REPLACE INTO position_status(tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, "
        "last_cycles) VALUES (?,?,?,?,?,?,?,?)");
    for (const auto& [key, row] : b.positions) {
        if (!row) continue;
        ps.reset();
        ps.bind(1, row->tail_number).bind(2, row->position).bind(3, row->actuator_serial).bind(4, row->sessions);
        ps.bind(5, row->last_session_id).bind(6, row->last_utc).bind(7, row->last_verdict);
        bind_optional(ps, 8, row->last_cycles);
        ps.run();
    }
    Statement& head = db.cached(
        "INSERT INTO chain_heads(tail_number, session_id, sessions, content_sha256) VALUES (?,?,?,?) "
        "ON CONFLICT DO UPDATE SET session_id = excluded.session_id, sessions = sessions + excluded.sessions, "
        "content_sha256 = excluded.content_sha256");
    for (const auto& [tail, h] : b.heads) {
        head.reset();
        head.bind(1, tail).bind(2, h.session_id).bind(3, h.added).bind(4, h.sha).run();
    }
    b = Batch{};
}

std::vector<SessionMeasurement> session_measurements(const std::vector<StoredFinding>& findings) {
    // A session has a handful of parameters: a flat list searched in place (no map nodes per call),
    // sums in the order of the findings, the result sorted by parameter.
    struct Acc {
        SessionMeasurement m;
        calc::InverseVarianceMean mean;
    };
    std::vector<Acc> acc;
    acc.reserve(findings.size());
    for (const auto& f : findings) {
        auto it = std::find_if(acc.begin(), acc.end(), [&f](const Acc& a) { return a.m.parameter == f.parameter; });
        if (it == acc.end()) {
            acc.emplace_back();
            it = acc.end() - 1;
            it->m.parameter = f.parameter;
        }
        if (f.limit_kind != kNoLimit && f.limit_value) {
            it->m.limit_kind = f.limit_kind;
            it->m.limit_value = f.limit_value;
        }
        // Physics findings are the measurements (the network findings are the verdict's cross-check).
        if (estimator_method_of(f.estimator) != EstimatorMethod::Physics || !f.value) continue;
        if (!f.std_error || !calc::is_weightable(*f.std_error)) continue;
        it->mean.add(*f.value, *f.std_error);
    }
    std::sort(acc.begin(), acc.end(), [](const Acc& x, const Acc& y) { return x.m.parameter < y.m.parameter; });
    std::vector<SessionMeasurement> out;
    out.reserve(acc.size());
    for (auto& a : acc) {
        if (!(a.mean.sum_w > 0)) continue;
        a.m.value = a.mean.mean();
        a.m.std_error = a.mean.std_error();
        out.push_back(std::move(a.m));
    }
    return out;
}

}  // namespace emadiag::db
