#include "emadiag/db/database.hpp"

#include "emadiag/db/db_error.hpp"
#include "record_detail.hpp"

#include "emadiag/io/output_path.hpp"
#include "emadiag/io/uri.hpp"
#include "schema_sql.hpp"

#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace emadiag::db {

namespace {
/// The first 16 bytes of every SQLite 3 database file (sqlite.org/fileformat.html, section 1.3.1).
constexpr char kSqliteHeader[] = "SQLite format 3";  // + its NUL: 16 bytes
constexpr std::size_t kSqliteHeaderBytes = 16;
/// The schema version whose migration is followed by the sealing of earlier sessions (hash chain).
constexpr int kSealVersion = 3;
/// The schema version that rebuilds test_sessions and findings clustered by tail: the migration
/// code checks that both keep every row.
constexpr int kClusterVersion = 6;
/// The schema version that chains the discovery findings: the migration code chains those stored before.
constexpr int kDiscoveryChainVersion = 7;
/// The tables a store updates in place (upserts) and the small ones it reads before writing: the
/// bounded check at open reads them whole (IntegrityScope::Open).
constexpr const char* kTablesUpdatedInPlace[] = {"aircraft", "positions", "chain_heads", "series_stats", "position_status"};
/// The page cache of a connection, KiB.
constexpr int kCacheSizeKiB = 256 * 1024;

DbErrorKind kind_of(int rc) {
    switch (rc & 0xff) {
        case SQLITE_BUSY:
        case SQLITE_LOCKED: return DbErrorKind::Busy;
        case SQLITE_FULL: return DbErrorKind::Full;
        case SQLITE_CORRUPT:
        case SQLITE_NOTADB: return DbErrorKind::Corrupt;
        case SQLITE_READONLY:
        case SQLITE_CANTOPEN:
        case SQLITE_PERM: return DbErrorKind::ReadOnly;
        case SQLITE_CONSTRAINT:
        case SQLITE_MISMATCH:
        case SQLITE_RANGE: return DbErrorKind::Invalid;
        default: return DbErrorKind::Other;
    }
}

std::string cause_of(DbErrorKind kind, int busy_timeout_ms) {
    switch (kind) {
        case DbErrorKind::Busy:
            return "locked by another writer (waited the busy timeout of " + std::to_string(busy_timeout_ms) + " ms); nothing was written";
        case DbErrorKind::Full: return "the disk is full; nothing was written";
        case DbErrorKind::Corrupt: return "the file is corrupt or not an emadiag database";
        case DbErrorKind::ReadOnly: return "the file or its directory cannot be written";
        default: return "";
    }
}
}  // namespace

namespace detail {
void throw_sqlite_error(Database& db, int rc, const std::string& what) {
    const DbErrorKind kind = kind_of(rc);
    const std::string cause = cause_of(kind, db.busy_timeout_ms());
    throw DbError("database " + db.path() + ": " + (cause.empty() ? "" : cause + ": ") + what + ": " + sqlite3_errmsg(db.handle()), kind);
}
}  // namespace detail

