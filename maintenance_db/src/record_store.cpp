#include "emadiag/db/record_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "run_store_detail.hpp"

#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <sstream>
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

/// The chain_heads row of a tail: sessions and their head, discovery findings and their head.
struct HeadRow {
    std::int64_t session_id = 0, sessions = 0, discovery_findings = 0;
    std::string content_sha256, discovery_head_sha256;
};
std::optional<HeadRow> head_row(Database& db, const std::string& tail_number) {
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

/// Checks a tail's discovery findings: each one's content hash, and their chain against the head
/// recorded in chain_heads. Adds problems to `out`; returns the recomputed links (oldest first).
std::vector<std::string> check_discovery_chain(Database& db, const std::string& tail_number, const std::optional<HeadRow>& head,
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

/// The installations the sessions of a tail imply, in the order the store records them: a session
/// at a position that shows a serial other than the one installed there (the serial of the
/// position's newest session so far, by started_utc; position_status). The rule of insert_session
/// and add_to_summaries (session_summaries.cpp), replayed over the sessions in session_id order.
std::vector<StoredInstallation> installations_implied(const std::vector<StoredTestSession>& sessions) {
    struct Installed {
        std::string serial, last_utc;
    };
    std::map<std::string, Installed> at;
    std::vector<StoredInstallation> out;
    for (const auto& s : sessions) {
        const std::string position = s.position.value_or("");
        auto it = at.find(position);
        if (s.position && !s.actuator_serial.empty() && (it == at.end() || it->second.serial != s.actuator_serial)) {
            StoredInstallation i;
            i.tail_number = s.tail_number;
            i.position = position;
            i.from_serial = it == at.end() ? "" : it->second.serial;
            i.to_serial = s.actuator_serial;
            i.detected_utc = s.started_utc;
            i.cycles = s.cycles;
            i.hours_h = s.hours_h;
            i.session_id = s.session_id;
            out.push_back(i);
        }
        if (it == at.end()) {
            at.emplace(position, Installed{s.actuator_serial, s.started_utc});
        } else if (s.started_utc >= it->second.last_utc) {
            it->second = Installed{s.actuator_serial, s.started_utc};
        }
    }
    return out;
}

std::string describe(const StoredInstallation& i) {
    const auto opt = [](const auto& v) { return v ? std::to_string(*v) : std::string("-"); };
    return i.position + " " + (i.from_serial.empty() ? "(none)" : i.from_serial) + " -> " + i.to_serial + " at " + i.detected_utc + ", session " +
           std::to_string(i.session_id) + ", cycles " + opt(i.cycles) + ", hours " + opt(i.hours_h);
}

bool same(const StoredInstallation& a, const StoredInstallation& b) {
    return a.tail_number == b.tail_number && a.position == b.position && a.from_serial == b.from_serial && a.to_serial == b.to_serial &&
           a.detected_utc == b.detected_utc && a.cycles == b.cycles && a.hours_h == b.hours_h && a.session_id == b.session_id;
}

std::string station_uuid(Database& db) {
    Statement st(db, "SELECT station_uuid FROM station_identity LIMIT 1");
    return st.step() ? st.column_text(0) : std::string("-");
}

/// One line of the anchor file (docs/record-format.md, "Anchoring the head").
struct AnchorLine {
    std::size_t line = 0;
    std::string station, tail, head, discovery_head, utc;
    std::int64_t sessions = -1, discovery_findings = -1;
    std::map<std::string, std::string> positions;  ///< position -> digest of its ATA reference and description
};

/// Every position's row as the anchor records it: position -> the first 32 hex digits of
/// SHA-256(ata_reference "\n" description). The report shows both; a position keeps them for good.
std::map<std::string, std::string> position_digests(Database& db) {
    std::map<std::string, std::string> out;
    for (const auto& p : list_positions(db)) out[p.position] = sha256_hex(p.ata_reference + "\n" + p.description).substr(0, 32);
    return out;
}
constexpr std::string_view kAnchorTag = "emadiag-anchor-v1";

std::optional<AnchorLine> parse_anchor_line(const std::string& text, std::size_t line) {
    std::istringstream in(text);
    std::string word;
    if (!(in >> word) || word != kAnchorTag) return std::nullopt;
    AnchorLine a;
    a.line = line;
    while (in >> word) {
        const auto eq = word.find('=');
        if (eq == std::string::npos) return std::nullopt;
        const std::string key = word.substr(0, eq), value = word.substr(eq + 1);
        try {
            if (key == "station") a.station = value;
            else if (key == "tail") a.tail = value;
            else if (key == "sessions") a.sessions = std::stoll(value);
            else if (key == "head") a.head = value == "-" ? "" : value;
            else if (key == "discovery_findings") a.discovery_findings = std::stoll(value);
            else if (key == "discovery_head") a.discovery_head = value == "-" ? "" : value;
            else if (key == "utc") a.utc = value;
            else if (key == "positions") {
                std::istringstream list(value);
                std::string item;
                while (std::getline(list, item, ',')) {
                    const auto slash = item.find('/');
                    if (slash != std::string::npos) a.positions[item.substr(0, slash)] = item.substr(slash + 1);
                }
            }
        } catch (const std::exception&) {
            return std::nullopt;
        }
    }
    if (a.tail.empty() || a.sessions < 0 || a.discovery_findings < 0) return std::nullopt;
    return a;
}

}  // namespace

std::string discovery_chain_link(const std::string& prev_link, const std::string& content_sha256) {
    Sha256 h;
    h.update("emadiag-discovery-chain-v1\n").update(prev_link).update("\n").update(content_sha256).update("\n");
    return h.hex();
}

void detail::append_anchor(Database& db, const std::vector<std::string>& tails) {
    if (db.anchor_path().empty() || tails.empty()) return;
    const std::string station = station_uuid(db);
    const auto now = std::chrono::system_clock::now();
    const std::time_t t = std::chrono::system_clock::to_time_t(now);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char utc[32];
    std::strftime(utc, sizeof utc, "%Y-%m-%dT%H:%M:%SZ", &tm);
    std::string positions;
    for (const auto& [name, digest] : position_digests(db)) positions += (positions.empty() ? "" : ",") + name + "/" + digest;
    std::string text;
    for (const auto& tail : tails) {
        const std::optional<HeadRow> h = head_row(db, tail);
        if (!h) continue;
        text += std::string(kAnchorTag) + " station=" + station + " tail=" + tail + " sessions=" + std::to_string(h->sessions) +
                " head=" + (h->content_sha256.empty() ? "-" : h->content_sha256) + " discovery_findings=" + std::to_string(h->discovery_findings) +
                " discovery_head=" + (h->discovery_head_sha256.empty() ? "-" : h->discovery_head_sha256) +
                (positions.empty() ? "" : " positions=" + positions) + " utc=" + utc + "\n";
    }
    if (text.empty()) return;
    const auto fail = [&](int err) {
        throw DbError("database " + db.path() + ": stored, but its anchor file " + db.anchor_path() + " could not be appended to: " +
                      std::strerror(err) + " (emadiag verify compares the chain heads with it)");
    };
    // O_APPEND: each line lands whole after the others, whatever other process appends at once.
    const int fd = ::open(db.anchor_path().c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) fail(errno);
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int e = n < 0 ? errno : EIO;
            ::close(fd);
            fail(e);
        }
        done += static_cast<std::size_t>(n);
    }
    if (::fsync(fd) != 0) {
        const int e = errno;
        ::close(fd);
        fail(e);
    }
    if (::close(fd) != 0) fail(errno);
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

