#include "emadiag/db/record_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "run_store_detail.hpp"

#include <algorithm>
#include <utility>

namespace emadiag::db {
namespace {

void invalid(const std::string& message) { throw DbError(message, DbErrorKind::Invalid); }

/// Reads a result row's columns left to right: each call takes the next column, so a reader lists
/// the fields in the order of its SELECT without numbering them.
class Columns {
public:
    explicit Columns(const Statement& st) : st_(st) {}
    std::string text() { return st_.column_text(col_++); }
    std::int64_t integer() { return st_.column_int(col_++); }
    double real() { return st_.column_double(col_++); }
    std::optional<std::string> optional_text() { return st_.column_is_null(col_) ? skip<std::string>() : std::optional<std::string>(text()); }
    std::optional<std::int64_t> optional_integer() { return st_.column_is_null(col_) ? skip<std::int64_t>() : std::optional<std::int64_t>(integer()); }
    std::optional<double> optional_real() { return st_.column_is_null(col_) ? skip<double>() : std::optional<double>(real()); }

private:
    template <class T>
    std::optional<T> skip() {
        ++col_;
        return std::nullopt;
    }
    const Statement& st_;
    int col_ = 0;
};

/// Every row of a bound statement, each read by `read(Columns&)`: the one query loop of this file.
template <class Read>
auto collect(Statement& st, Read read) {
    std::vector<decltype(read(std::declval<Columns&>()))> out;
    while (st.step()) {
        Columns c(st);
        out.push_back(read(c));
    }
    return out;
}

constexpr const char* kInstallationColumns =
    "installation_id, tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id FROM installations";

StoredInstallation read_installation(Columns& c) {
    StoredInstallation i;
    i.installation_id = c.integer();
    i.tail_number = c.text();
    i.position = c.text();
    i.from_serial = c.text();
    i.to_serial = c.text();
    i.detected_utc = c.text();
    i.cycles = c.optional_integer();
    i.hours_h = c.optional_real();
    i.session_id = c.integer();
    return i;
}

constexpr const char* kPositionStatusColumns =
    "tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, last_cycles";

PositionStatus read_position_status(Columns& c) {
    PositionStatus p;
    p.tail_number = c.text();
    p.position = c.text();
    p.actuator_serial = c.text();
    p.sessions = c.integer();
    p.last_session_id = c.integer();
    p.last_utc = c.text();
    p.last_verdict = c.text();
    p.last_cycles = c.optional_integer();
    return p;
}

SeriesStats read_series_stats(Columns& c) {
    SeriesStats s;
    s.tail_number = c.text();
    s.position = c.text();
    s.actuator_serial = c.text();
    s.parameter = c.text();
    s.n = c.integer();
    s.first_days = c.real();
    s.last_days = c.real();
    for (double* sum : {&s.s_w, &s.s_wt, &s.s_wtt, &s.s_wy, &s.s_wty, &s.s_wyy}) *sum = c.real();
    s.n_cycles = c.integer();
    s.first_cycles = c.optional_real();
    s.last_cycles = c.optional_real();
    for (double* sum : {&s.c_w, &s.c_wt, &s.c_wtt, &s.c_wy, &s.c_wty, &s.c_wyy}) *sum = c.real();
    s.last_session_id = c.integer();
    s.last_value = c.real();
    s.last_std_error = c.real();
    s.limit_kind = c.text();
    s.limit_value = c.optional_real();
    return s;
}

std::string discovery_sha256(const StoredDiscoveryFinding& f) {
    Sha256 h;
    h.update("emadiag-discovery-v1\n");
    for (const auto& [name, value] : std::initializer_list<std::pair<const char*, std::string>>{
             {"tail_number", f.tail_number},
             {"position", f.position.value_or("")},
             {"actuator_serial", f.actuator_serial},
             {"found_utc", f.found_utc},
             {"summary", f.summary},
             {"model_json", f.model_json},
             {"status", f.status},
             {"amends_finding_id", f.amends_finding_id ? std::to_string(*f.amends_finding_id) : "-"},
             {"tool_version", f.tool_version}}) {
        h.update(std::string(name) + ":" + std::to_string(value.size()) + ":").update(value).update("\n");
    }
    return h.hex();
}

}  // namespace

std::vector<StoredPosition> list_positions(Database& db) {
    Statement st(db, "SELECT position, ata_reference, description FROM positions ORDER BY position");
    return collect(st, [](Columns& c) { return StoredPosition{c.text(), c.text(), c.text()}; });
}

std::vector<StoredInstallation> list_installations(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT ") + kInstallationColumns + " WHERE tail_number = ? ORDER BY installation_id");
    st.bind(1, tail_number);
    return collect(st, read_installation);
}

std::vector<StoredInstallation> list_installations_of_serial(Database& db, const std::string& actuator_serial) {
    Statement st(db, std::string("SELECT ") + kInstallationColumns + " WHERE to_serial = ? OR from_serial = ? ORDER BY installation_id");
    st.bind(1, actuator_serial).bind(2, actuator_serial);
    return collect(st, read_installation);
}

std::int64_t store_discovery_finding(Database& db, const StoredDiscoveryFinding& finding) {
    const std::string where = "discovery finding: ";
    if (const auto p = detail::tail_number_problem(finding.tail_number)) invalid(where + *p);
    if (finding.position) {
        if (const auto p = position_problem(*finding.position)) invalid(where + *p);
        if (const auto p = ata_reference_problem(finding.position_ata)) invalid(where + "position " + *finding.position + ": " + *p);
    }
    if (finding.found_utc.size() < 19 || finding.found_utc[4] != '-' || finding.found_utc[10] != 'T')
        invalid(where + "found_utc '" + finding.found_utc + "' is not an ISO 8601 UTC time (YYYY-MM-DDThh:mm:ss...)");
    if (finding.summary.empty()) invalid(where + "summary is empty");
    if (finding.status != "open" && finding.status != "closed") invalid(where + "status is '" + finding.status + "': use 'open' or 'closed'");
    StoredDiscoveryFinding f = finding;
    f.content_sha256 = discovery_sha256(f);
    Transaction tx(db);
    Statement(db, "INSERT OR IGNORE INTO aircraft(tail_number) VALUES (?)").bind(1, f.tail_number).run();
    if (f.position) {
        Statement pos(db, "SELECT ata_reference FROM positions WHERE position = ?");
        pos.bind(1, *f.position);
        if (!pos.step()) {
            Statement(db, "INSERT INTO positions(position, ata_reference, description) VALUES (?,?,?)")
                .bind(1, *f.position)
                .bind(2, f.position_ata)
                .bind(3, f.position_description)
                .run();
        } else if (pos.column_text(0) != f.position_ata) {
            invalid(where + "position " + *f.position + " is recorded with ATA reference " + pos.column_text(0) + ", not " + f.position_ata);
        }
    }
    if (f.amends_finding_id) {
        Statement st(db, "SELECT tail_number, (SELECT finding_id FROM discovery_findings WHERE amends_finding_id = ?1) "
                         "FROM discovery_findings WHERE finding_id = ?1");
        st.bind(1, *f.amends_finding_id);
        if (!st.step()) invalid(where + "amends finding " + std::to_string(*f.amends_finding_id) + ", which is not in " + db.path());
        if (st.column_text(0) != f.tail_number)
            invalid(where + "amends finding " + std::to_string(*f.amends_finding_id) + " of tail " + st.column_text(0));
        if (!st.column_is_null(1))
            invalid(where + "finding " + std::to_string(*f.amends_finding_id) + " is already amended by finding " +
                    std::to_string(st.column_int(1)));
    }
    Statement ins(db, "INSERT INTO discovery_findings(tail_number, position, actuator_serial, found_utc, summary, model_json, status, "
                      "amends_finding_id, tool_version, content_sha256) VALUES (?,?,?,?,?,?,?,?,?,?)");
    ins.bind(1, f.tail_number);
    if (f.position) {
        ins.bind(2, *f.position);
    } else {
        ins.bind_null(2);
    }
    ins.bind(3, f.actuator_serial).bind(4, f.found_utc).bind(5, f.summary).bind(6, f.model_json).bind(7, f.status);
    if (f.amends_finding_id) {
        ins.bind(8, *f.amends_finding_id);
    } else {
        ins.bind_null(8);
    }
    ins.bind(9, f.tool_version).bind(10, f.content_sha256).run();
    const std::int64_t id = db.last_insert_id();
    tx.commit();
    return id;
}

std::vector<StoredDiscoveryFinding> list_discovery_findings(Database& db, const std::string& tail_number, bool open_only) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT d.finding_id, d.tail_number, d.position, p.ata_reference, p.description, d.actuator_serial, "
                                 "d.found_utc, d.summary, d.model_json, d.status, d.amends_finding_id, d.tool_version, d.content_sha256 "
                                 "FROM discovery_findings d LEFT JOIN positions p ON p.position = d.position WHERE d.tail_number = ?") +
                         (open_only ? " AND d.status = 'open' AND NOT EXISTS (SELECT 1 FROM discovery_findings a WHERE "
                                      "a.amends_finding_id = d.finding_id)"
                                    : "") +
                         " ORDER BY d.found_utc, d.finding_id");
    st.bind(1, tail_number);
    return collect(st, [](Columns& c) {
        StoredDiscoveryFinding f;
        f.finding_id = c.integer();
        f.tail_number = c.text();
        f.position = c.optional_text();
        f.position_ata = c.text();
        f.position_description = c.text();
        f.actuator_serial = c.text();
        f.found_utc = c.text();
        f.summary = c.text();
        f.model_json = c.text();
        f.status = c.text();
        f.amends_finding_id = c.optional_integer();
        f.tool_version = c.text();
        f.content_sha256 = c.text();
        return f;
    });
}

