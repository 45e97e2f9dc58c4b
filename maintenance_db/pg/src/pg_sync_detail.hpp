// emadiag sync (pg_fleet.hpp: sync_to_fleet), shared by its sources: pg_sync.cpp runs it (identity,
// recovery after a killed sync, the discovery findings), pg_sync_read.cpp reads a batch of sessions
// from the station, pg_sync_push.cpp pushes one to the fleet server. Internal to maintenance_db/pg.
#pragma once

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "emadiag/db/record_store.hpp"

#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace emadiag::db::sync_detail {

// The COPY text of one value (pg_sync.cpp).
std::string d2s(double v);
std::string opt_d(const std::optional<double>& v);
std::string opt_i(const std::optional<std::int64_t>& v);
std::string f(const std::string& s);
std::string f(const std::optional<std::string>& s);
std::string now_iso();
double utc_days(const std::string& iso);
/// A session's global identity as a UUID: SHA-256 of station UUID and local id, version 8 (custom).
std::string session_uuid(const std::string& station_uuid, std::int64_t local_id);
std::optional<std::string> col_opt_text(Statement& st, int c);
std::optional<double> col_opt_d(Statement& st, int c);
std::optional<std::int64_t> col_opt_i(Statement& st, int c);

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

/// A second connection to the station file, for the reader thread (pg_sync.cpp).
std::unique_ptr<Database> open_reader(const Database& station);

class Syncer {
public:
    Syncer(Database& station, const std::string& uri, const SyncOptions& o)
        : db_(station), reader_(open_reader(station)), pg_(uri), server_(uri), o_(o) {}

    SyncResult run();

private:
    // pg_sync.cpp
    std::int64_t local_max(const char* table, const char* col);
    void recover_sessions();
    std::int64_t fleet_session_of(std::int64_t local);
    std::vector<std::int64_t> reserve(const std::string& table, const std::string& col, std::size_t n);
    void register_places(const std::set<std::string>& tails, const std::map<std::string, std::pair<std::string, std::string>>& positions);
    // pg_sync_read.cpp
    PreparedBatch read_batch(Database& db, std::int64_t after);
    // pg_sync.cpp
    void progress(const std::string& line);
    std::future<PreparedBatch> read_ahead(std::int64_t after);
    void push_sessions();
    // pg_sync_push.cpp
    void push_batch(const PreparedBatch& b);
    void put_raw_logs(const std::vector<PreparedBatch::LocalRun>& runs, const std::unordered_map<std::int64_t, std::int64_t>& run_ids,
                      const std::function<void(const std::string&)>& put, std::int64_t& raw_bytes);
    // pg_sync.cpp
    void recover_findings();
    void push_findings();

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

}  // namespace emadiag::db::sync_detail
