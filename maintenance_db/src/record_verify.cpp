// Verifying a tail's record (verify_tail): its hash chain, its discovery findings' chain, the
// installations recomputed from the sessions, and the anchor file every store appends to
// (append_anchor, docs/record-format.md "Anchoring the head").
#include "emadiag/db/record_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "record_store_detail.hpp"

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
using namespace detail;

namespace {
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
