// Reading test sessions back: one session whole, or the sessions of a tail or of an actuator serial.
#include "session_store_detail.hpp"

#include "emadiag/db/db_error.hpp"

#include "run_store_detail.hpp"

#include <algorithm>
#include <unordered_map>

namespace emadiag::db {
using namespace detail;

StoredTestSession detail::read_session_row(const Statement& st) {
    StoredTestSession s;
    s.session_id = st.column_int(0);
    s.tail_number = st.column_text(1);
    s.actuator_serial = st.column_text(2);
    s.phase = st.column_text(3);
    s.started_utc = st.column_text(4);
    s.tool_version = st.column_text(5);
    s.verdict = st.column_text(6);
    s.verdict_note = st.column_text(7);
    s.limits_json = st.column_text(8);
    if (!st.column_is_null(9)) s.position = st.column_text(9);
    s.position_ata = st.column_text(10);
    s.position_description = st.column_text(11);
    if (!st.column_is_null(12)) s.cycles = st.column_int(12);
    if (!st.column_is_null(13)) s.hours_h = st.column_double(13);
    s.operator_id = st.column_text(14);
    s.technician_name = st.column_text(15);
    s.technician_certificate = st.column_text(16);
    s.work_performed = st.column_text(17);
    s.source = st.column_text(18);
    s.limits_sha256 = st.column_text(19);
    if (!st.column_is_null(20)) s.amends_session_id = st.column_int(20);
    s.correction_reason = st.column_text(21);
    s.prev_sha256 = st.column_text(22);
    s.content_sha256 = st.column_text(23);
    return s;
}

namespace {
StoredFinding read_finding(const Statement& st, int c) {
    const auto optional_column = [&st](int col) {
        return st.column_is_null(col) ? std::nullopt : std::optional<double>(st.column_double(col));
    };
    StoredFinding f;
    f.parameter = st.column_text(c);
    f.estimator = st.column_text(c + 1);
    f.value = optional_column(c + 2);
    f.std_error = optional_column(c + 3);
    f.limit_value = optional_column(c + 4);
    f.limit_kind = st.column_text(c + 5);
    f.status = st.column_text(c + 6);
    f.note = st.column_text(c + 7);
    return f;
}

constexpr const char* kFindingColumns = "f.parameter, f.estimator, f.value, f.std_error, f.limit_value, f.limit_kind, f.status, f.note";
}  // namespace

std::vector<StoredFinding> detail::load_findings(Database& db, std::int64_t session_id, FindingsLayout layout) {
    // Version 6 keys a finding by its session's tail first: found through the session's row.
    Statement st(db, std::string("SELECT ") + kFindingColumns +
                         (layout == FindingsLayout::ByTail
                              ? " FROM test_sessions s JOIN findings f ON f.tail_number = s.tail_number AND f.session_id = s.session_id "
                                "WHERE s.session_id = ? ORDER BY f.parameter, f.estimator"
                              : " FROM findings f WHERE f.session_id = ? ORDER BY f.parameter, f.estimator"));
    st.bind(1, session_id);
    std::vector<StoredFinding> out;
    while (st.step()) out.push_back(read_finding(st, 0));
    return out;
}

namespace {
std::vector<StoredArtifact> load_artifacts(Database& db, std::int64_t session_id) {
    Statement st(db, "SELECT role, name, sha256 FROM session_artifacts WHERE session_id = ? ORDER BY role, name");
    st.bind(1, session_id);
    std::vector<StoredArtifact> out;
    while (st.step()) out.push_back({st.column_text(0), st.column_text(1), st.column_text(2)});
    return out;
}

/// A tail's sessions, oldest first, with their findings: two key ranges of the tables clustered by
/// tail (schema/006), read in their stored order. The positions (a small table) are read once, not
/// joined per session; limits_json and the two hashes of the chain are read only when asked for.
std::vector<StoredTestSession> list_of_tail(Database& db, const std::string& tail_number, const SessionListParts& parts) {
    std::vector<StoredTestSession> out;
    std::unordered_map<std::string, std::pair<std::string, std::string>> positions;
    {
        Statement st(db, "SELECT position, ata_reference, description FROM positions");
        while (st.step()) positions.emplace(st.column_text(0), std::make_pair(st.column_text(1), st.column_text(2)));
    }
    {
        // Room for every session at once: the tail's count from its chain head (a hint only, bounded).
        constexpr std::int64_t kMaxReserved = std::int64_t{1} << 20;
        Statement count(db, "SELECT sessions FROM chain_heads WHERE tail_number = ?");
        count.bind(1, tail_number);
        if (count.step() && count.column_int(0) > 0) out.reserve(static_cast<std::size_t>(std::min(count.column_int(0), kMaxReserved)));
    }
    {
        Statement st(db, std::string("SELECT session_id, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, position, "
                                     "cycles, hours_h, operator_id, technician_name, technician_certificate, work_performed, source, "
                                     "amends_session_id, correction_reason, content_sha256") +
                             (parts.limits_and_links ? ", limits_json, limits_sha256, prev_sha256" : "") +
                             " FROM test_sessions WHERE tail_number = ? ORDER BY tail_number, started_utc, session_id");
        st.bind(1, tail_number);
        while (st.step()) {
            StoredTestSession& s = out.emplace_back();
            s.session_id = st.column_int(0);
            s.tail_number = tail_number;
            s.actuator_serial = st.column_view(1);
            s.phase = st.column_view(2);
            s.started_utc = st.column_view(3);
            s.tool_version = st.column_view(4);
            s.verdict = st.column_view(5);
            s.verdict_note = st.column_view(6);
            if (!st.column_is_null(7)) {
                s.position = st.column_view(7);
                // As the LEFT JOIN of list_where: a position missing from the table gives ''.
                if (const auto it = positions.find(*s.position); it != positions.end()) {
                    s.position_ata = it->second.first;
                    s.position_description = it->second.second;
                }
            }
            if (!st.column_is_null(8)) s.cycles = st.column_int(8);
            if (!st.column_is_null(9)) s.hours_h = st.column_double(9);
            s.operator_id = st.column_view(10);
            s.technician_name = st.column_view(11);
            s.technician_certificate = st.column_view(12);
            s.work_performed = st.column_view(13);
            s.source = st.column_view(14);
            if (!st.column_is_null(15)) s.amends_session_id = st.column_int(15);
            s.correction_reason = st.column_view(16);
            s.content_sha256 = st.column_view(17);
            if (parts.limits_and_links) {
                s.limits_json = st.column_view(18);
                s.limits_sha256 = st.column_view(19);
                s.prev_sha256 = st.column_view(20);
            } else {
                s.limits_json.clear();
            }
        }
    }
    if (out.empty()) return out;
    {
        // The tail's findings in key order (session_id, parameter, estimator): each session's in the
        // order load_test_session gives them. Sessions are in time order, which is session_id
        // order unless one was stored with an earlier time than an earlier-stored one: matched by id.
        std::vector<std::pair<std::int64_t, std::size_t>> by_id;
        by_id.reserve(out.size());
        for (std::size_t i = 0; i < out.size(); ++i) by_id.emplace_back(out[i].session_id, i);
        std::sort(by_id.begin(), by_id.end());
        Statement st(db, std::string("SELECT f.session_id, ") + kFindingColumns +
                             " FROM findings f WHERE f.tail_number = ? ORDER BY f.tail_number, f.session_id, f.parameter, f.estimator");
        st.bind(1, tail_number);
        std::size_t at = 0;
        StoredTestSession* session = nullptr;
        std::int64_t session_id = -1;
        std::size_t last_count = 0;  // sessions of a tail mostly have as many findings as the one before
        while (st.step()) {
            const std::int64_t id = st.column_int(0);
            if (id != session_id) {
                if (session != nullptr) last_count = session->findings.size();
                while (at < by_id.size() && by_id[at].first < id) ++at;
                // A finding whose session is not this tail's: its session lies elsewhere (changed
                // outside the tool); list_where's join would not show it either.
                session = at < by_id.size() && by_id[at].first == id ? &out[by_id[at].second] : nullptr;
                if (session != nullptr) session->findings.reserve(last_count);
                session_id = id;
            }
            if (session != nullptr) session->findings.push_back(read_finding(st, 1));
        }
    }
    if (!parts.artifacts && !parts.runs) return out;
    std::unordered_map<std::int64_t, std::size_t> index;
    for (std::size_t i = 0; i < out.size(); ++i) index[out[i].session_id] = i;
    if (parts.artifacts) {
        Statement st(db, "SELECT a.session_id, a.role, a.name, a.sha256 FROM test_sessions s JOIN session_artifacts a ON a.session_id = "
                         "s.session_id WHERE s.tail_number = ? ORDER BY a.session_id, a.role, a.name");
        st.bind(1, tail_number);
        while (st.step()) out[index.at(st.column_int(0))].artifacts.push_back({st.column_text(1), st.column_text(2), st.column_text(3)});
    }
    if (parts.runs) {
        for (auto& r : detail::runs_where(db, "s.tail_number = ?", tail_number)) {
            const auto it = index.find(r.session_id.value_or(-1));
            if (it != index.end()) out[it->second].runs.push_back(std::move(r));
        }
    }
    return out;
}

/// The sessions matching `where` (on alias s, one bound text), oldest first, with findings,
/// artifacts and runs without samples: one query per table, not per session.
std::vector<StoredTestSession> list_where(Database& db, const std::string& where, const std::string& value,
                                          const SessionListParts& parts = {}) {
    std::vector<StoredTestSession> out;
    std::unordered_map<std::int64_t, std::size_t> index;
    {
        Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE " + where + " ORDER BY s.started_utc, s.session_id");
        st.bind(1, value);
        while (st.step()) {
            out.push_back(read_session_row(st));
            index[out.back().session_id] = out.size() - 1;
        }
    }
    if (out.empty()) return out;
    {
        // The findings in the sessions' order, each session's by (parameter, estimator) as
        // load_test_session gives them: the session index (tail or serial, then time) and the
        // findings' primary key deliver that order, so SQLite sorts nothing, and the rows arrive
        // session by session (the map is a fallback for a session met out of turn).
        Statement st(db, std::string("SELECT f.session_id, ") + kFindingColumns +
                             " FROM test_sessions s JOIN findings f ON f.tail_number = s.tail_number AND f.session_id = s.session_id WHERE " +
                             where +
                             " ORDER BY s.started_utc, s.session_id, f.parameter, f.estimator");
        st.bind(1, value);
        std::size_t at = 0;
        while (st.step()) {
            const std::int64_t id = st.column_int(0);
            while (at < out.size() && out[at].session_id != id) ++at;
            if (at == out.size()) at = index.at(id);
            out[at].findings.push_back(read_finding(st, 1));
        }
    }
    if (parts.artifacts) {
        Statement st(db, "SELECT a.session_id, a.role, a.name, a.sha256 FROM test_sessions s JOIN session_artifacts a ON a.session_id = "
                         "s.session_id WHERE " + where + " ORDER BY a.session_id, a.role, a.name");
        st.bind(1, value);
        while (st.step()) out[index.at(st.column_int(0))].artifacts.push_back({st.column_text(1), st.column_text(2), st.column_text(3)});
    }
    if (!parts.runs) return out;
    for (auto& r : detail::runs_where(db, where, value)) {
        const auto it = index.find(r.session_id.value_or(-1));
        if (it != index.end()) out[it->second].runs.push_back(std::move(r));
    }
    return out;
}
}  // namespace

StoredTestSession detail::load_session(Database& db, std::int64_t session_id, FindingsLayout layout) {
    Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE s.session_id = ?");
    st.bind(1, session_id);
    if (!st.step()) throw DbError("no test session with id " + std::to_string(session_id) + " in " + db.path(), DbErrorKind::Invalid);
    StoredTestSession s = read_session_row(st);
    for (const auto& listed : detail::session_runs(db, session_id)) s.runs.push_back(load_run(db, listed.run_id));
    s.findings = load_findings(db, session_id, layout);
    s.artifacts = load_artifacts(db, session_id);
    return s;
}

StoredTestSession load_test_session(Database& db, std::int64_t session_id) { return load_session(db, session_id, FindingsLayout::ByTail); }

std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    return list_of_tail(db, tail_number, SessionListParts{});
}

std::vector<StoredTestSession> list_sessions_of_serial(Database& db, const std::string& actuator_serial) {
    return list_sessions_of_serial(db, actuator_serial, SessionListParts{});
}

std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number, const SessionListParts& parts) {
    check_tail_number(tail_number);
    return list_of_tail(db, tail_number, parts);
}

std::vector<StoredTestSession> list_sessions_of_serial(Database& db, const std::string& actuator_serial, const SessionListParts& parts) {
    if (actuator_serial.empty()) invalid("an empty actuator serial names no actuator");
    return list_where(db, "s.actuator_serial = ?", actuator_serial, parts);
}

}  // namespace emadiag::db
