// emadiag sync: a station's sessions to the fleet server, whole sessions per transaction.
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/utc_now.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <charconv>
#include <ctime>
#include <deque>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <tuple>
#include <unordered_map>

namespace emadiag::db {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kRawChunkBytes = 1 << 20;  // raw log chunk: at most 1 MiB on either side
constexpr std::int64_t kRecoverPage = 50000;
constexpr int kReaderCacheKiB = 16 * 1024;  // the reader thread's SQLite page cache

std::string d2s(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, static_cast<std::size_t>(r.ptr - buf));
}
std::string opt_d(const std::optional<double>& v) { return v ? d2s(*v) : "\\N"; }
std::string opt_i(const std::optional<std::int64_t>& v) { return v ? std::to_string(*v) : "\\N"; }
std::string f(const std::string& s) { return copy_field(s); }
std::string f(const std::optional<std::string>& s) { return copy_field(s); }
std::int64_t to_i64(const std::string& s) { return static_cast<std::int64_t>(std::stoll(s)); }

std::string now_iso() { return io::utc_now_iso8601(); }

/// One element of a PostgreSQL array literal: quoted, with '"' and '\\' escaped.
std::string array_element(const std::string& s) {
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') out += '\\';
        out += c;
    }
    return out + '"';
}

// The station's utc_days (maintenance_db/src/session_summaries.cpp), for the summary terms.
std::int64_t days_from_civil(int y, unsigned m, unsigned d) {
    y -= m <= 2 ? 1 : 0;
    const int era = (y >= 0 ? y : y - 399) / 400;
    const unsigned yoe = static_cast<unsigned>(y - era * 400);
    const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return static_cast<std::int64_t>(era) * 146097 + static_cast<std::int64_t>(doe) - 719468;
}
double utc_days(const std::string& iso) {
    const auto n = [&](std::size_t at, std::size_t len) { return std::stoi(iso.substr(at, len)); };
    return static_cast<double>(days_from_civil(n(0, 4), static_cast<unsigned>(n(5, 2)), static_cast<unsigned>(n(8, 2)))) +
           (n(11, 2) * 3600.0 + n(14, 2) * 60.0 + n(17, 2)) / 86400.0;
}

/// A session's global identity as a UUID: SHA-256 of station UUID and local id, version 8 (custom).
std::string session_uuid(const std::string& station_uuid, std::int64_t local_id) {
    std::string h = sha256_hex("emadiag-session-uuid:" + station_uuid + ":" + std::to_string(local_id)).substr(0, 32);
    h[12] = '8';
    h[16] = "89ab"[std::stoi(h.substr(16, 1), nullptr, 16) % 4];
    return h.substr(0, 8) + "-" + h.substr(8, 4) + "-" + h.substr(12, 4) + "-" + h.substr(16, 4) + "-" + h.substr(20, 12);
}

bool retryable(const DbError& e) {
    const std::string m = e.what();
    return m.find("SQLSTATE 40P01") != std::string::npos || m.find("SQLSTATE 40001") != std::string::npos ||
           m.find("SQLSTATE 23505") != std::string::npos;
}

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

std::optional<std::string> col_opt_text(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_text(c)); }
std::optional<double> col_opt_d(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_double(c)); }
std::optional<std::int64_t> col_opt_i(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_int(c)); }

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

