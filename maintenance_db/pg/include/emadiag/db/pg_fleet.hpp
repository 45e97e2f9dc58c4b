#pragma once
// The fleet server: PostgreSQL through libpq (the C API: Debian's libpq-dev, no C++ wrapper to
// build; COPY streaming and the SQLSTATE of every error are plain calls). Stations push their
// sessions to it with sync_to_fleet; the reports read it through PgRecordSource. Schema and
// migrations: maintenance_db/pg_schema/*.sql; docs/fleet-server.md.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_source.hpp"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct pg_conn;
struct pg_result;

namespace emadiag::db {

/// True for "postgresql://..." and "postgres://..." (a fleet server rather than a SQLite file).
[[nodiscard]] bool is_fleet_uri(const std::string& text);
/// Throws DbError when the connection string is not one libpq accepts, or when it carries a
/// password (passwords belong in a service file or PGPASSFILE, never on a command line). The
/// message never repeats the password.
void check_fleet_uri(const std::string& uri);

/// One libpq connection. Errors are DbError with the server's message and SQLSTATE.
class PgConnection {
public:
    explicit PgConnection(const std::string& uri);
    ~PgConnection();
    PgConnection(const PgConnection&) = delete;
    PgConnection& operator=(const PgConnection&) = delete;

    /// Rows of a query with text parameters (std::nullopt: NULL); every value as text, NULL as nullopt.
    using Row = std::vector<std::optional<std::string>>;
    std::vector<Row> query(const std::string& sql, const std::vector<std::optional<std::string>>& params = {});
    /// One row of a result, read in place (no copy of the result): valid during the call of each_row only.
    class RowView {
    public:
        RowView(const pg_result* result, int row) : result_(result), row_(row) {}
        [[nodiscard]] int row() const { return row_; }
        [[nodiscard]] int row_count() const;  ///< the rows of this result (to reserve room at row 0)
        [[nodiscard]] bool is_null(int column) const;
        [[nodiscard]] std::string_view text(int column) const;  ///< "" for NULL; a text column's bytes in either result format
        /// An integer column (int2, int4, int8) of a text or a binary result; DbError when it is not one.
        [[nodiscard]] std::int64_t integer(int column) const;
        /// A float8 or float4 column of a text or a binary result (the same double either way); DbError when it is not one.
        [[nodiscard]] double real(int column) const;
        /// A boolean column of a text or a binary result.
        [[nodiscard]] bool boolean(int column) const;
    private:
        const pg_result* result_;
        int row_;
    };
    /// As query, but hands each row to `f` where it lies in libpq's result (a report reads thousands
    /// of rows: no vector of strings in between).
    void each_row(const std::string& sql, const std::vector<std::optional<std::string>>& params, const std::function<void(const RowView&)>& f);
    /// One query of each_rows: with `binary`, the rows come in PostgreSQL's binary format (a double as
    /// its 8 bytes: no text to print on the server nor to parse here; read numbers with integer and real).
    struct Query {
        std::string sql;
        std::vector<std::optional<std::string>> params;
        bool binary = false;
        std::function<void(const RowView&)> on_row;
    };
    /// Several queries sent at once (libpq's pipeline mode: one round trip), their rows handed over in
    /// order: the server runs the next query while the rows of one are read here. The first error
    /// is thrown after every result has been read (the queries after it are not run).
    void each_row(const std::vector<Query>& queries);
    void exec(const std::string& sql);
    /// COPY table (columns) FROM STDIN: rows given as text-format lines through `fill`, which calls
    /// `put` as often as it likes (sent on in pieces of about 1 MiB, so memory stays bounded).
    void copy_in(const std::string& table_and_columns, const std::function<void(const std::function<void(const std::string&)>&)>& fill);
    [[nodiscard]] const std::string& uri() const { return uri_; }
    [[nodiscard]] pg_conn* handle() const { return conn_; }

private:
    pg_conn* conn_ = nullptr;
    std::string uri_;
};

/// COPY text format: one field escaped; NULL as \N.
[[nodiscard]] std::string copy_field(const std::string& text);
[[nodiscard]] std::string copy_field(const std::optional<std::string>& text);

/// Brings the fleet server's schema to the newest version (pg_schema/*.sql, in order, each in one
/// transaction). Run as the database owner. Returns the version reached.
int migrate_fleet_server(PgConnection& pg);
/// Creates (or grants) a station login role: member of emadiag_station, no password set (the
/// administrator sets it with \password, or uses peer / certificate authentication).
void add_station_role(PgConnection& pg, const std::string& role);

struct SyncOptions {
    std::size_t batch_sessions = 20000;  ///< whole sessions per PostgreSQL transaction (docs/fleet-server.md: why so many)
    int max_retries = 20;               ///< on deadlock or a concurrent sync of the same file
    /// One line per committed batch, and one per batch read ahead from the station while the server
    /// inserts the one before (may be empty; called from the sync's two threads, never at once).
    std::function<void(const std::string&)> progress;
};
struct SyncResult {
    std::string station_uuid;
    std::int64_t sessions_pushed = 0, sessions_recovered = 0, sessions_already = 0;
    std::int64_t runs = 0, samples = 0, raw_log_bytes = 0, discovery_findings = 0, batches = 0, retries = 0;
    double seconds = 0;
};
/// Pushes every session of the station that the server does not have yet (runs, samples, raw logs,
/// estimates, findings, artifacts, installations), then the discovery findings. Each batch of whole
/// sessions is one PostgreSQL transaction; what the server committed is recorded in the station's
/// tables synced_sessions / synced_discovery_findings (schema/005_sync.sql). A sync killed at any
/// point leaves no partial session on the server, and the next sync records what was committed and
/// pushes the rest. While the server inserts one batch, a second thread reads the next from the
/// station file on its own connection (one batch ahead at most; none for a ":memory:" station,
/// which is read in turn).
SyncResult sync_to_fleet(Database& station, const std::string& uri, const SyncOptions& options = {});

/// The reports' view of a fleet server.
class PgRecordSource final : public RecordSource {
public:
    explicit PgRecordSource(const std::string& uri);
    [[nodiscard]] const std::string& name() const override { return pg_.uri(); }
    [[nodiscard]] std::vector<std::string> tail_numbers() override;
    using RecordSource::sessions_of_serial;
    using RecordSource::sessions_of_tail;
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_tail(const std::string& tail_number, const SessionListParts& parts) override;
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_serial(const std::string& actuator_serial, const SessionListParts& parts) override;
    [[nodiscard]] bool serial_seen_elsewhere(const std::string& actuator_serial, const std::string& tail_number) override;
    [[nodiscard]] std::vector<StoredInstallation> installations_of_tail(const std::string& tail_number) override;
    [[nodiscard]] std::vector<StoredInstallation> installations_of_serial(const std::string& actuator_serial) override;
    [[nodiscard]] std::vector<StoredDiscoveryFinding> discovery_findings(const std::string& tail_number, bool open_only) override;
    [[nodiscard]] std::vector<StoredPosition> positions() override;
    [[nodiscard]] std::vector<SeriesStats> series_stats() override;
    [[nodiscard]] std::vector<PositionStatus> position_status() override;

private:
    /// by_tail: `value` is a tail number (the findings then come from schema 3's index by tail).
    std::vector<StoredTestSession> sessions_where(const std::string& where, const std::string& value, const SessionListParts& parts, bool by_tail);
    PgConnection pg_;
    int schema_version_ = 0;
    /// Client and server encodings agree: the packed rows of schemas 5 and 6 (texts in the server's
    /// encoding) read as the columns would.
    bool same_encoding_ = false;
    /// The positions' ATA reference and description (position -> both), read once in the snapshot.
    std::optional<std::map<std::string, std::pair<std::string, std::string>>> places_;
};

/// A RecordSource for --db: a fleet server for a postgresql:// URI, else the SQLite file (opened and
/// migrated as the reports always did).
struct OpenedSource {
    std::unique_ptr<Database> sqlite;
    std::unique_ptr<RecordSource> source;
};
[[nodiscard]] OpenedSource open_record_source(const std::string& db);

}  // namespace emadiag::db