Database::Database(const std::string& path, int busy_timeout_ms, bool quick_check, Access access)
    : path_(path), busy_timeout_ms_(busy_timeout_ms), access_(access) {
    const bool in_memory = path == ":memory:" || path.empty();
    if (!in_memory) anchor_path_ = path + ".anchor";
    if (!in_memory) {
        // A URI (postgresql://..., any scheme://) is no file name: refused before anything is created,
        // and never repeated with its password.
        if (io::has_uri_scheme(path))
            throw DbError("database " + io::redact_uri_passwords(path) +
                              " is a URI: this command works on a station's SQLite file only (give its path; the fleet server is read by "
                              "report, trend and fleet, and written by sync --to)",
                          DbErrorKind::Invalid);
    }
    const bool read_only = access == Access::ReadOnly;
    if (!in_memory && read_only) {
        std::error_code ec;
        const auto st = std::filesystem::status(path, ec);
        if (!std::filesystem::exists(st)) throw DbError("database " + path + " does not exist", DbErrorKind::Other);
        if (std::filesystem::is_directory(st))
            throw DbError("database " + path + " is a directory, not a database file", DbErrorKind::Other);
        if (!std::filesystem::is_regular_file(st))
            throw DbError("database " + path + " is not a regular file (a device, FIFO or socket)", DbErrorKind::Other);
    }
    if (!in_memory) {
        if (const auto problem = read_only ? std::nullopt : io::output_path_problem(path, "maintenance database")) throw DbError(*problem);
        // The header first: a file that is not SQLite's is refused before SQLite touches it.
        std::ifstream in(path, std::ios::binary);
        if (in) {
            std::string head(kSqliteHeaderBytes, '\0');
            in.read(head.data(), static_cast<std::streamsize>(head.size()));
            const auto got = static_cast<std::size_t>(in.gcount());
            if (got > 0 && (got < kSqliteHeaderBytes || head != std::string(kSqliteHeader, kSqliteHeaderBytes))) {
                throw DbError("database " + path + " is corrupt or not an SQLite database: corrupt or truncated (its first " +
                                  std::to_string(got) + " bytes are not the SQLite header); it was not opened and is left untouched",
                              DbErrorKind::Corrupt);
            }
        }
    }
    // SQLite's memory statistics take a global mutex around every allocation it makes (a bulk store
    // makes millions); emadiag reads none of them. Configurable only before SQLite initialises: a
    // later call is refused (SQLITE_MISUSE) and changes nothing.
    static const int kMemStatusOff = sqlite3_config(SQLITE_CONFIG_MEMSTATUS, 0);
    (void)kMemStatusOff;
    // A connection belongs to one Database object, used by one thread at a time (never shared
    // between threads): no per-call connection mutex (SQLite's multi-thread mode).
    const int flags = read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
    const int rc = sqlite3_open_v2(path.c_str(), &db_, flags | SQLITE_OPEN_NOMUTEX, nullptr);
    if (rc != SQLITE_OK) {
        const std::string msg = db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
        sqlite3_close(db_);
        db_ = nullptr;
        throw DbError("cannot open database " + path + ": " + msg, kind_of(rc));
    }
    sqlite3_busy_timeout(db_, busy_timeout_ms);
    try {
        // Every b-tree page is sanity-checked as it is read: a write that meets a corrupt page fails
        // (SQLITE_CORRUPT) and its transaction rolls back instead of building on it.
        exec("PRAGMA cell_size_check = ON");
        if (!in_memory && quick_check) check_before_write();
        // Off while migrating: version 3 rebuilds test_sessions, which other tables reference.
        if (read_only) {
            const int have = schema_version(), newest = static_cast<int>(std::size(kSchemaMigrations));
            if (have < newest && ::access(path_.c_str(), W_OK) == 0) {
                // An older file on writable storage is migrated first, as every command did before,
                // by a connection of its own; this one then reads the migrated file.
                cache_.clear();
                sqlite3_close(db_);
                db_ = nullptr;
                { Database migrating(path_, busy_timeout_ms, false, Access::ReadWrite); }
                const int again = sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr);
                if (again != SQLITE_OK) throw DbError("cannot open database " + path_ + ": " + sqlite3_errstr(again), kind_of(again));
                sqlite3_busy_timeout(db_, busy_timeout_ms);
                exec("PRAGMA cell_size_check = ON");
            } else if (have != newest) {
                throw DbError("database " + path_ + " has schema version " + std::to_string(have) + ", not this emadiag's " +
                                  std::to_string(newest) + "; a command that only reads does not migrate it (import into it, "
                                  "or a writable copy of it, once)",
                              DbErrorKind::Other);
            }
        } else {
            exec("PRAGMA foreign_keys = OFF");
            migrate();
        }
        exec("PRAGMA foreign_keys = ON");
        // A session's transaction (or a bulk import's) stays in memory until COMMIT: without room
        // SQLite spills pages to the file mid-transaction, syncing the journal each time.
        exec("PRAGMA cache_size = " + std::to_string(-kCacheSizeKiB));
    } catch (...) {
        // The destructor does not run for a constructor that throws: close the connection here.
        cache_.clear();
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
}

Database::~Database() {
    cache_.clear();  // finalize before closing
    sqlite3_close(db_);
}

Statement& Database::cached(const std::string& sql) {
    auto it = cache_.find(sql);
    if (it == cache_.end()) it = cache_.emplace(sql, std::make_unique<Statement>(*this, sql)).first;
    it->second->reset();
    return *it->second;
}

std::string Database::error_text() const { return std::string(sqlite3_errmsg(db_)) + " (" + path_ + ")"; }