/// A batch of whole sessions as read from the station: the rows of the server's COPY statements as
/// text, all but the fleet's ids, which the sender puts in once it has reserved them. Samples, raw
/// logs and estimates are not in it: the sender streams them from the station file.
struct PreparedBatch {
    struct LocalRun {
        std::int64_t run_id, session_id;
        std::string line;
        std::int64_t raw_bytes;
    };
    struct SessionLine {
        std::size_t index;  ///< into ids
        std::string rest;   ///< the columns after session_id, up to amends_session_id
        std::optional<std::int64_t> amends;
    };
    struct IndexedLine {
        std::size_t index;  ///< into ids
        std::string rest;   ///< the columns after session_id
    };
    struct SessionRow {
        std::int64_t session_id;  ///< the station's
        std::string rest;         ///< the other columns (after session_id for artifacts, before it for installations)
    };
    struct TermLine {
        std::int64_t session_id;  ///< the station's
        int ordinal, sign;
        std::int64_t of_session_id;  ///< the station's
        std::string rest;            ///< the columns after of_session_id
    };
    std::vector<std::int64_t> ids;  ///< the station's session ids, ascending; empty: nothing left
    std::int64_t lo = 0, hi = 0;
    std::set<std::string> tails;
    std::map<std::string, std::pair<std::string, std::string>> positions;
    std::vector<SessionLine> sessions;  ///< grouped by tail
    std::vector<LocalRun> runs;
    std::vector<IndexedLine> findings;  ///< grouped by tail
    std::vector<SessionRow> artifacts, installations;
    std::vector<TermLine> terms;  ///< in the order the server's summary statement sorts them
};

/// A second connection to the station file, for the reader thread; none for a database without a
/// file (":memory:"), which is then read on the sender's thread.
std::unique_ptr<Database> open_reader(const Database& station) {
    const std::string& path = station.path();
    if (path.empty() || path == ":memory:") return nullptr;
    auto reader = std::make_unique<Database>(path, station.busy_timeout_ms(), false);  // the caller's connection checked the file
    // It reads each page once, in order: no need for the cache a writing connection keeps (256 MiB),
    // which would double the sync's memory.
    reader->exec("PRAGMA cache_size = -" + std::to_string(kReaderCacheKiB));
    return reader;
}

class Syncer {
public:
    Syncer(Database& station, const std::string& uri, const SyncOptions& o)
        : db_(station), reader_(open_reader(station)), pg_(uri), server_(uri), o_(o) {}

    SyncResult run() {
        const auto t0 = Clock::now();
        {
            Statement st(db_, "SELECT station_uuid FROM station_identity");
            if (!st.step()) throw DbError("station database " + db_.path() + " has no station identity", DbErrorKind::Invalid);
            res_.station_uuid = st.column_text(0);
        }
        const auto v = pg_.query("SELECT to_regclass('fleet_schema_version') IS NOT NULL");
        if (v.at(0).at(0) != std::optional<std::string>("t"))
            throw DbError("fleet server " + server_ + " has no emadiag schema (run `emadiag fleet-server --to URI` as its owner first)",
                          DbErrorKind::Invalid);
        server_version_ = std::stoi(pg_.query("SELECT coalesce(max(version), 0) FROM fleet_schema_version").at(0).at(0).value_or("0"));
        pg_.query("INSERT INTO stations(station_uuid) VALUES ($1) ON CONFLICT DO NOTHING", {res_.station_uuid});
        const auto who = pg_.query("SELECT station_role, current_user FROM stations WHERE station_uuid = $1", {res_.station_uuid});
        if (who.empty() || who[0][0] != who[0][1])
            throw DbError("station " + res_.station_uuid + " (" + db_.path() + ") syncs to " + server_ + " as role " +
                              (who.empty() ? std::string("?") : who[0][0].value_or("?")) + "; this connection is role " +
                              (who.empty() ? std::string("?") : who[0][1].value_or("?")),
                          DbErrorKind::Invalid);
        for (int attempt = 0;; ++attempt) {
            try {
                recover_sessions();
                push_sessions();
                recover_findings();
                push_findings();
                break;
            } catch (const DbError& e) {
                try {
                    pg_.exec("ROLLBACK");
                } catch (...) {
                }
                if (!retryable(e) || attempt >= o_.max_retries) throw;
                ++res_.retries;
                progress(std::string("retrying after: ") + e.what());
            }
        }
        res_.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        return res_;
    }

private:
    std::int64_t local_max(const char* table, const char* col) {
        Statement st(db_, std::string("SELECT coalesce(max(") + col + "), 0) FROM " + table + " WHERE server = ?");
        st.bind(1, server_);
        st.step();
        return st.column_int(0);
    }

