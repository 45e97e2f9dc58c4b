#include "emadiag/db/record_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/sha256.hpp"

#include "run_store_detail.hpp"

#include <algorithm>

namespace emadiag::db {
namespace {

void invalid(const std::string& message) { throw DbError(message, DbErrorKind::Invalid); }

std::optional<std::string> optional_text(const Statement& st, int col) {
    return st.column_is_null(col) ? std::nullopt : std::optional<std::string>(st.column_text(col));
}
std::optional<double> optional_double(const Statement& st, int col) {
    return st.column_is_null(col) ? std::nullopt : std::optional<double>(st.column_double(col));
}
std::optional<std::int64_t> optional_int(const Statement& st, int col) {
    return st.column_is_null(col) ? std::nullopt : std::optional<std::int64_t>(st.column_int(col));
}

constexpr const char* kInstallationColumns =
    "installation_id, tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id FROM installations";

StoredInstallation read_installation(const Statement& st) {
    StoredInstallation i;
    i.installation_id = st.column_int(0);
    i.tail_number = st.column_text(1);
    i.position = st.column_text(2);
    i.from_serial = st.column_text(3);
    i.to_serial = st.column_text(4);
    i.detected_utc = st.column_text(5);
    i.cycles = optional_int(st, 6);
    i.hours_h = optional_double(st, 7);
    i.session_id = st.column_int(8);
    return i;
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
    std::vector<StoredPosition> out;
    while (st.step()) out.push_back({st.column_text(0), st.column_text(1), st.column_text(2)});
    return out;
}

std::vector<StoredInstallation> list_installations(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT ") + kInstallationColumns + " WHERE tail_number = ? ORDER BY installation_id");
    st.bind(1, tail_number);
    std::vector<StoredInstallation> out;
    while (st.step()) out.push_back(read_installation(st));
    return out;
}

std::vector<StoredInstallation> list_installations_of_serial(Database& db, const std::string& actuator_serial) {
    Statement st(db, std::string("SELECT ") + kInstallationColumns + " WHERE to_serial = ? OR from_serial = ? ORDER BY installation_id");
    st.bind(1, actuator_serial).bind(2, actuator_serial);
    std::vector<StoredInstallation> out;
    while (st.step()) out.push_back(read_installation(st));
    return out;
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
    std::vector<StoredDiscoveryFinding> out;
    while (st.step()) {
        StoredDiscoveryFinding f;
        f.finding_id = st.column_int(0);
        f.tail_number = st.column_text(1);
        f.position = optional_text(st, 2);
        f.position_ata = st.column_text(3);
        f.position_description = st.column_text(4);
        f.actuator_serial = st.column_text(5);
        f.found_utc = st.column_text(6);
        f.summary = st.column_text(7);
        f.model_json = st.column_text(8);
        f.status = st.column_text(9);
        f.amends_finding_id = optional_int(st, 10);
        f.tool_version = st.column_text(11);
        f.content_sha256 = st.column_text(12);
        out.push_back(std::move(f));
    }
    return out;
}

std::vector<PositionStatus> list_position_status(Database& db) {
    Statement st(db, "SELECT tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, last_cycles "
                     "FROM position_status ORDER BY tail_number, position");
    std::vector<PositionStatus> out;
    while (st.step()) {
        out.push_back({st.column_text(0), st.column_text(1), st.column_text(2), st.column_int(3), st.column_int(4), st.column_text(5),
                       st.column_text(6), optional_int(st, 7)});
    }
    return out;
}

std::vector<SeriesStats> list_series_stats(Database& db, const std::optional<std::string>& tail_number) {
    Statement st(db, std::string("SELECT tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, "
                                 "s_wy, s_wty, s_wyy, n_cycles, first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, "
                                 "last_session_id, last_value, last_std_error, limit_kind, limit_value FROM series_stats") +
                         (tail_number ? " WHERE tail_number = ?" : "") + " ORDER BY tail_number, position, actuator_serial, parameter");
    if (tail_number) st.bind(1, *tail_number);
    std::vector<SeriesStats> out;
    while (st.step()) {
        SeriesStats s;
        s.tail_number = st.column_text(0);
        s.position = st.column_text(1);
        s.actuator_serial = st.column_text(2);
        s.parameter = st.column_text(3);
        s.n = st.column_int(4);
        s.first_days = st.column_double(5);
        s.last_days = st.column_double(6);
        s.s_w = st.column_double(7);
        s.s_wt = st.column_double(8);
        s.s_wtt = st.column_double(9);
        s.s_wy = st.column_double(10);
        s.s_wty = st.column_double(11);
        s.s_wyy = st.column_double(12);
        s.n_cycles = st.column_int(13);
        s.first_cycles = optional_double(st, 14);
        s.last_cycles = optional_double(st, 15);
        s.c_w = st.column_double(16);
        s.c_wt = st.column_double(17);
        s.c_wtt = st.column_double(18);
        s.c_wy = st.column_double(19);
        s.c_wty = st.column_double(20);
        s.c_wyy = st.column_double(21);
        s.last_session_id = st.column_int(22);
        s.last_value = st.column_double(23);
        s.last_std_error = st.column_double(24);
        s.limit_kind = st.column_text(25);
        s.limit_value = optional_double(st, 26);
        out.push_back(std::move(s));
    }
    return out;
}

ChainCheck verify_tail(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    ChainCheck out;
    out.tail_number = tail_number;
    std::vector<std::int64_t> ids;
    {
        Statement st(db, "SELECT session_id FROM test_sessions WHERE tail_number = ? ORDER BY session_id");
        st.bind(1, tail_number);
        while (st.step()) ids.push_back(st.column_int(0));
    }
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
