#include "emadiag/db/database.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "schema_sql.hpp"

#include <sqlite3.h>

namespace emadiag::db {

Database::Database(const std::string& path, int busy_timeout_ms) : path_(path) {
    if (path != ":memory:") {
        if (const auto problem = io::output_path_problem(path, "maintenance database")) throw DbError(*problem);
    }
    const int rc = sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
    if (rc != SQLITE_OK) {
        const std::string msg = db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
        sqlite3_close(db_);
        db_ = nullptr;
        throw DbError("cannot open database " + path + ": " + msg);
    }
    sqlite3_busy_timeout(db_, busy_timeout_ms);
    try {
        check_writable_and_intact();
        exec("PRAGMA foreign_keys = ON");
        migrate();
    } catch (...) {
        // The destructor does not run for a constructor that throws: close the connection here.
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
}

Database::~Database() { sqlite3_close(db_); }

std::string Database::error_text() const { return std::string(sqlite3_errmsg(db_)) + " (" + path_ + ")"; }

void Database::exec(std::string_view sql) {
    char* err = nullptr;
    const std::string text(sql);
    if (sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
        const std::string msg = err != nullptr ? err : "unknown error";
        sqlite3_free(err);
        throw DbError("SQL failed on " + path_ + ": " + msg + " in: " + text.substr(0, 120));
    }
}

void Database::check_writable_and_intact() {
    // SQLite opens a file it may not write read-only without an error; every write would then fail
    // half-way through a command. Refuse it here, before anything is done.
    if (sqlite3_db_readonly(db_, "main") == 1) {
        throw DbError("database " + path_ + " is read-only (no write permission on the file or its medium); " +
                      "emadiag needs to write to it: copy it to a writable place or fix the permissions");
    }
    // A corrupt or truncated file is detected before any write (migrations included) touches it.
    // quick_check reads every page (O(size), about 0.1 s per 100 MB); its first problems are named.
    std::string problems;
    int n = 0;
    try {
        Statement st(*this, "PRAGMA quick_check(5)");
        while (st.step()) {
            const std::string line = st.column_text(0);
            if (line == "ok") continue;
            problems += (n++ > 0 ? "; " : "") + line;
        }
    } catch (const DbError& e) {
        problems = e.what();  // e.g. "file is not a database", "database disk image is malformed"
    }
    if (!problems.empty()) {
        throw DbError("database " + path_ + " is corrupt or truncated and was not opened (nothing was written to it): " +
                      problems + "; restore it from a backup");
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
    for (int v = have; v < newest; ++v) {
        Transaction tx(*this);
        exec(kSchemaMigrations[v]);
        exec("PRAGMA user_version = " + std::to_string(v + 1));
        tx.commit();
    }
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
Statement& Statement::bind_null(int index) {
    check_bind(sqlite3_bind_null(stmt_, index), db_, index, sql_);
    return *this;
}

bool Statement::step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw DbError("statement '" + sql_ + "' failed: " + db_.error_text());
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
