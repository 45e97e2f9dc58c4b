#include "emadiag/db/test_session_store.hpp"

#include "emadiag/db/db_error.hpp"

#include "run_store_detail.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <string_view>

namespace emadiag::db {

namespace {
// The values the schema's CHECK constraints accept (schema/002_test_sessions.sql); checked here
// first so that the message names the field and the value.
constexpr std::array<std::string_view, 2> kPhases{"pre-flight", "post-flight"};
constexpr std::array<std::string_view, 4> kVerdicts{"SERVICEABLE", "UNSERVICEABLE", "INCONCLUSIVE", "NO_TEST"};
constexpr std::array<std::string_view, 3> kLimitKinds{"max", "min", "none"};
constexpr std::string_view kNoLimit = "none";
/// "YYYY-MM-DDThh:mm:ss": the part of an ISO 8601 time every started_utc begins with ('9' = a digit).
constexpr std::string_view kIsoDateTimePattern = "9999-99-99T99:99:99";

constexpr const char* kSessionColumns =
    "session_id, tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, limits_json "
    "FROM test_sessions";

template <std::size_t N>
std::string one_of(const std::array<std::string_view, N>& allowed) {
    std::string out;
    for (std::size_t i = 0; i < N; ++i) {
        if (i > 0) out += i + 1 == N ? " or " : ", ";
        out += "'" + std::string(allowed[i]) + "'";
    }
    return out;
}

template <std::size_t N>
void check_one_of(const std::string& value, const std::array<std::string_view, N>& allowed, const std::string& field) {
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
        throw DbError(field + " is '" + value + "': use " + one_of(allowed));
    }
}

bool is_iso_date_time(const std::string& text) {
    if (text.size() < kIsoDateTimePattern.size()) return false;
    for (std::size_t i = 0; i < kIsoDateTimePattern.size(); ++i) {
        const bool ok = kIsoDateTimePattern[i] == '9' ? std::isdigit(static_cast<unsigned char>(text[i])) != 0
                                                      : text[i] == kIsoDateTimePattern[i];
        if (!ok) return false;
    }
    return true;
}

void check_optional_finite(const std::optional<double>& v, const std::string& field) {
    if (v && !std::isfinite(*v)) throw DbError(field + " is not a finite number (" + std::to_string(*v) + ")");
}

void check_session(const StoredTestSession& s) {
    const std::string where = "test session: ";
    if (const auto problem = detail::tail_number_problem(s.tail_number)) throw DbError(where + *problem);
    check_one_of(s.phase, kPhases, where + "phase");
    check_one_of(s.verdict, kVerdicts, where + "verdict");
    if (!is_iso_date_time(s.started_utc)) {
        throw DbError(where + "started_utc '" + s.started_utc + "' is not an ISO 8601 UTC time (" +
                      std::string(kIsoDateTimePattern) + "...)");
    }
    for (std::size_t i = 0; i < s.runs.size(); ++i) {
        const std::string context = "test session run " + std::to_string(i) + ": ";
        detail::check_run(s.runs[i], context);
        if (s.runs[i].tail_number != s.tail_number) {
            throw DbError(context + "tail_number '" + s.runs[i].tail_number + "' differs from the session's '" +
                          s.tail_number + "'");
        }
    }
    for (std::size_t i = 0; i < s.findings.size(); ++i) {
        const auto& f = s.findings[i];
        const std::string context = "test session finding " + std::to_string(i) + " (" + f.parameter + "/" + f.estimator + "): ";
        if (f.parameter.empty()) throw DbError(context + "parameter is empty");
        if (f.estimator.empty()) throw DbError(context + "estimator is empty");
        if (f.status.empty()) throw DbError(context + "status is empty");
        check_optional_finite(f.value, context + "value");
        check_optional_finite(f.std_error, context + "std_error");
        if (f.std_error && *f.std_error < 0) {
            throw DbError(context + "std_error " + std::to_string(*f.std_error) + " is negative");
        }
        check_one_of(f.limit_kind, kLimitKinds, context + "limit_kind");
        check_optional_finite(f.limit_value, context + "limit_value");
        if ((f.limit_kind == kNoLimit) == f.limit_value.has_value()) {
            throw DbError(context + "limit_kind '" + f.limit_kind + "' " +
                          (f.limit_value ? "with limit_value " + std::to_string(*f.limit_value)
                                         : std::string("without a limit_value")) +
                          ": a 'max' or 'min' limit has a value, 'none' has none");
        }
        for (std::size_t j = 0; j < i; ++j) {
            if (s.findings[j].parameter == f.parameter && s.findings[j].estimator == f.estimator) {
                throw DbError(context + "duplicate of finding " + std::to_string(j) +
                              ": each (parameter, estimator) is found once per session");
            }
        }
    }
}

void bind_optional(Statement& st, int index, const std::optional<double>& v) {
    if (v) {
        st.bind(index, *v);
    } else {
        st.bind_null(index);
    }
}

StoredTestSession read_session_row(const Statement& st) {
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
    return s;
}

std::vector<StoredFinding> load_findings(Database& db, std::int64_t session_id) {
    Statement st(db, "SELECT parameter, estimator, value, std_error, limit_value, limit_kind, status, note FROM findings "
                     "WHERE session_id = ? ORDER BY parameter, estimator");
    st.bind(1, session_id);
    std::vector<StoredFinding> out;
    const auto optional_column = [&st](int col) {
        return st.column_is_null(col) ? std::nullopt : std::optional<double>(st.column_double(col));
    };
    while (st.step()) {
        StoredFinding f;
        f.parameter = st.column_text(0);
        f.estimator = st.column_text(1);
        f.value = optional_column(2);
        f.std_error = optional_column(3);
        f.limit_value = optional_column(4);
        f.limit_kind = st.column_text(5);
        f.status = st.column_text(6);
        f.note = st.column_text(7);
        out.push_back(f);
    }
    return out;
}
}  // namespace

