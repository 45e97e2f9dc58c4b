#include "emadiag/db/record_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "run_store_detail.hpp"
#include "record_store_detail.hpp"

#include <initializer_list>
#include <utility>

namespace emadiag::db {
using namespace detail;

namespace {
void invalid(const std::string& message) { throw DbError(message, DbErrorKind::Invalid); }

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

/// The columns of a discovery finding with its position's ATA reference and description, as
/// read_discovery_finding reads them (alias d, positions p joined).
constexpr const char* kDiscoveryColumns =
    "d.finding_id, d.tail_number, d.position, p.ata_reference, p.description, d.actuator_serial, d.found_utc, d.summary, d.model_json, "
    "d.status, d.amends_finding_id, d.tool_version, d.content_sha256 FROM discovery_findings d LEFT JOIN positions p ON p.position = d.position";

StoredDiscoveryFinding read_discovery_finding(Columns& c) {
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
}

/// A tail's discovery findings in finding_id order (the chain's order).
std::vector<StoredDiscoveryFinding> discovery_chain_of(Database& db, const std::string& tail_number) {
    Statement st(db, std::string("SELECT ") + kDiscoveryColumns + " WHERE d.tail_number = ? ORDER BY d.finding_id");
    st.bind(1, tail_number);
    return collect(st, read_discovery_finding);
}

}  // namespace

std::optional<HeadRow> detail::head_row(Database& db, const std::string& tail_number) {
    Statement st(db, "SELECT session_id, sessions, content_sha256, discovery_findings, discovery_head_sha256 FROM chain_heads WHERE tail_number = ?");
    st.bind(1, tail_number);
    if (!st.step()) return std::nullopt;
    Columns c(st);
    HeadRow h;
    h.session_id = c.integer();
    h.sessions = c.integer();
    h.content_sha256 = c.text();
    h.discovery_findings = c.integer();
    h.discovery_head_sha256 = c.text();
    return h;
}

std::vector<std::string> detail::check_discovery_chain(Database& db, const std::string& tail_number, const std::optional<HeadRow>& head,
                                               std::vector<std::string>& out) {
    std::vector<std::string> links;
    std::string link;
    for (const auto& f : discovery_chain_of(db, tail_number)) {
        const std::string recomputed = discovery_sha256(f);
        if (recomputed != f.content_sha256)
            out.push_back("discovery finding " + std::to_string(f.finding_id) + " (" + f.found_utc + "): its content differs from its stored hash " +
                          f.content_sha256.substr(0, 16) + "... (recomputed " + recomputed.substr(0, 16) + "...): changed outside the tool");
        link = discovery_chain_link(link, f.content_sha256);
        links.push_back(link);
    }
    const std::int64_t recorded = head ? head->discovery_findings : 0;
    const std::string recorded_head = head ? head->discovery_head_sha256 : "";
    if (recorded != static_cast<std::int64_t>(links.size()) || recorded_head != link)
        out.push_back("the chain head records " + std::to_string(recorded) + " discovery findings" +
                      (recorded_head.empty() ? "" : " ending at " + recorded_head.substr(0, 16) + "...") + ", the tail has " +
                      std::to_string(links.size()) + (link.empty() ? "" : " ending at " + link.substr(0, 16) + "...") +
                      ": discovery findings were removed, added or re-hashed outside the tool");
    return links;
}

std::string discovery_chain_link(const std::string& prev_link, const std::string& content_sha256) {
    Sha256 h;
    h.update("emadiag-discovery-chain-v1\n").update(prev_link).update("\n").update(content_sha256).update("\n");
    return h.hex();
}

void detail::seal_discovery_findings_before_v7(Database& db) {
    std::vector<std::string> tails;
    {
        Statement st(db, "SELECT DISTINCT tail_number FROM discovery_findings ORDER BY tail_number");
        while (st.step()) tails.push_back(st.column_text(0));
    }
    for (const auto& tail : tails) {
        std::string link;
        std::int64_t n = 0;
        for (const auto& f : discovery_chain_of(db, tail)) {
            link = discovery_chain_link(link, f.content_sha256);
            ++n;
        }
        Statement(db, "INSERT INTO chain_heads(tail_number, session_id, sessions, content_sha256, discovery_findings, discovery_head_sha256) "
                      "VALUES (?, 0, 0, '', ?, ?) ON CONFLICT DO UPDATE SET discovery_findings = excluded.discovery_findings, "
                      "discovery_head_sha256 = excluded.discovery_head_sha256")
            .bind(1, tail)
            .bind(2, n)
            .bind(3, link)
            .run();
    }
}

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
    // The tail's discovery findings are chained (their head in chain_heads): nothing is appended to
    // a broken chain.
    std::vector<std::string> problems;
    const std::vector<std::string> links = check_discovery_chain(db, f.tail_number, head_row(db, f.tail_number), problems);
    if (!problems.empty())
        throw DbError("tail " + f.tail_number + ": the chain of its discovery findings is broken (the first problem: " + problems.front() +
                          "); nothing was stored (`emadiag verify --tail " + f.tail_number + "` lists every problem)",
                      DbErrorKind::BrokenChain);
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
    Statement(db, "INSERT INTO chain_heads(tail_number, session_id, sessions, content_sha256, discovery_findings, discovery_head_sha256) "
                  "VALUES (?, 0, 0, '', ?, ?) ON CONFLICT DO UPDATE SET discovery_findings = excluded.discovery_findings, "
                  "discovery_head_sha256 = excluded.discovery_head_sha256")
        .bind(1, f.tail_number)
        .bind(2, static_cast<std::int64_t>(links.size()) + 1)
        .bind(3, discovery_chain_link(links.empty() ? "" : links.back(), f.content_sha256))
        .run();
    tx.commit();
    detail::append_anchor(db, {f.tail_number});
    return id;
}

std::vector<StoredDiscoveryFinding> list_discovery_findings(Database& db, const std::string& tail_number, bool open_only) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT ") + kDiscoveryColumns + " WHERE d.tail_number = ?" +
                         (open_only ? " AND d.status = 'open' AND NOT EXISTS (SELECT 1 FROM discovery_findings a WHERE "
                                      "a.amends_finding_id = d.finding_id)"
                                    : "") +
                         " ORDER BY d.found_utc, d.finding_id");
    st.bind(1, tail_number);
    return collect(st, read_discovery_finding);
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

}  // namespace emadiag::db
