// emadiag sync: a station's sessions to the fleet server, whole sessions per transaction.
// This file runs it; a batch is read by pg_sync_read.cpp and pushed by pg_sync_push.cpp.
#include "pg_sync_detail.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/utc_now.hpp"

#include <algorithm>
#include <chrono>
#include <charconv>
#include <ctime>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <unordered_map>

namespace emadiag::db {
namespace sync_detail {

using Clock = std::chrono::steady_clock;
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

std::optional<std::string> col_opt_text(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_text(c)); }
std::optional<double> col_opt_d(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_double(c)); }
std::optional<std::int64_t> col_opt_i(Statement& st, int c) { return st.column_is_null(c) ? std::nullopt : std::optional(st.column_int(c)); }

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

SyncResult Syncer::run() {
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

std::int64_t Syncer::local_max(const char* table, const char* col) {
    Statement st(db_, std::string("SELECT coalesce(max(") + col + "), 0) FROM " + table + " WHERE server = ?");
    st.bind(1, server_);
    st.step();
    return st.column_int(0);
}

/// Records the sessions the server already has (a sync killed after the server committed).
void Syncer::recover_sessions() {
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

std::int64_t Syncer::fleet_session_of(std::int64_t local) {
    Statement& st = db_.cached("SELECT fleet_session_id FROM synced_sessions WHERE server = ? AND session_id = ?");
    st.bind(1, server_).bind(2, local);
    if (!st.step()) throw DbError("station session " + std::to_string(local) + " is not synced yet", DbErrorKind::Invalid);
    const std::int64_t id = st.column_int(0);
    st.reset();
    return id;
}

std::vector<std::int64_t> Syncer::reserve(const std::string& table, const std::string& col, std::size_t n) {
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
void Syncer::register_places(const std::set<std::string>& tails, const std::map<std::string, std::pair<std::string, std::string>>& positions) {
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

/// A line to the caller's progress callback, from either thread (one at a time).
void Syncer::progress(const std::string& line) {
    if (!o_.progress) return;
    const std::lock_guard<std::mutex> lock(progress_mutex_);
    o_.progress(line);
}

/// The batch after `after`, read on the reader thread (or, for a station without a file of its
/// own, on this one when asked for).
std::future<PreparedBatch> Syncer::read_ahead(std::int64_t after) {
    if (reader_) return std::async(std::launch::async, [this, after] { return read_batch(*reader_, after); });
    return std::async(std::launch::deferred, [this, after] { return read_batch(db_, after); });
}

/// Pushes every session after the station's record, a batch per transaction: while the server
/// inserts one batch, the reader thread reads the next from the station file (the two used to
/// take turns: the server waited while the station was read, the station while the server wrote).
void Syncer::push_sessions() {
    std::future<PreparedBatch> next = read_ahead(local_max("synced_sessions", "session_id"));
    for (;;) {
        PreparedBatch b = next.get();
        if (b.ids.empty()) return;
        next = read_ahead(b.hi);
        push_batch(b);
    }
}

void Syncer::recover_findings() {
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

void Syncer::push_findings() {
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

}  // namespace sync_detail


SyncResult sync_to_fleet(Database& station, const std::string& uri, const SyncOptions& options) {
    if (options.batch_sessions == 0) throw DbError("sync: a batch holds at least one session", DbErrorKind::Invalid);
    sync_detail::Syncer s(station, uri, options);
    return s.run();
}

}  // namespace emadiag::db