void Database::check_before_write() {
    // SQLite opens a file it may not write read-only without an error; every write would then fail
    // half-way through a command. Refuse it here, before anything is done.
    if (access_ == Access::ReadWrite && sqlite3_db_readonly(db_, "main") == 1) {
        throw DbError("database " + path_ + " is read-only (no write permission on the file or its medium); " +
                          "emadiag needs to write to it: copy it to a writable place or fix the permissions",
                      DbErrorKind::ReadOnly);
    }
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(path_, ec);
    const IntegrityScope scope = !ec && bytes > kFullCheckMaxBytes ? IntegrityScope::Open : IntegrityScope::Full;
    std::vector<std::string> problems;
    try {
        problems = integrity_problems(scope, 3);
    } catch (const DbError& e) {
        std::string inner = e.what();
        if (const std::string tag = "[maintenance_db] "; inner.rfind(tag, 0) == 0) inner.erase(0, tag.size());
        throw DbError("database " + path_ + " is corrupt or truncated and was not opened, or cannot be checked before use: " + inner +
                          "; it is left untouched",
                      e.kind() == DbErrorKind::Other ? DbErrorKind::Corrupt : e.kind());
    }
    if (!problems.empty()) {
        std::string list;
        for (const auto& p : problems) list += (list.empty() ? "" : "; ") + p;
        throw DbError("database " + path_ + " is corrupt or truncated and was not opened (nothing was written to it; " +
                          (scope == IntegrityScope::Full ? "PRAGMA quick_check and the file size" : "check at open") + ": " + list +
                          "); it is left untouched: restore it from a backup",
                      DbErrorKind::Corrupt);
    }
}

namespace {
/// Big-endian unsigned integer of `n` bytes at `at`.
std::uint64_t big_endian(const std::string& b, std::size_t at, std::size_t n) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
    return v;
}
}  // namespace

std::vector<std::string> Database::integrity_problems(IntegrityScope scope, int max_problems) {
    std::vector<std::string> problems;
    const auto add = [&](const std::string& p) {
        if (static_cast<int>(problems.size()) < max_problems) problems.push_back(p);
    };
    std::vector<std::string> statements;
    if (scope == IntegrityScope::Full) {
        statements.emplace_back("PRAGMA quick_check(" + std::to_string(max_problems) + ")");
    } else {
        statements.emplace_back("SELECT count(*) FROM sqlite_schema");  // reads and parses the schema
        // Only the tables this database has (an old version lacks the summary tables until migrated).
        for (const char* table : kTablesUpdatedInPlace) {
            Statement has(*this, "SELECT 1 FROM sqlite_schema WHERE type = 'table' AND name = ?");
            has.bind(1, std::string(table));
            if (has.step()) statements.emplace_back(std::string("PRAGMA quick_check(") + table + ")");
        }
    }
    for (const auto& sql : statements) {
        sqlite3_stmt* st = nullptr;
        int rc = sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr);
        while (rc == SQLITE_OK || rc == SQLITE_ROW) {
            rc = sqlite3_step(st);
            if (rc != SQLITE_ROW) break;
            const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
            const std::string line = text != nullptr ? text : "";
            if (sql.rfind("PRAGMA", 0) == 0 && line != "ok") add(line);
        }
        const std::string err = sqlite3_errmsg(db_);
        sqlite3_finalize(st);
        if (rc != SQLITE_DONE && rc != SQLITE_OK) {
            const DbErrorKind kind = kind_of(rc);
            throw DbError(sql + ": " + (cause_of(kind, busy_timeout_ms_).empty() ? "" : cause_of(kind, busy_timeout_ms_) + ": ") + err, kind);
        }
    }
    if (path_ != ":memory:" && !path_.empty()) {
        if (const auto p = file_size_problem()) add(*p);
    }
    return problems;
}

