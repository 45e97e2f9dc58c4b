// emadiag sync, the reader's side: a batch of whole sessions read from the station file, with the
// summary terms the server's transaction adds (the sender's side is pg_sync_push.cpp).
#include "pg_sync_detail.hpp"

#include "emadiag/db/record_store.hpp"

#include <algorithm>
#include <deque>
#include <map>
#include <mutex>
#include <tuple>

namespace emadiag::db::sync_detail {
namespace {

/// The part of a local session the sync needs beyond the rows it copies: for the summary terms.
struct LightSession {
    std::int64_t id = 0;
    std::string tail, serial, started_utc, verdict;
    std::optional<std::string> position;
    std::string position_ata, position_description;
    std::optional<std::int64_t> cycles;
    std::optional<std::int64_t> amends;
    std::vector<StoredFinding> findings;
};

constexpr const char* kLocalSessionColumns =
    "s.session_id, s.tail_number, s.actuator_serial, s.phase, s.started_utc, s.tool_version, s.verdict, s.verdict_note, s.limits_json, "
    "s.position, coalesce(p.ata_reference, ''), coalesce(p.description, ''), s.cycles, s.hours_h, s.operator_id, s.technician_name, "
    "s.technician_certificate, s.work_performed, s.source, s.limits_sha256, s.amends_session_id, s.correction_reason, s.prev_sha256, "
    "s.content_sha256 FROM test_sessions s LEFT JOIN positions p ON p.position = s.position";

void load_findings(Database& db, const std::set<std::string>& tails, std::int64_t lo, std::int64_t hi,
                   std::map<std::int64_t, LightSession>& into) {
    // Findings are keyed by tail first (station schema 6): one range of the key per tail of the batch.
    // (A join through the sessions' rows let SQLite carry the session-id range over to the findings and
    // search, for every session, all its tail's findings in the range: quadratic in the sessions a tail
    // has in one batch; 1,218 us a session for a station of 10 tails, against 45 us for 1,000 tails.)
    Statement st(db, "SELECT f.session_id, f.parameter, f.estimator, f.value, f.std_error, f.limit_value, f.limit_kind, f.status, f.note "
                     "FROM findings f WHERE f.tail_number = ? AND f.session_id BETWEEN ? AND ? ORDER BY f.session_id, f.parameter, f.estimator");
    for (const auto& tail : tails) {
        st.reset();
        st.bind(1, tail).bind(2, lo).bind(3, hi);
        while (st.step()) {
            auto it = into.find(st.column_int(0));
            if (it == into.end()) continue;
            StoredFinding x;
            x.parameter = st.column_text(1);
            x.estimator = st.column_text(2);
            x.value = col_opt_d(st, 3);
            x.std_error = col_opt_d(st, 4);
            x.limit_value = col_opt_d(st, 5);
            x.limit_kind = st.column_text(6);
            x.status = st.column_text(7);
            x.note = st.column_text(8);
            it->second.findings.push_back(std::move(x));
        }
    }
}

LightSession load_light(Database& db, std::int64_t id) {
    Statement st(db, "SELECT s.session_id, s.tail_number, s.actuator_serial, s.started_utc, s.verdict, s.position, s.cycles, s.amends_session_id "
                     "FROM test_sessions s WHERE s.session_id = ?");
    st.bind(1, id);
    if (!st.step()) throw DbError("station session " + std::to_string(id) + " is missing", DbErrorKind::Invalid);
    std::map<std::int64_t, LightSession> m;
    LightSession& l = m[id];
    l.id = id;
    l.tail = st.column_text(1);
    l.serial = st.column_text(2);
    l.started_utc = st.column_text(3);
    l.verdict = st.column_text(4);
    l.position = col_opt_text(st, 5);
    l.cycles = col_opt_i(st, 6);
    l.amends = col_opt_i(st, 7);
    load_findings(db, {m.begin()->second.tail}, id, id, m);
    return m[id];
}

}  // namespace

/// Reads the batch of sessions after `after` from the station (at most batch_sessions of them;
/// no sessions when none is left) with everything the server's transaction needs but the fleet's
/// ids. Runs on the reader thread with its own connection, while the sender pushes the batch
/// before it; it holds station_gate_, so the sender's record of a batch waits for it.
PreparedBatch Syncer::read_batch(Database& db, std::int64_t after) {
    const std::lock_guard<std::mutex> gate(station_gate_);
    PreparedBatch b;
    {
        Statement st(db, "SELECT session_id FROM test_sessions WHERE session_id > ? ORDER BY session_id LIMIT ?");
        st.bind(1, after).bind(2, static_cast<std::int64_t>(o_.batch_sessions));
        while (st.step()) b.ids.push_back(st.column_int(0));
    }
    if (b.ids.empty()) return b;
    b.lo = b.ids.front();
    b.hi = b.ids.back();
    const std::int64_t lo = b.lo, hi = b.hi;
    std::map<std::int64_t, LightSession> light;
    std::vector<std::string> session_lines;
    {
        Statement st(db, std::string("SELECT ") + kLocalSessionColumns + " WHERE s.session_id BETWEEN ? AND ? ORDER BY s.session_id");
        st.bind(1, lo).bind(2, hi);
        while (st.step()) {
            LightSession& l = light[st.column_int(0)];
            l.id = st.column_int(0);
            l.tail = st.column_text(1);
            l.serial = st.column_text(2);
            l.started_utc = st.column_text(4);
            l.verdict = st.column_text(6);
            l.position = col_opt_text(st, 9);
            l.cycles = col_opt_i(st, 12);
            l.amends = col_opt_i(st, 20);
            b.tails.insert(l.tail);
            if (l.position) b.positions[*l.position] = {st.column_text(10), st.column_text(11)};
            // The columns after the fleet's own session_id (which the sender puts first), up to the
            // amended session's fleet id (which the sender appends).
            session_lines.push_back('\t' + session_uuid(res_.station_uuid, l.id) + '\t' + res_.station_uuid + '\t' + std::to_string(l.id) +
                                    '\t' + f(l.tail) + '\t' + f(col_opt_text(st, 9)) + '\t' + f(l.serial) + '\t' + f(st.column_text(3)) +
                                    '\t' + f(l.started_utc) + '\t' + opt_i(l.cycles) + '\t' + opt_d(col_opt_d(st, 13)) + '\t' +
                                    f(st.column_text(14)) + '\t' + f(st.column_text(15)) + '\t' + f(st.column_text(16)) + '\t' +
                                    f(st.column_text(17)) + '\t' + f(st.column_text(18)) + '\t' + f(st.column_text(5)) + '\t' +
                                    f(l.verdict) + '\t' + f(st.column_text(7)) + '\t' + f(st.column_text(8)) + '\t' +
                                    f(st.column_text(19)) + '\t' + f(st.column_text(21)) + '\t' + f(col_opt_text(st, 22)) + '\t' +
                                    f(col_opt_text(st, 23)) + '\t');
        }
    }
    if (light.size() != b.ids.size())
        throw DbError("station " + db.path() + ": sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " changed while read",
                      DbErrorKind::Invalid);
    load_findings(db, b.tails, lo, hi, light);
    {
        Statement st(db, "SELECT r.run_id, r.session_id, r.tail_number, r.actuator_serial, r.started_utc, r.source, r.load_case, r.sequence, "
                         "r.k_t_nm_per_a, r.j_kgm2, r.tau, r.sample_period_s, r.valid, r.status_note, r.meta_json, "
                         "coalesce(g.format, ''), coalesce(length(g.content), 0) FROM runs r LEFT JOIN raw_logs g ON g.run_id = r.run_id "
                         "WHERE r.session_id BETWEEN ? AND ? ORDER BY r.run_id");
        st.bind(1, lo).bind(2, hi);
        while (st.step()) {
            b.runs.push_back({st.column_int(0), st.column_int(1),
                              f(st.column_text(2)) + '\t' + f(st.column_text(3)) + '\t' + f(st.column_text(4)) + '\t' + f(st.column_text(5)) +
                                  '\t' + f(st.column_text(6)) + '\t' + f(st.column_text(7)) + '\t' + d2s(st.column_double(8)) + '\t' +
                                  d2s(st.column_double(9)) + '\t' + d2s(st.column_double(10)) + '\t' + d2s(st.column_double(11)) + '\t' +
                                  (st.column_int(12) != 0 ? "t" : "f") + '\t' + f(st.column_text(13)) + '\t' + f(st.column_text(14)) +
                                  '\t' + f(st.column_text(15)) + '\t' + std::to_string(st.column_int(16)),
                              st.column_int(16)});
        }
    }
    // Sessions and findings go in grouped by tail (in the batch's order within a tail): a tail's rows then
    // share heap pages, which is what a report for one tail reads.
    std::vector<std::size_t> by_tail(b.ids.size());
    for (std::size_t i = 0; i < b.ids.size(); ++i) by_tail[i] = i;
    std::stable_sort(by_tail.begin(), by_tail.end(), [&](std::size_t x, std::size_t y) { return light.at(b.ids[x]).tail < light.at(b.ids[y]).tail; });
    // Schema 3 keeps each finding's tail beside it (the report reads a tail's findings as one index range).
    const bool finding_tails = server_version_ >= 3;
    for (const std::size_t i : by_tail) {
        const LightSession& l = light.at(b.ids[i]);
        b.sessions.push_back({i, std::move(session_lines[i]), l.amends});
        for (const auto& x : l.findings)
            b.findings.push_back({i, '\t' + f(x.parameter) + '\t' + f(x.estimator) + '\t' + opt_d(x.value) + '\t' + opt_d(x.std_error) + '\t' +
                                         opt_d(x.limit_value) + '\t' + f(x.limit_kind) + '\t' + f(x.status) + '\t' + f(x.note) +
                                         (finding_tails ? '\t' + f(l.tail) : std::string()) + '\n'});
    }
    session_lines = {};
    {
        Statement st(db, "SELECT session_id, role, name, sha256 FROM session_artifacts WHERE session_id BETWEEN ? AND ?");
        st.bind(1, lo).bind(2, hi);
        while (st.step())
            b.artifacts.push_back({st.column_int(0), '\t' + f(st.column_text(1)) + '\t' + f(st.column_text(2)) + '\t' + f(st.column_text(3)) + '\n'});
    }
    {
        Statement st(db, "SELECT tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id FROM installations "
                         "WHERE session_id BETWEEN ? AND ? ORDER BY installation_id");
        st.bind(1, lo).bind(2, hi);
        while (st.step())
            b.installations.push_back({st.column_int(7), f(st.column_text(0)) + '\t' + f(st.column_text(1)) + '\t' + f(st.column_text(2)) + '\t' +
                                                             f(st.column_text(3)) + '\t' + f(st.column_text(4)) + '\t' + opt_i(col_opt_i(st, 5)) +
                                                             '\t' + opt_d(col_opt_d(st, 6)) + '\t'});
    }
    // The summary terms, in the order the station applied them (add_to_summaries): per session, the
    // amended session's measurements out (-1), then the session's own in (+1). Sent sorted by series
    // (byte order, as COLLATE "C"), then by that order: the server's summary statement sorts them so,
    // and finds them already sorted (pg_schema/003). The fleet's session ids are assigned in the
    // order of the local ones, so the local ids sort the terms as the fleet's will.
    struct Term {
        const std::string *tail, *position, *serial;
        std::string parameter;  // session_measurements' values do not outlive emit
        PreparedBatch::TermLine line;
    };
    std::vector<Term> terms;
    std::deque<LightSession> amended;  // sessions of earlier batches that this one amends (a deque: stable addresses)
    static const std::string kNoPosition;
    for (const auto id : b.ids) {
        const LightSession& l = light.at(id);
        int ordinal = 0;
        const auto emit = [&](const LightSession& s, int sign) {
            const double days = utc_days(s.started_utc);
            for (const auto& m : session_measurements(s.findings)) {
                const double w = sign / (m.std_error * m.std_error);
                std::string rest = '\t' + f(s.tail) + '\t' + f(s.position.value_or("")) + '\t' + f(s.serial) + '\t' + f(m.parameter) + '\t' +
                                   d2s(days) + '\t' + d2s(w) + '\t' + d2s(w * m.value) + '\t' + d2s(w * m.value * m.value) + '\t' +
                                   (s.cycles ? d2s(static_cast<double>(*s.cycles)) : std::string("\\N")) + '\t' + d2s(m.value) + '\t' +
                                   d2s(m.std_error) + '\t' + f(m.limit_kind) + '\t' + opt_d(m.limit_value) + '\n';
                terms.push_back({&s.tail, s.position ? &*s.position : &kNoPosition, &s.serial, m.parameter,
                                 {id, ordinal++, sign, s.id, std::move(rest)}});
            }
        };
        if (l.amends) {
            const auto it = light.find(*l.amends);
            if (it != light.end()) {
                emit(it->second, -1);
            } else {
                amended.push_back(load_light(db, *l.amends));
                emit(amended.back(), -1);
            }
        }
        emit(l, +1);
    }
    std::sort(terms.begin(), terms.end(), [](const Term& x, const Term& y) {
        return std::tie(*x.tail, *x.position, *x.serial, x.parameter, x.line.session_id, x.line.ordinal) <
               std::tie(*y.tail, *y.position, *y.serial, y.parameter, y.line.session_id, y.line.ordinal);
    });
    b.terms.reserve(terms.size());
    for (auto& t : terms) b.terms.push_back(std::move(t.line));
    progress("sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " read ahead from the station");
    return b;
}

}  // namespace emadiag::db::sync_detail