ChainCheck verify_tail(Database& db, const std::string& tail_number) { return verify_tail(db, tail_number, true); }

ChainCheck verify_tail(Database& db, const std::string& tail_number, bool compare_anchor) {
    check_tail_number(tail_number);
    ChainCheck out;
    out.tail_number = tail_number;
    // The anchor first, then the database in one read transaction: a store appends to the anchor
    // after its commit, so every line read here is of a state the snapshot below includes (another
    // process may commit in between: never a false "removed").
    std::vector<AnchorLine> anchor;
    std::size_t unreadable = 0;
    const bool anchor_given = compare_anchor && !db.anchor_path().empty();
    bool anchor_found = false;
    if (anchor_given) {
        std::ifstream in(db.anchor_path());
        anchor_found = static_cast<bool>(in);
        std::string text;
        std::size_t line = 0;
        while (anchor_found && std::getline(in, text)) {
            ++line;
            if (const auto a = parse_anchor_line(text, line)) {
                if (a->tail == tail_number) anchor.push_back(*a);
            } else {
                ++unreadable;
            }
        }
    }
    const bool own_transaction = sqlite3_get_autocommit(db.handle()) != 0;
    if (own_transaction) db.exec("BEGIN");
    struct EndRead {
        Database& db;
        bool active;
        ~EndRead() {
            if (active) sqlite3_exec(db.handle(), "COMMIT", nullptr, nullptr, nullptr);  // a read: nothing to lose, never throws
        }
    } end_read{db, own_transaction};
    Statement of_tail(db, "SELECT session_id FROM test_sessions WHERE tail_number = ? ORDER BY session_id");
    of_tail.bind(1, tail_number);
    const std::vector<std::int64_t> ids = collect(of_tail, [](Columns& c) { return c.integer(); });
    std::string prev;
    std::vector<std::string> session_hashes;  // in chain order, for the anchor
    std::vector<StoredTestSession> light;     // the fields the installations derive from
    for (const auto id : ids) {
        StoredTestSession s = load_test_session(db, id);
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
        session_hashes.push_back(prev);
        ++out.sessions_checked;
        s.runs.clear();
        s.findings.clear();
        s.artifacts.clear();
        light.push_back(std::move(s));
    }
    out.head_sha256 = prev;
    const std::optional<HeadRow> head = head_row(db, tail_number);
    if (head) {
        if (head->content_sha256 != prev || head->sessions != static_cast<std::int64_t>(ids.size()))
            out.problems.push_back("the chain head records " + std::to_string(head->sessions) + " sessions ending at session " +
                                   std::to_string(head->session_id) + " (" + head->content_sha256.substr(0, 16) + "...), the tail has " +
                                   std::to_string(ids.size()) + (ids.empty() ? "" : " ending at session " + std::to_string(ids.back())) +
                                   ": sessions were removed or added outside the tool");
    } else if (!ids.empty()) {
        out.problems.push_back("the tail has " + std::to_string(ids.size()) + " sessions but no chain head: the record was changed outside the tool");
    }

    // Discovery findings: each one's hash, and their chain against its head.
    const std::vector<std::string> links = check_discovery_chain(db, tail_number, head, out.problems);
    out.discovery_findings_checked = static_cast<std::int64_t>(links.size());
    out.discovery_head_sha256 = links.empty() ? "" : links.back();

    // Installations: derived from the sessions (which the chain covers), so recomputed and compared.
    const std::vector<StoredInstallation> implied = installations_implied(light);
    const std::vector<StoredInstallation> stored = list_installations(db, tail_number);
    out.installations_checked = static_cast<std::int64_t>(stored.size());
    for (std::size_t i = 0; i < std::max(implied.size(), stored.size()); ++i) {
        if (i < implied.size() && i < stored.size()) {
            if (!same(implied[i], stored[i]))
                out.problems.push_back("installation " + std::to_string(stored[i].installation_id) + " reads " + describe(stored[i]) +
                                       "; the sessions record " + describe(implied[i]) + ": changed outside the tool");
        } else if (i < stored.size()) {
            out.problems.push_back("installation " + std::to_string(stored[i].installation_id) + " (" + describe(stored[i]) +
                                   ") is shown by no session of the tail: added outside the tool");
        } else {
            out.problems.push_back("session " + std::to_string(implied[i].session_id) + " shows an installation change (" + describe(implied[i]) +
                                   ") that is not in the installations: removed outside the tool");
        }
    }

    // The anchor file: every line this database wrote for the tail must still be a prefix of its chains.
    if (anchor_given && !anchor_found) out.notes.push_back("no anchor file " + db.anchor_path() + " to compare the chain heads with");
    if (anchor_found) {
        out.anchor_path = db.anchor_path();
        const std::string station = station_uuid(db);
        const std::map<std::string, std::string> positions_now = position_digests(db);
        std::map<std::string, std::string> position_problems;  // one problem per position, however many lines show it
        std::size_t other_database = 0;
        for (const AnchorLine& a : anchor) {
            if (a.station != station) {
                ++other_database;
                continue;
            }
            ++out.anchor_lines_checked;
            const std::string at = "the anchor " + db.anchor_path() + " line " + std::to_string(a.line) + " (" + a.utc + ")";
            for (const auto& [position, digest] : a.positions) {
                const auto now = positions_now.find(position);
                if (now == positions_now.end())
                    position_problems.emplace(position, at + " records position " + position + ", which the positions table no longer holds: removed outside the tool");
                else if (now->second != digest)
                    position_problems.emplace(position, at + " records position " + position + " with another ATA reference or description than the positions table holds now: changed outside the tool");
            }
            if (a.sessions > static_cast<std::int64_t>(session_hashes.size())) {
                out.problems.push_back(at + " records " + std::to_string(a.sessions) + " sessions ending at " + a.head.substr(0, 16) +
                                       "..., the database holds " + std::to_string(session_hashes.size()) + ": sessions were removed outside the tool");
            } else if (a.sessions > 0 && session_hashes[static_cast<std::size_t>(a.sessions - 1)] != a.head) {
                out.problems.push_back(at + " records session " + std::to_string(a.sessions) + " of the chain as " + a.head.substr(0, 16) +
                                       "..., the database holds " + session_hashes[static_cast<std::size_t>(a.sessions - 1)].substr(0, 16) +
                                       "...: the chain was rewritten outside the tool");
            }
            if (a.discovery_findings > static_cast<std::int64_t>(links.size())) {
                out.problems.push_back(at + " records " + std::to_string(a.discovery_findings) + " discovery findings, the database holds " +
                                       std::to_string(links.size()) + ": discovery findings were removed outside the tool");
            } else if (a.discovery_findings > 0 && links[static_cast<std::size_t>(a.discovery_findings - 1)] != a.discovery_head) {
                out.problems.push_back(at + " records discovery finding " + std::to_string(a.discovery_findings) + " of the chain as " +
                                       a.discovery_head.substr(0, 16) + "..., the database's differs: rewritten outside the tool");
            }
        }
        for (const auto& [position, problem] : position_problems) out.problems.push_back(problem);
        if (other_database > 0)
            out.notes.push_back(std::to_string(other_database) + " line(s) of " + db.anchor_path() + " for " + tail_number +
                                " name another database (station uuid) and were not compared");
        if (unreadable > 0) out.notes.push_back(std::to_string(unreadable) + " line(s) of " + db.anchor_path() + " are not anchor lines");
        if (out.anchor_lines_checked == 0 && (!ids.empty() || !links.empty()))
            out.notes.push_back("the anchor " + db.anchor_path() + " holds no line of this database for " + tail_number);
    }
    return out;
}

}  // namespace emadiag::db