std::optional<std::string> Database::file_size_problem() {
    // Under a shared lock (a read transaction): no writer is half-way through growing the file, and
    // the first read has rolled back a hot journal left by a crash (restoring the header). The
    // header (sqlite.org/fileformat.html 1.3): page size at 16, change counter at 24, page count at
    // 28, valid when the version-valid-for number at 92 equals the change counter.
    const bool own_transaction = sqlite3_get_autocommit(db_) != 0;
    if (own_transaction) exec("BEGIN");
    std::optional<std::string> problem;
    try {
        Statement(*this, "SELECT count(*) FROM sqlite_schema").step();
        std::ifstream in(path_, std::ios::binary);
        std::string head(100, '\0');
        in.read(head.data(), static_cast<std::streamsize>(head.size()));
        std::error_code ec;
        const auto bytes = std::filesystem::file_size(path_, ec);
        if (in.gcount() == 100 && !ec) {
            std::uint64_t page_size = big_endian(head, 16, 2);
            if (page_size == 1) page_size = 65536;
            const std::uint64_t pages = big_endian(head, 28, 4);
            const bool valid = big_endian(head, 24, 4) == big_endian(head, 92, 4) && pages > 0;
            if (page_size < 512 || (page_size & (page_size - 1)) != 0) {
                problem = "page size " + std::to_string(page_size) + " in the header is not valid";
            } else if (valid && pages * page_size > bytes) {
                problem = "the header records " + std::to_string(pages) + " pages of " + std::to_string(page_size) + " bytes, the file holds " +
                          std::to_string(bytes) + " bytes: truncated";
            } else if (valid && bytes > pages * page_size) {
                problem = "the header records " + std::to_string(pages) + " pages of " + std::to_string(page_size) + " bytes (" +
                          std::to_string(pages * page_size) + " bytes), the file holds " + std::to_string(bytes) + ": " +
                          std::to_string(bytes - pages * page_size) + " bytes after the last page were not written by SQLite";
            } else if (bytes % page_size != 0) {
                problem = "the file holds " + std::to_string(bytes) + " bytes, not a whole number of " + std::to_string(page_size) +
                          "-byte pages: " + std::to_string(bytes % page_size) + " bytes after the last page were not written by SQLite";
            }
        }
    } catch (...) {
        if (own_transaction) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
    if (own_transaction) exec("COMMIT");
    return problem;
}

void Database::exec(std::string_view sql) {
    char* err = nullptr;
    const std::string text(sql);
    const int rc = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &err);
    if (rc != SQLITE_OK) {
        const std::string msg = err != nullptr ? err : "unknown error";
        sqlite3_free(err);
        const DbErrorKind kind = kind_of(rc);
        const std::string cause = cause_of(kind, busy_timeout_ms_);
        throw DbError("database " + path_ + ": " + (cause.empty() ? "SQL failed: " : cause + ": ") + msg + " in: " + text.substr(0, 120), kind);
    }
}

int Database::schema_version() {
    Statement st(*this, "PRAGMA user_version");
    st.step();
    return static_cast<int>(st.column_int(0));
}

std::int64_t Database::last_insert_id() const { return sqlite3_last_insert_rowid(db_); }

void Database::migrate() {
    const int have = schema_version();
    const int newest = static_cast<int>(std::size(kSchemaMigrations));
    if (have > newest) {
        throw DbError("database " + path_ + " has schema version " + std::to_string(have) +
                      ", newer than this emadiag understands (" + std::to_string(newest) + ")");
    }
    if (have == newest) return;
    // Every pending step in one transaction: the file moves from the version it had to the newest
    // or not at all. A new file is never seen half-made (a kill -9 after step 1's commit once left
    // a version-1 file with no test_sessions table), and an old one never stops at a middle version.
    // BEGIN IMMEDIATE takes the write lock (waiting the busy timeout for another process that is
    // creating or migrating the same file), and the version is read again under that lock: the
    // other process may have done the work meanwhile (four importers creating one new file raced
    // here: "table aircraft already exists").
    Transaction tx(*this);
    const int locked_have = schema_version();
    if (locked_have > newest) {
        throw DbError("database " + path_ + " has schema version " + std::to_string(locked_have) +
                      ", newer than this emadiag understands (" + std::to_string(newest) + ")");
    }
    for (int v = locked_have; v < newest; ++v) {
        const auto count_rows = [this](const char* table) {
            Statement st(*this, std::string("SELECT count(*) FROM ") + table);
            st.step();
            return st.column_int(0);
        };
        std::int64_t sessions_before = 0, findings_before = 0;
        if (v + 1 == kClusterVersion) {
            sessions_before = count_rows("test_sessions");
            findings_before = count_rows("findings");
        }
        exec(kSchemaMigrations[v]);
        if (v + 1 == kSealVersion) detail::seal_sessions_before_v3(*this);
        if (v + 1 == kDiscoveryChainVersion) detail::seal_discovery_findings_before_v7(*this);
        if (v + 1 == kClusterVersion) {
            const std::int64_t sessions_after = count_rows("test_sessions"), findings_after = count_rows("findings");
            if (sessions_after != sessions_before || findings_after != findings_before)
                throw DbError("database " + path_ + ": migration to version " + std::to_string(v + 1) + " would keep " +
                              std::to_string(sessions_after) + " of " + std::to_string(sessions_before) + " test sessions and " +
                              std::to_string(findings_after) + " of " + std::to_string(findings_before) +
                              " findings (a finding without its session?); nothing was changed");
        }
        exec("PRAGMA user_version = " + std::to_string(v + 1));
        if (v + 1 == newest) {
            Statement fk(*this, "PRAGMA foreign_key_check");
            if (fk.step())
                throw DbError("database " + path_ + ": migration to version " + std::to_string(v + 1) + " left a broken reference in table " +
                              fk.column_text(0) + "; nothing was changed");
        }
    }
    tx.commit();
}

