#include "emadiag/db/session_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "run_store_detail.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>
#include <string_view>

namespace emadiag::db {

namespace {
// The values the schema's CHECK constraints accept (schema/003_fleet_record.sql); checked here
// first so that the message names the field and the value.
constexpr std::array<std::string_view, 4> kPhases{"pre-flight", "post-flight", "in-flight", "load-rig"};
constexpr std::array<std::string_view, 4> kVerdicts{"SERVICEABLE", "UNSERVICEABLE", "INCONCLUSIVE", "NO_TEST"};
constexpr std::array<std::string_view, 3> kLimitKinds{"max", "min", "none"};
constexpr std::array<std::string_view, 3> kArtifactRoles{"model", "limits", "positions"};
constexpr std::string_view kNoLimit = "none";
constexpr std::size_t kSha256HexDigits = 64;
/// "YYYY-MM-DDThh:mm:ss": the part of an ISO 8601 time every started_utc begins with ('9' = a digit).
constexpr std::string_view kIsoDateTimePattern = "9999-99-99T99:99:99";
/// The tag that starts every session's hashed content (docs/record-format.md).
constexpr std::string_view kSessionHashTag = "emadiag-session-v1";
/// Estimators whose findings are measurements (the network findings are the verdict's cross-check).
constexpr std::string_view kPhysicsPrefix = "physics";

constexpr const char* kSessionColumns =
    "s.session_id, s.tail_number, s.actuator_serial, s.phase, s.started_utc, s.tool_version, s.verdict, s.verdict_note, s.limits_json, "
    "s.position, p.ata_reference, p.description, s.cycles, s.hours_h, s.operator_id, s.technician_name, s.technician_certificate, "
    "s.work_performed, s.source, s.limits_sha256, s.amends_session_id, s.correction_reason, s.prev_sha256, s.content_sha256 "
    "FROM test_sessions s LEFT JOIN positions p ON p.position = s.position";

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
bool is_one_of(std::string_view value, const std::array<std::string_view, N>& allowed) {
    return std::find(allowed.begin(), allowed.end(), value) != allowed.end();
}

/// Throws unless `value` is one of `allowed`; `field()` names it (built only for the message: the
/// bulk store checks millions of values).
template <std::size_t N, typename Field>
void check_one_of(const std::string& value, const std::array<std::string_view, N>& allowed, const Field& field) {
    if (!is_one_of(value, allowed)) throw DbError(field() + " is '" + value + "': use " + one_of(allowed), DbErrorKind::Invalid);
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

bool is_sha256_hex(const std::string& s) {
    return s.size() == kSha256HexDigits &&
           std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || (c >= 'a' && c <= 'f'); });
}

void invalid(const std::string& message) { throw DbError(message, DbErrorKind::Invalid); }

template <typename Field>
void check_optional_finite(const std::optional<double>& v, const Field& field) {
    if (v && !std::isfinite(*v)) invalid(field() + " is not a finite number (" + std::to_string(*v) + ")");
}

void check_session(const StoredTestSession& s) {
    // The messages are built only when a check fails (this runs once per stored session).
    const std::string_view where = "test session: ";
    const auto named = [&where](const char* field) { return [&where, field] { return std::string(where) + field; }; };
    if (const auto problem = detail::tail_number_problem(s.tail_number)) invalid(std::string(where) + *problem);
    check_one_of(s.phase, kPhases, named("phase"));
    check_one_of(s.verdict, kVerdicts, named("verdict"));
    if (!is_iso_date_time(s.started_utc)) {
        invalid(std::string(where) + "started_utc '" + s.started_utc + "' is not an ISO 8601 UTC time (" + std::string(kIsoDateTimePattern) +
                "...)");
    }
    if (s.position) {
        if (const auto problem = position_problem(*s.position)) invalid(std::string(where) + *problem);
        if (const auto problem = ata_reference_problem(s.position_ata)) invalid(std::string(where) + "position " + *s.position + ": " + *problem);
    }
    if (s.cycles && *s.cycles < 0) invalid(std::string(where) + "cycles " + std::to_string(*s.cycles) + " is negative");
    check_optional_finite(s.hours_h, named("hours_h"));
    if (s.hours_h && *s.hours_h < 0) invalid(std::string(where) + "hours_h " + std::to_string(*s.hours_h) + " is negative");
    if (s.amends_session_id.has_value() == s.correction_reason.empty())
        invalid(std::string(where) +
                (s.amends_session_id ? "a correction (amends session " + std::to_string(*s.amends_session_id) + ") needs a reason"
                                     : std::string("correction_reason '") + s.correction_reason + "' without amends_session_id"));
    for (std::size_t i = 0; i < s.artifacts.size(); ++i) {
        const auto& a = s.artifacts[i];
        const auto context = [&] { return std::string(where) + "artifact " + std::to_string(i) + " (" + a.name + "): "; };
        check_one_of(a.role, kArtifactRoles, [&] { return context() + "role"; });
        if (a.name.empty()) invalid(context() + "name is empty");
        if (!is_sha256_hex(a.sha256)) invalid(context() + "sha256 '" + a.sha256 + "' is not 64 lowercase hex digits");
        for (std::size_t j = 0; j < i; ++j)
            if (s.artifacts[j].role == a.role && s.artifacts[j].name == a.name) invalid(context() + "duplicate of artifact " + std::to_string(j));
    }
    for (std::size_t i = 0; i < s.runs.size(); ++i) {
        const std::string context = "test session run " + std::to_string(i) + ": ";
        detail::check_run(s.runs[i], context);
        if (s.runs[i].tail_number != s.tail_number) {
            invalid(context + "tail_number '" + s.runs[i].tail_number + "' differs from the session's '" + s.tail_number + "'");
        }
    }
    for (std::size_t i = 0; i < s.findings.size(); ++i) {
        const auto& f = s.findings[i];
        const auto context = [&] { return "test session finding " + std::to_string(i) + " (" + f.parameter + "/" + f.estimator + "): "; };
        if (f.parameter.empty()) invalid(context() + "parameter is empty");
        if (f.estimator.empty()) invalid(context() + "estimator is empty");
        if (f.status.empty()) invalid(context() + "status is empty");
        check_optional_finite(f.value, [&] { return context() + "value"; });
        check_optional_finite(f.std_error, [&] { return context() + "std_error"; });
        if (f.std_error && *f.std_error < 0) invalid(context() + "std_error " + std::to_string(*f.std_error) + " is negative");
        check_one_of(f.limit_kind, kLimitKinds, [&] { return context() + "limit_kind"; });
        check_optional_finite(f.limit_value, [&] { return context() + "limit_value"; });
        if ((f.limit_kind == kNoLimit) == f.limit_value.has_value()) {
            invalid(context() + "limit_kind '" + f.limit_kind + "' " +
                    (f.limit_value ? "with limit_value " + std::to_string(*f.limit_value) : std::string("without a limit_value")) +
                    ": a 'max' or 'min' limit has a value, 'none' has none");
        }
        for (std::size_t j = 0; j < i; ++j) {
            if (s.findings[j].parameter == f.parameter && s.findings[j].estimator == f.estimator) {
                invalid(context() + "duplicate of finding " + std::to_string(j) + ": each (parameter, estimator) is found once per session");
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
void bind_optional(Statement& st, int index, const std::optional<std::int64_t>& v) {
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

/// The layout of the findings table: clustered by tail (schema version 6 on) or keyed by session
/// alone (versions 2 to 5: only the sealing of the version-3 migration reads it so).
enum class FindingsLayout { ByTail, BySession };

std::vector<StoredFinding> load_findings(Database& db, std::int64_t session_id, FindingsLayout layout = FindingsLayout::ByTail) {
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

// ---- the hash chain (docs/record-format.md, "Hash chain") ----

/// Appends one field as "name:length:bytes\n"; a missing value as "name:-\n".
class Canon {
public:
    explicit Canon(Sha256& h) : h_(h) {}
    void text(std::string_view name, std::string_view v) {
        // "name:length:" built on the stack (this runs some 60 times per stored session).
        char head[96];
        std::size_t n = std::min(name.size(), sizeof head - 24);
        std::copy_n(name.data(), n, head);
        head[n++] = ':';
        const auto r = std::to_chars(head + n, head + sizeof head - 1, v.size());
        n = static_cast<std::size_t>(r.ptr - head);
        head[n++] = ':';
        h_.update(std::string_view(head, n)).update(v).update("\n");
    }
    void number(std::string_view name, double v) {
        if (v == 0) v = 0.0;  // SQLite stores -0.0 as the integer 0: hash both as "0"
        char buf[64];
        const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest form that reads back exactly
        text(name, std::string_view(buf, static_cast<std::size_t>(r.ptr - buf)));
    }
    void integer(std::string_view name, std::int64_t v) { text(name, std::to_string(v)); }
    void none(std::string_view name) { h_.update(name).update(":-\n"); }
    void opt(std::string_view name, const std::optional<double>& v) { v ? number(name, *v) : none(name); }
    void opt(std::string_view name, const std::optional<std::int64_t>& v) { v ? integer(name, *v) : none(name); }
    void opt(std::string_view name, const std::optional<std::string>& v) { v ? text(name, *v) : none(name); }

private:
    Sha256& h_;
};

// ---- the summary tables (series_stats, position_status) ----

int64_t days_from_civil(int y, unsigned m, unsigned d) {
    // H. Hinnant, "chrono-compatible low-level date algorithms": days since 1970-01-01.
    y -= m <= 2 ? 1 : 0;
    const int era = (y >= 0 ? y : y - 399) / 400;
    const unsigned yoe = static_cast<unsigned>(y - era * 400);
    const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return static_cast<int64_t>(era) * 146097 + static_cast<int64_t>(doe) - 719468;
}

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
    return static_cast<double>(days_from_civil(n(0, 4), static_cast<unsigned>(n(5, 2)), static_cast<unsigned>(n(8, 2)))) +
           (n(11, 2) * 3600.0 + n(14, 2) * 60.0 + n(17, 2)) / 86400.0;
}

/// What one transaction of stores (one session, or a batch) has read and changed of the small
/// per-tail tables, kept in memory and written once before COMMIT (flush): the summary rows
/// (series_stats, position_status), the chain heads, the tails and positions known to exist. Each
/// row is read from the database the first time the transaction touches it and then updated here
/// by the same rules, in the same order, as one statement per session would: the result is the same
/// as storing the sessions one by one. Dropped unflushed when the transaction rolls back.
struct Batch {
    struct Head {
        std::int64_t session_id = 0, added = 0;
        std::string sha;
    };
    /// (tail, position, serial) -> parameter -> its series_stats row (none: not stored yet). Two
    /// levels: a session's parameters share the first key, looked up once per session.
    std::map<std::tuple<std::string, std::string, std::string>, std::map<std::string, std::optional<SeriesStats>>> series;
    std::map<std::pair<std::string, std::string>, std::optional<PositionStatus>> positions;
    std::unordered_map<std::string, Head> heads;
    std::unordered_map<std::string, std::string> head_before;  ///< tail -> its stored head ("" none)
    std::unordered_map<std::string, bool> tails_known;
    std::unordered_map<std::string, std::string> position_ata;  ///< position -> its ATA reference, checked or registered
    /// The last limits text hashed and its SHA-256 (a fleet's sessions share their limits).
    std::string limits_json, limits_sha256;
    /// The id the next stored session gets (0: not read yet in this transaction).
    std::int64_t next_session_id = 0;
    /// Check each tail's chain head before appending to it (off only while the migration seals).
    bool check_heads = true;
    /// The insert statements, fetched from the connection's cache once per transaction.
    Statement *insert_aircraft = nullptr, *insert_session = nullptr, *insert_finding = nullptr, *insert_artifact = nullptr;
};

/// The statement in `slot` reset and unbound, prepared (or taken from the connection's cache) the
/// first time.
Statement& prepared(Database& db, Statement*& slot, const char* sql) {
    if (slot == nullptr) {
        slot = &db.cached(sql);
    } else {
        slot->reset();
    }
    return *slot;
}

const std::string& limits_sha256_of(Batch& b, const std::string& limits_json) {
    if (b.limits_sha256.empty() || b.limits_json != limits_json) {
        b.limits_json = limits_json;
        b.limits_sha256 = sha256_hex(limits_json);
    }
    return b.limits_sha256;
}

std::optional<SeriesStats>& series_row(Database& db, std::map<std::string, std::optional<SeriesStats>>& group, const std::string& tail,
                                       const std::string& position, const std::string& serial, const std::string& parameter) {
    auto [it, fresh] = group.try_emplace(parameter);
    if (fresh) {
        it->second = detail::find_series_stats(db, tail, position, serial, parameter);
    }
    return it->second;
}

std::optional<PositionStatus>& position_row(Database& db, Batch& b, const std::string& tail, const std::string& position) {
    auto [it, fresh] = b.positions.try_emplace({tail, position});
    if (fresh) it->second = detail::find_position_status(db, tail, position);
    return it->second;
}

/// Adds (sign +1) or removes (sign -1, for a session a correction amends) a session's measurements
/// in series_stats, and its place in position_status (docs/record-format.md, "Summary tables").
void add_to_summaries(Database& db, Batch& b, const StoredTestSession& s, std::int64_t session_id, int sign) {
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

StoredTestSession load_session(Database& db, std::int64_t session_id, FindingsLayout layout);

/// Throws DbError (kind BrokenChain) naming the tail and the session when the tail's chain head is
/// not what the tool left: the session it names is missing, of another tail, has another hash, or
/// no longer hashes to its stored value (its content was changed or damaged). One session's reads:
/// the bulk store checks this for every tail it appends to; a single store verifies the whole chain
/// first (verify_tail).
void check_chain_head(Database& db, const std::string& tail, const std::optional<std::pair<std::int64_t, std::string>>& head) {
    const auto broken = [&](const std::string& what) {
        throw DbError("tail " + tail + ": its hash chain is broken: " + what + "; nothing was stored (`emadiag verify --tail " + tail +
                          "` lists every problem; restore the database from a backup)",
                      DbErrorKind::BrokenChain);
    };
    if (!head || head->second.empty()) {
        Statement& any = db.cached("SELECT session_id FROM test_sessions WHERE tail_number = ? LIMIT 1");
        any.bind(1, tail);
        const bool has = any.step();
        const std::int64_t id = has ? any.column_int(0) : 0;
        any.reset();
        if (has) broken("it has sessions (e.g. session " + std::to_string(id) + ") but its chain head records none");
        return;
    }
    Statement& st = db.cached("SELECT tail_number, content_sha256 FROM test_sessions WHERE session_id = ?");
    st.bind(1, head->first);
    const bool found = st.step();
    const std::string of_tail = found ? st.column_text(0) : "", sha = found ? st.column_text(1) : "";
    st.reset();
    const std::string id = std::to_string(head->first);
    if (!found) broken("its chain head names session " + id + ", which is not in the database (removed outside the tool)");
    if (of_tail != tail) broken("its chain head names session " + id + ", which is a session of tail " + of_tail);
    if (sha != head->second)
        broken("session " + id + " (its newest) has hash " + sha.substr(0, 16) + "..., its chain head records " + head->second.substr(0, 16) + "...");
    const StoredTestSession s = load_session(db, head->first, FindingsLayout::ByTail);
    if (session_content_sha256(s, s.prev_sha256) != s.content_sha256)
        broken("session " + id + " (" + s.started_utc + "): its content differs from its stored hash (changed or damaged outside the tool)");
}

std::string chain_head(Database& db, Batch& b, const std::string& tail) {
    if (const auto it = b.heads.find(tail); it != b.heads.end()) return it->second.sha;
    if (const auto it = b.head_before.find(tail); it != b.head_before.end()) return it->second;
    Statement& st = db.cached("SELECT session_id, content_sha256 FROM chain_heads WHERE tail_number = ?");
    st.bind(1, tail);
    std::optional<std::pair<std::int64_t, std::string>> row;
    if (st.step()) row.emplace(st.column_int(0), st.column_text(1));
    st.reset();
    // The sealing of the version-3 migration builds the chain from nothing: no head to check.
    if (b.check_heads) check_chain_head(db, tail, row);
    const std::string head = row ? row->second : "";
    b.head_before[tail] = head;
    return head;
}

void set_chain_head(Batch& b, const std::string& tail, std::int64_t session_id, const std::string& sha) {
    Batch::Head& h = b.heads[tail];
    h.session_id = session_id;
    h.sha = sha;
    ++h.added;
}

/// Writes what the batch changed, inside its transaction.
void flush(Database& db, Batch& b) {
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

void register_position(Database& db, Batch& b, const StoredTestSession& s) {
    std::string ata;
    if (const auto it = b.position_ata.find(*s.position); it != b.position_ata.end()) {
        ata = it->second;
    } else {
        Statement& st = db.cached("SELECT ata_reference FROM positions WHERE position = ?");
        st.bind(1, *s.position);
        const bool known = st.step();
        ata = known ? st.column_text(0) : s.position_ata;
        st.reset();
        if (!known)
            db.cached("INSERT INTO positions(position, ata_reference, description) VALUES (?,?,?)")
                .bind(1, *s.position)
                .bind(2, s.position_ata)
                .bind(3, s.position_description)
                .run();
        b.position_ata[*s.position] = ata;
    }
    if (ata != s.position_ata)
        invalid("position " + *s.position + " is recorded in " + db.path() + " with ATA reference " + ata + ", not " + s.position_ata +
                ": a position keeps its ATA reference");
}

}  // namespace

std::optional<std::string> position_problem(const std::string& position) {
    bool ok = !position.empty() && position.size() <= kMaxPositionLength;
    for (char c : position)
        ok = ok && (std::isupper(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '-');
    if (ok) return std::nullopt;
    return "position '" + position + "' is not valid: use 1 to " + std::to_string(kMaxPositionLength) + " characters of A-Z, 0-9 and '-'";
}

std::optional<std::string> ata_reference_problem(const std::string& ata) {
    const bool ok = ata.size() >= 5 && ata.size() <= 16 && ata.compare(0, 3, "27-") == 0 && std::isdigit(static_cast<unsigned char>(ata[3])) &&
                    std::isdigit(static_cast<unsigned char>(ata[4]));
    if (ok) return std::nullopt;
    return "ATA reference '" + ata + "' is not valid: use chapter 27 (flight controls), e.g. 27-30";
}

std::vector<SessionMeasurement> session_measurements(const std::vector<StoredFinding>& findings) {
    // A session has a handful of parameters: a flat list searched in place (no map nodes per call),
    // sums in the order of the findings, the result sorted by parameter.
    struct Acc {
        SessionMeasurement m;
        double sum_w = 0, sum_wy = 0;
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
        if (f.estimator.rfind(kPhysicsPrefix, 0) != 0 || !f.value) continue;
        if (!f.std_error || !(*f.std_error > 0) || !std::isfinite(*f.std_error)) continue;
        const double w = 1.0 / (*f.std_error * *f.std_error);
        it->sum_w += w;
        it->sum_wy += w * *f.value;
    }
    std::sort(acc.begin(), acc.end(), [](const Acc& x, const Acc& y) { return x.m.parameter < y.m.parameter; });
    std::vector<SessionMeasurement> out;
    out.reserve(acc.size());
    for (auto& a : acc) {
        if (!(a.sum_w > 0)) continue;
        a.m.value = a.sum_wy / a.sum_w;
        a.m.std_error = 1.0 / std::sqrt(a.sum_w);
        out.push_back(std::move(a.m));
    }
    return out;
}

namespace {
/// The content hash of `s` with its limits hash given (the store computes it without copying `s`).
std::string content_sha256(const StoredTestSession& s, const std::string& limits_sha256, const std::string& prev_sha256) {
    Sha256 h;
    h.update(kSessionHashTag).update("\n");
    Canon c(h);
    c.text("prev_sha256", prev_sha256);
    c.text("tail_number", s.tail_number);
    c.opt("position", s.position);
    c.text("actuator_serial", s.actuator_serial);
    c.text("phase", s.phase);
    c.text("started_utc", s.started_utc);
    c.opt("cycles", s.cycles);
    c.opt("hours_h", s.hours_h);
    c.text("operator_id", s.operator_id);
    c.text("technician_name", s.technician_name);
    c.text("technician_certificate", s.technician_certificate);
    c.text("work_performed", s.work_performed);
    c.text("source", s.source);
    c.text("tool_version", s.tool_version);
    c.text("verdict", s.verdict);
    c.text("verdict_note", s.verdict_note);
    c.text("limits_json", s.limits_json);
    c.text("limits_sha256", limits_sha256);
    c.opt("amends_session_id", s.amends_session_id);
    c.text("correction_reason", s.correction_reason);
    std::vector<const StoredArtifact*> artifacts;
    for (const auto& a : s.artifacts) artifacts.push_back(&a);
    std::sort(artifacts.begin(), artifacts.end(), [](const auto* a, const auto* b) { return std::tie(a->role, a->name) < std::tie(b->role, b->name); });
    c.integer("artifacts", static_cast<std::int64_t>(artifacts.size()));
    for (const auto* ap : artifacts) {
        const StoredArtifact& a = *ap;
        c.text("role", a.role);
        c.text("name", a.name);
        c.text("sha256", a.sha256);
    }
    c.integer("runs", static_cast<std::int64_t>(s.runs.size()));
    for (const auto& r : s.runs) {
        c.text("run.actuator_serial", r.actuator_serial);
        c.text("run.started_utc", r.started_utc);
        c.text("run.source", r.source);
        c.text("run.load_case", r.load_case);
        c.text("run.sequence", r.sequence);
        c.number("run.k_t_nm_per_a", r.k_t_nm_per_a);
        c.number("run.j_kgm2", r.j_kgm2);
        c.number("run.tau", r.tau);
        c.number("run.sample_period_s", r.sample_period_s);
        c.integer("run.valid", r.valid ? 1 : 0);
        c.text("run.status_note", r.status_note);
        c.text("run.meta_json", r.meta_json);
        c.integer("run.samples", static_cast<std::int64_t>(r.samples.size()));
        for (const auto& x : r.samples) {
            for (double v : {x.t_s, x.current_a, x.speed_rad_s, x.theta_m_rad, x.hinge_moment_nm, x.command_deg}) c.number("x", v);
        }
        c.text("run.raw_log_format", r.raw_log_format);
        c.text("run.raw_log_sha256", sha256_hex(r.raw_log));
        auto est = r.estimates;
        std::sort(est.begin(), est.end(), [](const auto& a, const auto& b) { return std::tie(a.estimator, a.parameter) < std::tie(b.estimator, b.parameter); });
        c.integer("run.estimates", static_cast<std::int64_t>(est.size()));
        for (const auto& e : est) {
            c.text("estimator", e.estimator);
            c.text("parameter", e.parameter);
            c.opt("value", e.value);
            c.number("std_error", e.std_error);
            c.integer("identifiable", e.identifiable ? 1 : 0);
            c.text("method", e.method);
            c.text("note", e.note);
        }
    }
    std::vector<const StoredFinding*> findings;
    for (const auto& f : s.findings) findings.push_back(&f);
    std::sort(findings.begin(), findings.end(),
              [](const auto* a, const auto* b) { return std::tie(a->parameter, a->estimator) < std::tie(b->parameter, b->estimator); });
    c.integer("findings", static_cast<std::int64_t>(findings.size()));
    for (const auto* fp : findings) {
        const StoredFinding& f = *fp;
        c.text("parameter", f.parameter);
        c.text("estimator", f.estimator);
        c.opt("value", f.value);
        c.opt("std_error", f.std_error);
        c.opt("limit_value", f.limit_value);
        c.text("limit_kind", f.limit_kind);
        c.text("status", f.status);
        c.text("note", f.note);
    }
    return h.hex();
}
}  // namespace

std::string session_content_sha256(const StoredTestSession& s, const std::string& prev_sha256) {
    return content_sha256(s, s.limits_sha256, prev_sha256);
}

namespace {
/// Writes one checked session inside the caller's open transaction.
SessionReceipt insert_session(Database& db, Batch& b, const StoredTestSession& session) {
    // The session as given, with its three hashes beside it (no copy of the session).
    const StoredTestSession& s = session;
    const std::string& limits_sha256 = limits_sha256_of(b, s.limits_json);
    if (b.tails_known.emplace(s.tail_number, true).second)
        prepared(db, b.insert_aircraft, "INSERT OR IGNORE INTO aircraft(tail_number) VALUES (?)").bind(1, s.tail_number).run();
    if (s.position) register_position(db, b, s);
    std::optional<StoredTestSession> amended;
    if (s.amends_session_id) {
        Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE s.session_id = ?");
        st.bind(1, *s.amends_session_id);
        if (!st.step()) invalid("test session: amends session " + std::to_string(*s.amends_session_id) + ", which is not in " + db.path());
        amended = read_session_row(st);
        if (amended->tail_number != s.tail_number)
            invalid("test session: amends session " + std::to_string(*s.amends_session_id) + " of tail " + amended->tail_number +
                    ", not of " + s.tail_number);
        Statement again(db, "SELECT session_id FROM test_sessions WHERE amends_session_id = ?");
        again.bind(1, *s.amends_session_id);
        if (again.step())
            invalid("test session: session " + std::to_string(*s.amends_session_id) + " is already amended by session " +
                    std::to_string(again.column_int(0)) + "; amend that one instead");
        amended->findings = load_findings(db, amended->session_id);
    }
    const std::string prev_sha256 = chain_head(db, b, s.tail_number);
    const std::string content = content_sha256(s, limits_sha256, prev_sha256);
    if (b.next_session_id == 0) {
        // session_id is no rowid (schema/006): the next id above every one used so far, including a
        // tail's last session recorded in chain_heads (an id is never given twice).
        Statement& next = db.cached(
            "SELECT max(coalesce((SELECT max(session_id) FROM test_sessions), 0), coalesce((SELECT max(session_id) FROM chain_heads), 0)) + 1");
        next.step();
        b.next_session_id = next.column_int(0);
        next.reset();
    }
    const std::int64_t session_id = b.next_session_id++;

    // The texts are bound without a copy (bind_view): the session, the batch's limits hash and the
    // two local hashes outlive the statement's run below.
    Statement& ins = prepared(db, b.insert_session,
        "INSERT INTO test_sessions(tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, limits_json, "
        "position, cycles, hours_h, operator_id, technician_name, technician_certificate, work_performed, source, limits_sha256, "
        "amends_session_id, correction_reason, prev_sha256, content_sha256, session_id) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    ins.bind_view(1, s.tail_number).bind_view(2, s.actuator_serial).bind_view(3, s.phase).bind_view(4, s.started_utc);
    ins.bind_view(5, s.tool_version).bind_view(6, s.verdict).bind_view(7, s.verdict_note).bind_view(8, s.limits_json);
    if (s.position) {
        ins.bind_view(9, *s.position);
    } else {
        ins.bind_null(9);
    }
    bind_optional(ins, 10, s.cycles);
    bind_optional(ins, 11, s.hours_h);
    ins.bind_view(12, s.operator_id).bind_view(13, s.technician_name).bind_view(14, s.technician_certificate).bind_view(15, s.work_performed);
    ins.bind_view(16, s.source).bind_view(17, limits_sha256);
    bind_optional(ins, 18, s.amends_session_id);
    ins.bind_view(19, s.correction_reason).bind_view(20, prev_sha256).bind_view(21, content).bind(22, session_id);
    ins.run();
    SessionReceipt receipt;
    receipt.session_id = session_id;
    receipt.content_sha256 = content;

    for (const auto& run : s.runs) (void)detail::insert_run(db, run, receipt.session_id);
    for (const auto& f : s.findings) {
        Statement& fnd = prepared(db, b.insert_finding,
            "INSERT INTO findings(session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note, tail_number) "
            "VALUES (?,?,?,?,?,?,?,?,?,?)");
        fnd.bind(1, receipt.session_id).bind_view(2, f.parameter).bind_view(3, f.estimator);
        bind_optional(fnd, 4, f.value);
        bind_optional(fnd, 5, f.std_error);
        bind_optional(fnd, 6, f.limit_value);
        fnd.bind_view(7, f.limit_kind).bind_view(8, f.status).bind_view(9, f.note).bind_view(10, s.tail_number).run();
    }
    for (const auto& a : s.artifacts) {
        Statement& art = prepared(db, b.insert_artifact, "INSERT INTO session_artifacts(session_id, role, name, sha256) VALUES (?,?,?,?)");
        art.bind(1, receipt.session_id).bind_view(2, a.role).bind_view(3, a.name).bind_view(4, a.sha256).run();
    }
    // An installation change: the position shows a serial other than the one installed there so far.
    if (s.position && !s.actuator_serial.empty()) {
        const std::optional<PositionStatus>& now = position_row(db, b, s.tail_number, *s.position);
        const std::optional<std::string> installed = now ? std::optional<std::string>(now->actuator_serial) : std::nullopt;
        if (!installed || *installed != s.actuator_serial) {
            StoredInstallation inst;
            inst.tail_number = s.tail_number;
            inst.position = *s.position;
            inst.from_serial = installed.value_or("");
            inst.to_serial = s.actuator_serial;
            inst.detected_utc = s.started_utc;
            inst.cycles = s.cycles;
            inst.hours_h = s.hours_h;
            inst.session_id = receipt.session_id;
            Statement& ii = db.cached(
                "INSERT INTO installations(tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id) "
                "VALUES (?,?,?,?,?,?,?,?)");
            ii.bind(1, inst.tail_number).bind(2, inst.position).bind(3, inst.from_serial).bind(4, inst.to_serial).bind(5, inst.detected_utc);
            bind_optional(ii, 6, inst.cycles);
            bind_optional(ii, 7, inst.hours_h);
            ii.bind(8, inst.session_id).run();
            inst.installation_id = db.last_insert_id();
            receipt.installation = inst;
        }
    }
    set_chain_head(b, s.tail_number, receipt.session_id, content);
    if (amended) add_to_summaries(db, b, *amended, amended->session_id, -1);
    add_to_summaries(db, b, s, receipt.session_id, +1);
    return receipt;
}
}  // namespace

namespace {
/// The tails a batch appended to (for the anchor file), before flush() clears the batch.
std::vector<std::string> tails_of(const Batch& b) {
    std::vector<std::string> tails;
    for (const auto& [tail, head] : b.heads) tails.push_back(tail);
    std::sort(tails.begin(), tails.end());
    return tails;
}

/// Throws DbError (kind BrokenChain) unless the tail's whole record verifies (verify_tail): a store
/// never appends to a broken chain. The message names the tail and the first problem.
void require_intact(Database& db, const std::string& tail) {
    {
        // Verified whole by this connection, and nobody has appended since: the head check inside
        // the transaction (check_chain_head) is enough.
        Statement& head = db.cached("SELECT content_sha256 FROM chain_heads WHERE tail_number = ?");
        head.bind(1, tail);
        const std::string now = head.step() ? head.column_text(0) : "";
        head.reset();
        if (!now.empty() && db.verified_head(tail) == now) return;
    }
    const ChainCheck c = verify_tail(db, tail, /*compare_anchor=*/false);
    if (c.ok()) {
        db.set_verified_head(tail, c.head_sha256);
        return;
    }
    throw DbError("tail " + tail + ": its record was changed outside the tool (" + std::to_string(c.problems.size()) +
                      " problem(s); the first: " + c.problems.front() + "); nothing was stored: nothing is appended to a broken chain (`emadiag verify --tail " +
                      tail + "` lists every problem; restore the database from a backup)",
                  DbErrorKind::BrokenChain);
}
}  // namespace

struct SessionBatch::State {
    explicit State(Database& d) : db(d) {}
    Database& db;
    std::optional<Transaction> tx;
    Batch b;
    std::map<std::string, bool> verified;  ///< tails whose whole record was verified in this batch
    bool committed = false;
};

SessionBatch::SessionBatch(Database& db) : state_(std::make_unique<State>(db)) {}
SessionBatch::~SessionBatch() = default;  // an open transaction rolls back (Transaction's destructor)

SessionReceipt SessionBatch::add(const StoredTestSession& session) {
    State& st = *state_;
    if (st.committed) throw DbError("session batch on " + st.db.path() + " already committed", DbErrorKind::Invalid);
    check_session(session);
    if (st.verified.emplace(session.tail_number, true).second) {
        // The first tail is verified before the write lock is taken (reading a long record must not
        // hold other writers off); a later one inside the transaction.
        require_intact(st.db, session.tail_number);
    }
    if (!st.tx) st.tx.emplace(st.db);
    return insert_session(st.db, st.b, session);
}

void SessionBatch::commit() {
    State& st = *state_;
    if (st.committed) throw DbError("session batch on " + st.db.path() + " already committed", DbErrorKind::Invalid);
    st.committed = true;
    if (!st.tx) return;  // nothing added
    const std::vector<std::string> tails = tails_of(st.b);
    std::vector<std::pair<std::string, std::string>> heads;  // each verified tail's new head
    for (const auto& [tail, h] : st.b.heads) heads.emplace_back(tail, h.sha);
    flush(st.db, st.b);
    st.tx->commit();
    for (auto& [tail, sha] : heads) st.db.set_verified_head(tail, std::move(sha));
    detail::append_anchor(st.db, tails);
}

SessionReceipt store_session(Database& db, const StoredTestSession& session) {
    SessionBatch batch(db);
    SessionReceipt receipt = batch.add(session);
    batch.commit();
    return receipt;
}

std::vector<SessionReceipt> store_sessions(Database& db, const std::vector<StoredTestSession>& sessions) {
    for (std::size_t i = 0; i < sessions.size(); ++i) {
        try {
            check_session(sessions[i]);
        } catch (const DbError& e) {
            throw DbError("batch session " + std::to_string(i) + ": " + std::string(e.what()).substr(std::string("[maintenance_db] ").size()),
                          e.kind());
        }
    }
    std::vector<SessionReceipt> out;
    out.reserve(sessions.size());
    Transaction tx(db);
    Batch b;  // checks each tail's chain head (one session's reads per tail) before appending to it
    for (const auto& s : sessions) out.push_back(insert_session(db, b, s));
    const std::vector<std::string> tails = tails_of(b);
    flush(db, b);
    tx.commit();
    detail::append_anchor(db, tails);
    return out;
}

std::int64_t store_test_session(Database& db, const StoredTestSession& session) { return store_session(db, session).session_id; }

namespace {
StoredTestSession load_session(Database& db, std::int64_t session_id, FindingsLayout layout) {
    Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE s.session_id = ?");
    st.bind(1, session_id);
    if (!st.step()) throw DbError("no test session with id " + std::to_string(session_id) + " in " + db.path(), DbErrorKind::Invalid);
    StoredTestSession s = read_session_row(st);
    for (const auto& listed : detail::session_runs(db, session_id)) s.runs.push_back(load_run(db, listed.run_id));
    s.findings = load_findings(db, session_id, layout);
    s.artifacts = load_artifacts(db, session_id);
    return s;
}
}  // namespace

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

void detail::seal_sessions_before_v3(Database& db) {
    std::vector<std::int64_t> ids;
    {
        Statement st(db, "SELECT session_id FROM test_sessions ORDER BY session_id");
        while (st.step()) ids.push_back(st.column_int(0));
    }
    Batch b;
    b.check_heads = false;
    for (const auto id : ids) {
        StoredTestSession s = load_session(db, id, FindingsLayout::BySession);  // the version-3 layout
        s.limits_sha256 = sha256_hex(s.limits_json);
        s.prev_sha256 = chain_head(db, b, s.tail_number);
        s.content_sha256 = session_content_sha256(s, s.prev_sha256);
        Statement up(db, "UPDATE test_sessions SET limits_sha256 = ?, prev_sha256 = ?, content_sha256 = ? WHERE session_id = ?");
        up.bind(1, s.limits_sha256).bind(2, s.prev_sha256).bind(3, s.content_sha256).bind(4, id).run();
        set_chain_head(b, s.tail_number, id, s.content_sha256);
        add_to_summaries(db, b, s, id, +1);
    }
    flush(db, b);
}

}  // namespace emadiag::db