std::int64_t store_test_session(Database& db, const StoredTestSession& session) {
    check_session(session);

    Transaction tx(db);
    Statement(db, "INSERT OR IGNORE INTO aircraft(tail_number) VALUES (?)").bind(1, session.tail_number).run();
    Statement ins(db, "INSERT INTO test_sessions(tail_number, actuator_serial, phase, started_utc, tool_version, verdict, "
                      "verdict_note, limits_json) VALUES (?,?,?,?,?,?,?,?)");
    ins.bind(1, session.tail_number).bind(2, session.actuator_serial).bind(3, session.phase).bind(4, session.started_utc);
    ins.bind(5, session.tool_version).bind(6, session.verdict).bind(7, session.verdict_note).bind(8, session.limits_json);
    ins.run();
    const std::int64_t id = db.last_insert_id();

    for (const auto& run : session.runs) (void)detail::insert_run(db, run, id);

    Statement fnd(db, "INSERT INTO findings(session_id, parameter, estimator, value, std_error, limit_value, limit_kind, "
                      "status, note) VALUES (?,?,?,?,?,?,?,?,?)");
    for (const auto& f : session.findings) {
        fnd.bind(1, id).bind(2, f.parameter).bind(3, f.estimator);
        bind_optional(fnd, 4, f.value);
        bind_optional(fnd, 5, f.std_error);
        bind_optional(fnd, 6, f.limit_value);
        fnd.bind(7, f.limit_kind).bind(8, f.status).bind(9, f.note).run();
        fnd.reset();
    }
    tx.commit();
    return id;
}

StoredTestSession load_test_session(Database& db, std::int64_t session_id) {
    Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE session_id = ?");
    st.bind(1, session_id);
    if (!st.step()) throw DbError("no test session with id " + std::to_string(session_id) + " in " + db.path());
    StoredTestSession s = read_session_row(st);
    for (const auto& listed : detail::session_runs(db, session_id)) s.runs.push_back(load_run(db, listed.run_id));
    s.findings = load_findings(db, session_id);
    return s;
}

std::vector<StoredTestSession> list_test_sessions(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE tail_number = ? ORDER BY started_utc, session_id");
    st.bind(1, tail_number);
    std::vector<StoredTestSession> out;
    while (st.step()) out.push_back(read_session_row(st));
    for (auto& s : out) {
        s.runs = detail::session_runs(db, s.session_id);
        s.findings = load_findings(db, s.session_id);
    }
    return out;
}

}  // namespace emadiag::db