std::vector<PositionStatus> list_position_status(Database& db) {
    Statement st(db, std::string("SELECT ") + kPositionStatusColumns + " FROM position_status ORDER BY tail_number, position");
    return collect(st, read_position_status);
}

std::optional<PositionStatus> detail::find_position_status(Database& db, const std::string& tail_number, const std::string& position) {
    Statement& st = db.cached(std::string("SELECT ") + kPositionStatusColumns + " FROM position_status WHERE tail_number = ? AND position = ?");
    st.bind(1, tail_number).bind(2, position);
    std::vector<PositionStatus> rows = collect(st, read_position_status);
    st.reset();
    if (rows.empty()) return std::nullopt;
    return std::move(rows.front());
}

std::vector<SeriesStats> list_series_stats(Database& db, const std::optional<std::string>& tail_number) {
    Statement st(db, std::string("SELECT ") + detail::kSeriesStatsColumns + " FROM series_stats" + (tail_number ? " WHERE tail_number = ?" : "") +
                         " ORDER BY tail_number, position, actuator_serial, parameter");
    if (tail_number) st.bind(1, *tail_number);
    return collect(st, read_series_stats);
}

std::optional<SeriesStats> detail::find_series_stats(Database& db, const std::string& tail_number, const std::string& position,
                                                     const std::string& actuator_serial, const std::string& parameter) {
    Statement& st = db.cached(std::string("SELECT ") + kSeriesStatsColumns +
                              " FROM series_stats WHERE tail_number = ? AND position = ? AND actuator_serial = ? AND parameter = ?");
    st.bind(1, tail_number).bind(2, position).bind(3, actuator_serial).bind(4, parameter);
    std::vector<SeriesStats> rows = collect(st, read_series_stats);
    st.reset();
    if (rows.empty()) return std::nullopt;
    return std::move(rows.front());
}