Statement::Statement(Database& db, std::string_view sql) : db_(db), sql_(sql) {
    if (sqlite3_prepare_v2(db.handle(), sql_.c_str(), static_cast<int>(sql_.size()), &stmt_, nullptr) != SQLITE_OK) {
        throw DbError("cannot prepare '" + sql_ + "': " + db.error_text());
    }
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

namespace {
void check_bind(int rc, Database& db, int index, const std::string& sql) {
    if (rc != SQLITE_OK) throw DbError("cannot bind parameter " + std::to_string(index) + " of '" + sql + "': " + db.error_text());
}
}  // namespace

Statement& Statement::bind(int index, double value) {
    check_bind(sqlite3_bind_double(stmt_, index, value), db_, index, sql_);
    return *this;
}
Statement& Statement::bind(int index, std::int64_t value) {
    check_bind(sqlite3_bind_int64(stmt_, index, value), db_, index, sql_);
    return *this;
}
Statement& Statement::bind(int index, const std::string& value) {
    check_bind(sqlite3_bind_text(stmt_, index, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT), db_,
               index, sql_);
    return *this;
}
Statement& Statement::bind_blob(int index, std::string_view bytes) {
    check_bind(sqlite3_bind_blob64(stmt_, index, bytes.data(), bytes.size(), SQLITE_TRANSIENT), db_, index, sql_);
    return *this;
}
Statement& Statement::bind_view(int index, std::string_view value) {
    // A null data pointer would bind SQL NULL, not the empty text.
    const char* text = value.data() != nullptr ? value.data() : "";
    check_bind(sqlite3_bind_text(stmt_, index, text, static_cast<int>(value.size()), SQLITE_STATIC), db_, index, sql_);
    return *this;
}
Statement& Statement::bind_null(int index) {
    check_bind(sqlite3_bind_null(stmt_, index), db_, index, sql_);
    return *this;
}

bool Statement::step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    detail::throw_sqlite_error(db_, rc, "statement '" + sql_.substr(0, 160) + "' failed");
}

void Statement::run() {
    while (step()) {
    }
}

void Statement::reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
}

double Statement::column_double(int col) const { return sqlite3_column_double(stmt_, col); }
std::int64_t Statement::column_int(int col) const { return sqlite3_column_int64(stmt_, col); }
std::string Statement::column_text(int col) const {
    const auto* p = sqlite3_column_blob(stmt_, col);
    const int n = sqlite3_column_bytes(stmt_, col);
    return p != nullptr ? std::string(static_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
std::string_view Statement::column_view(int col) const {
    const auto* p = sqlite3_column_blob(stmt_, col);
    const int n = sqlite3_column_bytes(stmt_, col);
    return p != nullptr ? std::string_view(static_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string_view();
}
bool Statement::column_is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }

Transaction::Transaction(Database& db) : db_(db) { db_.exec("BEGIN IMMEDIATE"); }

Transaction::~Transaction() {
    if (!done_) sqlite3_exec(db_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);  // never throws
}

void Transaction::commit() {
    if (done_) throw DbError("transaction on " + db_.path() + " already committed");
    db_.exec("COMMIT");
    done_ = true;
}

}  // namespace emadiag::db