    /// Records the sessions the server already has (a sync killed after the server committed).
    void recover_sessions() {
        for (;;) {
            const std::int64_t have = local_max("synced_sessions", "session_id");
            const auto rows = pg_.query("SELECT station_session_id, session_id, content_sha256 FROM test_sessions WHERE station_uuid = $1 "
                                        "AND station_session_id > $2 ORDER BY station_session_id LIMIT " + std::to_string(kRecoverPage),
                                        {res_.station_uuid, std::to_string(have)});
            if (rows.empty()) return;
            Transaction tx(db_);
            Statement& local = db_.cached("SELECT content_sha256 FROM test_sessions WHERE session_id = ?");
            Statement& rec = db_.cached("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES (?,?,?,?)");
            const std::string now = now_iso();
            for (const auto& r : rows) {
                const std::int64_t id = to_i64(*r[0]);
                local.reset();
                local.bind(1, id);
                if (!local.step() || local.column_text(0) != *r[2])
                    throw DbError("station session " + std::to_string(id) + " of " + db_.path() + " differs from the copy on " + server_ +
                                      " (fleet session " + *r[1] + "): the station file is not the one that was synced",
                                  DbErrorKind::Invalid);
                local.reset();
                rec.reset();
                rec.bind(1, server_).bind(2, id).bind(3, to_i64(*r[1])).bind(4, now).run();
                ++res_.sessions_recovered;
            }
            tx.commit();
        }
    }

    std::int64_t fleet_session_of(std::int64_t local) {
        Statement& st = db_.cached("SELECT fleet_session_id FROM synced_sessions WHERE server = ? AND session_id = ?");
        st.bind(1, server_).bind(2, local);
        if (!st.step()) throw DbError("station session " + std::to_string(local) + " is not synced yet", DbErrorKind::Invalid);
        const std::int64_t id = st.column_int(0);
        st.reset();
        return id;
    }

    std::vector<std::int64_t> reserve(const std::string& table, const std::string& col, std::size_t n) {
        std::vector<std::int64_t> ids;
        if (n == 0) return ids;
        // The sequence named once, as a literal the parser turns into its OID: pg_get_serial_sequence
        // in the statement was evaluated for every id (1.7 s of the server's 33 s for 240,000 sessions).
        auto& nextval = nextval_sql_[table + "." + col];
        if (nextval.empty()) {
            const auto seq = pg_.query("SELECT quote_literal(pg_get_serial_sequence($1, $2))", {table, col});
            if (seq.empty() || !seq[0][0])
                throw DbError("fleet server " + server_ + ": " + table + "." + col + " has no sequence", DbErrorKind::Invalid);
            nextval = "SELECT nextval(" + *seq[0][0] + "::regclass) FROM generate_series(1, $1)";
        }
        for (const auto& r : pg_.query(nextval, {std::to_string(n)})) ids.push_back(to_i64(*r[0]));
        std::sort(ids.begin(), ids.end());
        return ids;
    }

    /// The batch's tails and positions on the server (three statements, whatever their number).
    void register_places(const std::set<std::string>& tails, const std::map<std::string, std::pair<std::string, std::string>>& positions) {
        if (!tails.empty()) {
            std::string a;
            for (const auto& t : tails) {
                if (!a.empty()) a += ',';
                a += array_element(t);
            }
            pg_.query("INSERT INTO aircraft(tail_number) SELECT unnest($1::text[]) ON CONFLICT DO NOTHING", {"{" + a + "}"});
        }
        if (positions.empty()) return;
        std::string p, ata, desc;
        for (const auto& [name, ad] : positions) {
            for (auto [list, element] : {std::pair{&p, &name}, std::pair{&ata, &ad.first}, std::pair{&desc, &ad.second}}) {
                if (!list->empty()) *list += ',';
                *list += array_element(*element);
            }
        }
        pg_.query("INSERT INTO positions(position, ata_reference, description) SELECT * FROM unnest($1::text[], $2::text[], $3::text[]) "
                  "ON CONFLICT DO NOTHING",
                  {"{" + p + "}", "{" + ata + "}", "{" + desc + "}"});
        for (const auto& r : pg_.query("SELECT position, ata_reference FROM positions WHERE position = ANY($1::text[])", {"{" + p + "}"})) {
            const auto& [want_ata, want_desc] = positions.at(*r[0]);
            if (r[1] != want_ata)
                throw DbError("position " + *r[0] + " is recorded on " + server_ + " with ATA reference " + r[1].value_or("?") + ", in " +
                                  db_.path() + " with " + want_ata + ": a position keeps its ATA reference",
                              DbErrorKind::Invalid);
        }
    }