ChainCheck verify_tail(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    ChainCheck out;
    out.tail_number = tail_number;
    Statement of_tail(db, "SELECT session_id FROM test_sessions WHERE tail_number = ? ORDER BY session_id");
    of_tail.bind(1, tail_number);
    const std::vector<std::int64_t> ids = collect(of_tail, [](Columns& c) { return c.integer(); });
    std::string prev;
    for (const auto id : ids) {
        const StoredTestSession s = load_test_session(db, id);
        const std::string where = "session " + std::to_string(id) + " (" + s.started_utc + "): ";
        if (s.prev_sha256 != prev)
            out.problems.push_back(where + "its link to the previous session (" + s.prev_sha256.substr(0, 16) + "...) is not that session's hash (" +
                                   prev.substr(0, 16) + "...): a session before it was removed, added or changed");
        if (sha256_hex(s.limits_json) != s.limits_sha256) out.problems.push_back(where + "its limits differ from their stored hash");
        const std::string recomputed = session_content_sha256(s, s.prev_sha256);
        if (recomputed != s.content_sha256)
            out.problems.push_back(where + "its content differs from its stored hash " + s.content_sha256.substr(0, 16) +
                                   "... (recomputed " + recomputed.substr(0, 16) + "...): changed outside the tool");
        prev = s.content_sha256;
        ++out.sessions_checked;
    }
    out.head_sha256 = prev;
    Statement head(db, "SELECT session_id, sessions, content_sha256 FROM chain_heads WHERE tail_number = ?");
    head.bind(1, tail_number);
    if (head.step()) {
        if (head.column_text(2) != prev || head.column_int(1) != static_cast<std::int64_t>(ids.size()))
            out.problems.push_back("the chain head records " + std::to_string(head.column_int(1)) + " sessions ending at session " +
                                   std::to_string(head.column_int(0)) + " (" + head.column_text(2).substr(0, 16) + "...), the tail has " +
                                   std::to_string(ids.size()) + (ids.empty() ? "" : " ending at session " + std::to_string(ids.back())) +
                                   ": sessions were removed or added outside the tool");
    } else if (!ids.empty()) {
        out.problems.push_back("the tail has " + std::to_string(ids.size()) + " sessions but no chain head: the record was changed outside the tool");
    }
    return out;
}

}  // namespace emadiag::db
