#pragma once
// A thin RAII layer over the SQLite C API (after SQLiteCpp): Database, Statement, Transaction.
#include <cstdint>
#include <memory>
#include <vector>
#include <unordered_map>
#include <optional>
#include <string>
#include <string_view>

struct sqlite3;
struct sqlite3_stmt;

namespace emadiag::db {

class Database;

/// A prepared statement. Bind indexes start at 1, column indexes at 0.
class Statement {
public:
    Statement(Database& db, std::string_view sql);
    ~Statement();
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;

    Statement& bind(int index, double value);
    Statement& bind(int index, std::int64_t value);
    Statement& bind(int index, const std::string& value);
    Statement& bind_blob(int index, std::string_view bytes);
    Statement& bind_null(int index);
    /// Binds text without copying it (SQLITE_STATIC): `value` must stay valid and unchanged until
    /// the statement has run and been reset (the bulk store binds the caller's session fields).
    Statement& bind_view(int index, std::string_view value);
    /// Column text as a view into SQLite's buffer: valid until the next step(), reset() or column
    /// call of another type on that column (read it into a string at once, or compare it).
    [[nodiscard]] std::string_view column_view(int col) const;
    /// Steps once: true while a row is available, false when done. Throws DbError on failure.
    bool step();
    /// Runs a statement that returns no rows.
    void run();
    void reset();

    [[nodiscard]] double column_double(int col) const;
    [[nodiscard]] std::int64_t column_int(int col) const;
    [[nodiscard]] std::string column_text(int col) const;
    [[nodiscard]] bool column_is_null(int col) const;

private:
    Database& db_;
    sqlite3_stmt* stmt_ = nullptr;
    std::string sql_;
};

/// One SQLite connection. Not for concurrent use: one thread at a time (the connection is opened
/// without its own mutex, SQLite's multi-thread mode); open one Database per thread.
class Database {
public:
    static constexpr int kDefaultBusyTimeoutMs = 5000;
    /// Files up to this size get the full PRAGMA quick_check at open (it reads the whole file, about
    /// 1 s per GB: at most a few tenths of a second here); larger ones the bounded check
    /// (IntegrityScope::Open, docs/record-format.md "Corruption").
    static constexpr std::uintmax_t kFullCheckMaxBytes = std::uintmax_t{256} << 20;
    /// What integrity_problems checks.
    enum class IntegrityScope {
        /// The bounded check at open: the header's page count against the file size (a truncated
        /// file, or bytes appended after the last page; both scopes check this), the schema, and PRAGMA quick_check of every table a store updates in place (the
        /// summary tables, chain heads, positions, aircraft) with their indexes. The large append-only
        /// tables are checked page by page as SQLite reads them (PRAGMA cell_size_check is on), so a
        /// write that meets a corrupt page fails and rolls back; the full check is `emadiag verify`.
        Open,
        /// PRAGMA quick_check of the whole file.
        Full,
    };
    /// Opens (creating if needed) the database at `path` (":memory:" for tests) and brings its schema
    /// to the newest version. A busy database is retried for busy_timeout_ms before DbError (kind
    /// Busy). An existing file is checked before anything is written: its header must be SQLite's
    /// and, with `quick_check`, the integrity check must pass (Full up to kFullCheckMaxBytes, else
    /// Open); otherwise DbError (kind Corrupt) and the file is left untouched. Skip it only for a
    /// file this process has just checked or created.
    /// ReadOnly (for the commands that only read: report, trend, fleet, verify, export) opens an
    /// existing file with SQLITE_OPEN_READONLY, so a database on read-only media or without write
    /// permission can be read; it never creates a file, and is checked as a writable one is. An older
    /// schema is migrated first by a read-write connection of its own where the file can be written,
    /// else DbError naming both versions.
    enum class Access { ReadWrite, ReadOnly };
    explicit Database(const std::string& path, int busy_timeout_ms = kDefaultBusyTimeoutMs, bool quick_check = true,
                      Access access = Access::ReadWrite);
    ~Database();
    Database(const Database&) = delete;
    Database& operator=(const Database&) = delete;

    void exec(std::string_view sql);
    [[nodiscard]] int schema_version();
    [[nodiscard]] std::int64_t last_insert_id() const;
    [[nodiscard]] sqlite3* handle() const { return db_; }
    [[nodiscard]] const std::string& path() const { return path_; }
    [[nodiscard]] int busy_timeout_ms() const { return busy_timeout_ms_; }
    /// The anchor file every store appends each tail's chain head to (docs/record-format.md,
    /// "Anchoring the head"): DB.anchor beside the database by default, none ("") for ":memory:".
    [[nodiscard]] const std::string& anchor_path() const { return anchor_path_; }
    void set_anchor_path(std::string path) { anchor_path_ = std::move(path); }
    /// The head of a tail's chain this connection has verified whole (verify_tail) or appended to
    /// after such a check ("" none): a store through the same connection need not read the whole
    /// record again while the chain head is still that one (a writer storing in a loop).
    [[nodiscard]] std::string verified_head(const std::string& tail_number) const {
        const auto it = verified_heads_.find(tail_number);
        return it == verified_heads_.end() ? std::string() : it->second;
    }
    void set_verified_head(const std::string& tail_number, std::string head) { verified_heads_[tail_number] = std::move(head); }
    /// "message (path)" for the last error on this connection.
    [[nodiscard]] std::string error_text() const;
    /// A statement prepared once per connection and kept (for the bulk paths); reset and unbound
    /// on every call. Valid while the Database lives.
    [[nodiscard]] Statement& cached(const std::string& sql);
    /// The problems an integrity check finds (at most max_problems lines; empty: none). Throws
    /// DbError when the file cannot be read at all.
    [[nodiscard]] std::vector<std::string> integrity_problems(IntegrityScope scope, int max_problems = 20);

private:
    /// Throws DbError, before anything is written, for a read-only file and for a corrupt or
    /// truncated one (PRAGMA quick_check).
    void check_before_write();
    /// The file's size against the page count its header records (read under a shared lock, after
    /// a hot journal was rolled back): a truncated file, or bytes after the last page. Empty: sound.
    [[nodiscard]] std::optional<std::string> file_size_problem();
    void migrate();
    sqlite3* db_ = nullptr;
    std::string path_;
    std::string anchor_path_;
    int busy_timeout_ms_ = kDefaultBusyTimeoutMs;
    Access access_ = Access::ReadWrite;
    std::unordered_map<std::string, std::unique_ptr<Statement>> cache_;
    std::unordered_map<std::string, std::string> verified_heads_;
};

/// Begins a transaction; rolls back in the destructor unless commit() was called. Never throws
/// from the destructor.
class Transaction {
public:
    explicit Transaction(Database& db);
    ~Transaction();
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;
    void commit();

private:
    Database& db_;
    bool done_ = false;
};

}  // namespace emadiag::db