    /// Reads the batch of sessions after `after` from the station (at most batch_sessions of them;
    /// no sessions when none is left) with everything the server's transaction needs but the fleet's
    /// ids. Runs on the reader thread with its own connection, while the sender pushes the batch
    /// before it; it holds station_gate_, so the sender's record of a batch waits for it.
    PreparedBatch read_batch(Database& db, std::int64_t after) {
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

    /// A line to the caller's progress callback, from either thread (one at a time).
    void progress(const std::string& line) {
        if (!o_.progress) return;
        const std::lock_guard<std::mutex> lock(progress_mutex_);
        o_.progress(line);
    }

    /// The batch after `after`, read on the reader thread (or, for a station without a file of its
    /// own, on this one when asked for).
    std::future<PreparedBatch> read_ahead(std::int64_t after) {
        if (reader_) return std::async(std::launch::async, [this, after] { return read_batch(*reader_, after); });
        return std::async(std::launch::deferred, [this, after] { return read_batch(db_, after); });
    }

    /// Pushes every session after the station's record, a batch per transaction: while the server
    /// inserts one batch, the reader thread reads the next from the station file (the two used to
    /// take turns: the server waited while the station was read, the station while the server wrote).
    void push_sessions() {
        std::future<PreparedBatch> next = read_ahead(local_max("synced_sessions", "session_id"));
        for (;;) {
            PreparedBatch b = next.get();
            if (b.ids.empty()) return;
            next = read_ahead(b.hi);
            push_batch(b);
        }
    }

    /// One batch of whole sessions in one transaction, then its record on the station.
    void push_batch(const PreparedBatch& b) {
        const auto& ids = b.ids;
        const std::int64_t lo = b.lo, hi = b.hi;
        const auto& runs = b.runs;
        std::vector<std::int64_t> sids;
        std::int64_t samples = 0, raw_bytes = 0;
        try {
            pg_.exec("BEGIN");
            register_places(b.tails, b.positions);
            sids = reserve("test_sessions", "session_id", ids.size());
            const auto rids = reserve("runs", "run_id", runs.size());
            std::unordered_map<std::int64_t, std::int64_t> batch_ids, run_ids;
            for (std::size_t i = 0; i < ids.size(); ++i) batch_ids[ids[i]] = sids[i];
            for (std::size_t i = 0; i < runs.size(); ++i) run_ids[runs[i].run_id] = rids[i];
            const auto fleet = [&](std::int64_t local) {
                const auto it = batch_ids.find(local);
                return it != batch_ids.end() ? it->second : fleet_session_of(local);
            };
            pg_.copy_in("test_sessions (session_id, session_uuid, station_uuid, station_session_id, tail_number, position, actuator_serial, "
                        "phase, started_utc, cycles, hours_h, operator_id, technician_name, technician_certificate, work_performed, source, "
                        "tool_version, verdict, verdict_note, limits_json, limits_sha256, correction_reason, prev_sha256, content_sha256, "
                        "amends_session_id)",
                        [&](const auto& put) {
                            std::string line;
                            for (const auto& s : b.sessions) {
                                line = std::to_string(sids[s.index]);
                                line += s.rest;
                                line += s.amends ? std::to_string(fleet(*s.amends)) : "\\N";
                                line += '\n';
                                put(line);
                            }
                        });
            if (!runs.empty()) {
                pg_.copy_in("runs (run_id, session_id, tail_number, actuator_serial, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, "
                            "tau, sample_period_s, valid, status_note, meta_json, raw_log_format, raw_log_bytes)",
                            [&](const auto& put) {
                                for (const auto& r : runs) put(std::to_string(run_ids.at(r.run_id)) + '\t' + std::to_string(batch_ids.at(r.session_id)) + '\t' + r.line + '\n');
                            });
                pg_.copy_in("estimates (run_id, estimator, parameter, value, std_error, identifiable, method, note)", [&](const auto& put) {
                    Statement st(db_, "SELECT e.run_id, e.estimator, e.parameter, e.value, e.std_error, e.identifiable, e.method, e.note FROM estimates e "
                                      "JOIN runs r ON r.run_id = e.run_id WHERE r.session_id BETWEEN ? AND ?");
                    st.bind(1, lo).bind(2, hi);
                    while (st.step())
                        put(std::to_string(run_ids.at(st.column_int(0))) + '\t' + f(st.column_text(1)) + '\t' + f(st.column_text(2)) + '\t' +
                            opt_d(col_opt_d(st, 3)) + '\t' + d2s(st.column_double(4)) + '\t' + (st.column_int(5) != 0 ? "t" : "f") + '\t' +
                            f(st.column_text(6)) + '\t' + f(st.column_text(7)) + '\n');
                });
                // Samples streamed from the station file: never all in memory.
                pg_.copy_in("samples (run_id, sample_index, t_s, current_a, speed_rad_s, theta_m_rad, hinge_moment_nm, command_deg)",
                            [&](const auto& put) {
                                Statement st(db_, "SELECT x.run_id, x.sample_index, x.t_s, x.current_a, x.speed_rad_s, x.theta_m_rad, "
                                                  "x.hinge_moment_nm, x.command_deg FROM samples x JOIN runs r ON r.run_id = x.run_id "
                                                  "WHERE r.session_id BETWEEN ? AND ?");
                                st.bind(1, lo).bind(2, hi);
                                std::string line;
                                while (st.step()) {
                                    line = std::to_string(run_ids.at(st.column_int(0))) + '\t' + std::to_string(st.column_int(1));
                                    for (int c = 2; c < 8; ++c) line += '\t' + d2s(st.column_double(c));
                                    line += '\n';
                                    put(line);
                                    ++samples;
                                }
                            });
                // Raw logs streamed in chunks straight from the SQLite blob.
                pg_.copy_in("raw_log_chunks (run_id, chunk_index, content)", [&](const auto& put) {
                    std::string chunk, line;
                    static const char* hex = "0123456789abcdef";
                    for (const auto& r : runs) {
                        if (r.raw_bytes == 0) continue;
                        sqlite3_blob* blob = nullptr;
                        if (sqlite3_blob_open(db_.handle(), "main", "raw_logs", "content", r.run_id, 0, &blob) != SQLITE_OK)
                            throw DbError("cannot read the raw log of run " + std::to_string(r.run_id) + ": " + db_.error_text());
                        const int total = sqlite3_blob_bytes(blob);
                        int chunk_index = 0;
                        for (int at = 0; at < total; at += static_cast<int>(kRawChunkBytes), ++chunk_index) {
                            const int n = std::min(total - at, static_cast<int>(kRawChunkBytes));
                            chunk.resize(static_cast<std::size_t>(n));
                            if (sqlite3_blob_read(blob, chunk.data(), n, at) != SQLITE_OK) {
                                sqlite3_blob_close(blob);
                                throw DbError("cannot read the raw log of run " + std::to_string(r.run_id) + ": " + db_.error_text());
                            }
                            line = std::to_string(run_ids.at(r.run_id)) + '\t' + std::to_string(chunk_index) + "\t\\\\x";
                            line.reserve(line.size() + 2 * chunk.size() + 1);
                            for (unsigned char c : chunk) {
                                line += hex[c >> 4];
                                line += hex[c & 15];
                            }
                            line += '\n';
                            put(line);
                        }
                        sqlite3_blob_close(blob);
                        raw_bytes += total;
                    }
                });
            }
            pg_.copy_in(std::string("findings (session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note") +
                            (server_version_ >= 3 ? ", tail_number)" : ")"),
                        [&](const auto& put) {
                            std::string line;
                            for (const auto& x : b.findings) {
                                line = std::to_string(sids[x.index]);
                                line += x.rest;
                                put(line);
                            }
                        });
            pg_.copy_in("session_artifacts (session_id, role, name, sha256)", [&](const auto& put) {
                for (const auto& a : b.artifacts) put(std::to_string(batch_ids.at(a.session_id)) + a.rest);
            });
            pg_.copy_in("installations (tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id)", [&](const auto& put) {
                for (const auto& i : b.installations) put(i.rest + std::to_string(batch_ids.at(i.session_id)) + '\n');
            });
            pg_.copy_in("session_measurements (session_id, ordinal, sign, of_session_id, tail_number, position, actuator_serial, parameter, days, "
                        "w, wy, wyy, cycles, value, std_error, limit_kind, limit_value)",
                        [&](const auto& put) {
                            std::string line;
                            for (const auto& t : b.terms) {
                                line = std::to_string(batch_ids.at(t.session_id));
                                line += '\t';
                                line += std::to_string(t.ordinal);
                                line += '\t';
                                line += std::to_string(t.sign);
                                line += '\t';
                                line += std::to_string(fleet(t.of_session_id));
                                line += t.rest;
                                put(line);
                            }
                        });
            pg_.exec("COMMIT");
        } catch (const DbError& e) {
            std::string m = e.what();
            if (m.rfind("[maintenance_db] ", 0) == 0) m = m.substr(17);
            throw DbError("sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " of " + db_.path() + ": " + m, e.kind());
        }
        // Only now is the batch on the server: record it on the station (once the reader thread has
        // read the next batch: the station file takes one writer and no readers at a time).
        {
            const std::lock_guard<std::mutex> gate(station_gate_);
            Transaction tx(db_);
            Statement& rec = db_.cached("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES (?,?,?,?)");
            const std::string now = now_iso();
            for (std::size_t i = 0; i < ids.size(); ++i) {
                rec.reset();
                rec.bind(1, server_).bind(2, ids[i]).bind(3, sids[i]).bind(4, now).run();
            }
            tx.commit();
        }
        res_.sessions_pushed += static_cast<std::int64_t>(ids.size());
        res_.runs += static_cast<std::int64_t>(runs.size());
        res_.samples += samples;
        res_.raw_log_bytes += raw_bytes;
        ++res_.batches;
        progress("sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " -> fleet sessions " + std::to_string(sids.front()) + ".." +
                 std::to_string(sids.back()) + " committed");
    }

    void recover_findings() {
        const std::int64_t have = local_max("synced_discovery_findings", "finding_id");
        const auto rows = pg_.query("SELECT station_finding_id, finding_id FROM discovery_findings WHERE station_uuid = $1 AND "
                                    "station_finding_id > $2 ORDER BY station_finding_id",
                                    {res_.station_uuid, std::to_string(have)});
        if (rows.empty()) return;
        Transaction tx(db_);
        Statement& rec = db_.cached("INSERT INTO synced_discovery_findings(server, finding_id, fleet_finding_id, synced_utc) VALUES (?,?,?,?)");
        for (const auto& r : rows) {
            rec.reset();
            rec.bind(1, server_).bind(2, to_i64(*r[0])).bind(3, to_i64(*r[1])).bind(4, now_iso()).run();
        }
        tx.commit();
    }

    void push_findings() {
        const std::int64_t after = local_max("synced_discovery_findings", "finding_id");
        std::vector<StoredDiscoveryFinding> list;
        std::vector<std::int64_t> local_ids;
        std::set<std::string> tails;
        std::map<std::string, std::pair<std::string, std::string>> positions;
        {
            Statement st(db_, "SELECT d.finding_id, d.tail_number, d.position, coalesce(p.ata_reference, ''), coalesce(p.description, ''), "
                              "d.actuator_serial, d.found_utc, d.summary, d.model_json, d.status, d.amends_finding_id, d.tool_version, "
                              "d.content_sha256 FROM discovery_findings d LEFT JOIN positions p ON p.position = d.position "
                              "WHERE d.finding_id > ? ORDER BY d.finding_id");
            st.bind(1, after);
            while (st.step()) {
                StoredDiscoveryFinding x;
                x.finding_id = st.column_int(0);
                x.tail_number = st.column_text(1);
                x.position = col_opt_text(st, 2);
                x.actuator_serial = st.column_text(5);
                x.found_utc = st.column_text(6);
                x.summary = st.column_text(7);
                x.model_json = st.column_text(8);
                x.status = st.column_text(9);
                x.amends_finding_id = col_opt_i(st, 10);
                x.tool_version = st.column_text(11);
                x.content_sha256 = st.column_text(12);
                tails.insert(x.tail_number);
                if (x.position) positions[*x.position] = {st.column_text(3), st.column_text(4)};
                list.push_back(std::move(x));
            }
        }
        if (list.empty()) return;
        pg_.exec("BEGIN");
        register_places(tails, positions);
        const auto fids = reserve("discovery_findings", "finding_id", list.size());
        std::unordered_map<std::int64_t, std::int64_t> map;
        for (std::size_t i = 0; i < list.size(); ++i) map[list[i].finding_id] = fids[i];
        const auto fleet = [&](std::int64_t local) -> std::int64_t {
            if (auto it = map.find(local); it != map.end()) return it->second;
            Statement st(db_, "SELECT fleet_finding_id FROM synced_discovery_findings WHERE server = ? AND finding_id = ?");
            st.bind(1, server_).bind(2, local);
            if (!st.step()) throw DbError("discovery finding " + std::to_string(local) + " is not synced yet", DbErrorKind::Invalid);
            return st.column_int(0);
        };
        pg_.copy_in("discovery_findings (finding_id, station_uuid, station_finding_id, tail_number, position, actuator_serial, found_utc, "
                    "summary, model_json, status, amends_finding_id, tool_version, content_sha256)",
                    [&](const auto& put) {
                        for (const auto& x : list)
                            put(std::to_string(map.at(x.finding_id)) + '\t' + res_.station_uuid + '\t' + std::to_string(x.finding_id) + '\t' +
                                f(x.tail_number) + '\t' + f(x.position) + '\t' + f(x.actuator_serial) + '\t' + f(x.found_utc) + '\t' +
                                f(x.summary) + '\t' + f(x.model_json) + '\t' + f(x.status) + '\t' +
                                (x.amends_finding_id ? std::to_string(fleet(*x.amends_finding_id)) : "\\N") + '\t' + f(x.tool_version) +
                                '\t' + f(x.content_sha256) + '\n');
                    });
        pg_.exec("COMMIT");
        Transaction tx(db_);
        Statement& rec = db_.cached("INSERT INTO synced_discovery_findings(server, finding_id, fleet_finding_id, synced_utc) VALUES (?,?,?,?)");
        for (const auto& x : list) {
            rec.reset();
            rec.bind(1, server_).bind(2, x.finding_id).bind(3, map.at(x.finding_id)).bind(4, now_iso()).run();
        }
        tx.commit();
        res_.discovery_findings += static_cast<std::int64_t>(list.size());
    }

    Database& db_;
    std::unique_ptr<Database> reader_;  ///< the reader thread's connection to the station file
    std::mutex station_gate_;           ///< held while a batch is read from the station, and while one is recorded in it
    std::mutex progress_mutex_;
    std::map<std::string, std::string> nextval_sql_;  ///< per table.column: the statement that reserves its ids
    PgConnection pg_;
    std::string server_;
    SyncOptions o_;
    SyncResult res_;
    int server_version_ = 0;  ///< the fleet server's schema version (fleet_schema_version)
};

}  // namespace

SyncResult sync_to_fleet(Database& station, const std::string& uri, const SyncOptions& options) {
    if (options.batch_sessions == 0) throw DbError("sync: a batch holds at least one session", DbErrorKind::Invalid);
    Syncer s(station, uri, options);
    return s.run();
}

}  // namespace emadiag::db
