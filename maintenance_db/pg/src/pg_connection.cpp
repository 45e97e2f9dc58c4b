#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "emadiag/io/uri.hpp"

#include "pg_schema_sql.hpp"

#include <libpq-fe.h>

#include <bit>
#include <charconv>
#include <cstring>
#include <iterator>
#include <limits>
#include <memory>

namespace emadiag::db {
namespace {

std::string error_of(PGconn* conn, const PGresult* res, const std::string& what) {
    std::string msg = res ? PQresultErrorMessage(res) : PQerrorMessage(conn);
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    const char* state = res ? PQresultErrorField(res, PG_DIAG_SQLSTATE) : nullptr;
    return "fleet server: " + what + ": " + msg + (state ? " (SQLSTATE " + std::string(state) + ")" : "");
}

struct ResultDeleter {
    void operator()(PGresult* r) const { PQclear(r); }
};
using Result = std::unique_ptr<PGresult, ResultDeleter>;

/// A DbError that keeps the SQLSTATE at the end of its message for the retry logic.
[[noreturn]] void fail(PGconn* conn, const PGresult* res, const std::string& what) {
    throw DbError(error_of(conn, res, what), DbErrorKind::Other);
}

std::string short_sql(const std::string& sql) { return sql.size() > 80 ? sql.substr(0, 80) + "..." : sql; }

/// One statement with text parameters (nullopt: NULL); a result that is not rows or a command's is an error.
Result exec_params(PGconn* conn, const std::string& sql, const std::vector<std::optional<std::string>>& params) {
    std::vector<const char*> values;
    values.reserve(params.size());
    for (const auto& p : params) values.push_back(p ? p->c_str() : nullptr);
    Result res(PQexecParams(conn, sql.c_str(), static_cast<int>(values.size()), nullptr, values.data(), nullptr, nullptr, 0));
    const auto status = PQresultStatus(res.get());
    if (status != PGRES_TUPLES_OK && status != PGRES_COMMAND_OK) fail(conn, res.get(), short_sql(sql));
    return res;
}

}  // namespace

bool is_fleet_uri(const std::string& text) { return text.rfind("postgresql://", 0) == 0 || text.rfind("postgres://", 0) == 0; }

void check_fleet_uri(const std::string& uri) {
    char* err = nullptr;
    PQconninfoOption* opts = PQconninfoParse(uri.c_str(), &err);
    if (opts == nullptr) {
        std::string m = err ? err : "cannot parse";
        if (err) PQfreemem(err);
        while (!m.empty() && m.back() == '\n') m.pop_back();
        // libpq quotes the URI whole in its message: the password goes before it is printed.
        throw DbError("fleet server address is not a valid PostgreSQL connection URI: " + io::redact_uri_passwords(m), DbErrorKind::Invalid);
    }
    bool has_password = false;
    for (PQconninfoOption* o = opts; o->keyword != nullptr; ++o)
        if (std::string(o->keyword) == "password" && o->val != nullptr && o->val[0] != '\0') has_password = true;
    PQconninfoFree(opts);
    if (has_password)
        throw DbError("the fleet server URI carries a password: passwords never go on the command line or into logs; put it in a "
                      "password file (~/.pgpass or PGPASSFILE) or a service file (PGSERVICEFILE, URI ?service=NAME) and give the URI "
                      "without it",
                      DbErrorKind::Invalid);
}

PgConnection::PgConnection(const std::string& uri) : uri_(uri) {
    check_fleet_uri(uri);
    conn_ = PQconnectdb(uri.c_str());
    if (conn_ == nullptr || PQstatus(conn_) != CONNECTION_OK) {
        const std::string msg = io::redact_uri_passwords(error_of(conn_, nullptr, "cannot connect to " + uri));
        if (conn_) PQfinish(conn_);
        conn_ = nullptr;
        throw DbError(msg, DbErrorKind::Other);
    }
    exec("SET client_min_messages = warning");
    exec("SET extra_float_digits = 1");  // shortest text that reads back to the same double (PostgreSQL 12+)
}

PgConnection::~PgConnection() {
    if (conn_) PQfinish(conn_);
}

std::vector<PgConnection::Row> PgConnection::query(const std::string& sql, const std::vector<std::optional<std::string>>& params) {
    const Result res = exec_params(conn_, sql, params);
    std::vector<Row> rows;
    const int n = PQntuples(res.get()), m = PQnfields(res.get());
    rows.reserve(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        Row r;
        r.reserve(static_cast<std::size_t>(m));
        for (int j = 0; j < m; ++j) {
            if (PQgetisnull(res.get(), i, j)) {
                r.emplace_back(std::nullopt);
            } else {
                r.emplace_back(std::string(PQgetvalue(res.get(), i, j), static_cast<std::size_t>(PQgetlength(res.get(), i, j))));
            }
        }
        rows.push_back(std::move(r));
    }
    return rows;
}

int PgConnection::RowView::row_count() const { return PQntuples(result_); }
bool PgConnection::RowView::is_null(int column) const { return PQgetisnull(result_, row_, column) != 0; }
std::string_view PgConnection::RowView::text(int column) const {
    return {PQgetvalue(result_, row_, column), static_cast<std::size_t>(PQgetlength(result_, row_, column))};
}

namespace {
// Type OIDs (pg_type.dat): the numbers a binary result may hold here.
constexpr Oid kBoolOid = 16, kInt8Oid = 20, kInt2Oid = 21, kInt4Oid = 23, kFloat4Oid = 700, kFloat8Oid = 701;

/// A big-endian unsigned integer of `n` bytes (PostgreSQL's binary send format).
std::uint64_t big_endian(const char* p, std::size_t n) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v = (v << 8) | static_cast<unsigned char>(p[i]);
    return v;
}

[[noreturn]] void not_a(const char* what, const pg_result* res, int column, std::string_view value) {
    throw DbError("fleet server: column " + std::string(PQfname(res, column)) + " (type " + std::to_string(PQftype(res, column)) + ", " +
                  (PQfformat(res, column) == 1 ? "binary" : "text") + ", " + std::to_string(value.size()) + " bytes) is not " + what);
}
}  // namespace

std::int64_t PgConnection::RowView::integer(int column) const {
    const std::string_view v = text(column);
    if (PQfformat(result_, column) == 1) {
        const Oid type = PQftype(result_, column);
        const std::size_t bytes = type == kInt8Oid ? 8 : type == kInt4Oid ? 4 : type == kInt2Oid ? 2 : 0;
        if (bytes == 0 || v.size() != bytes) not_a("an integer", result_, column, v);
        const std::uint64_t u = big_endian(v.data(), bytes);
        if (bytes == 8) return static_cast<std::int64_t>(u);
        if (bytes == 4) return static_cast<std::int32_t>(static_cast<std::uint32_t>(u));
        return static_cast<std::int16_t>(static_cast<std::uint16_t>(u));
    }
    std::int64_t out = 0;
    const auto r = std::from_chars(v.data(), v.data() + v.size(), out);
    if (r.ec != std::errc() || r.ptr != v.data() + v.size()) throw DbError("fleet server: '" + std::string(v) + "' is not an integer");
    return out;
}

double PgConnection::RowView::real(int column) const {
    const std::string_view v = text(column);
    if (PQfformat(result_, column) == 1) {
        const Oid type = PQftype(result_, column);
        if (type == kFloat8Oid && v.size() == 8) return std::bit_cast<double>(big_endian(v.data(), 8));
        if (type == kFloat4Oid && v.size() == 4) return std::bit_cast<float>(static_cast<std::uint32_t>(big_endian(v.data(), 4)));
        not_a("a float8", result_, column, v);
    }
    double out = 0;
    const auto r = std::from_chars(v.data(), v.data() + v.size(), out);
    if (r.ec == std::errc() && r.ptr == v.data() + v.size()) return out;
    if (v == "NaN") return std::numeric_limits<double>::quiet_NaN();
    if (v == "Infinity") return std::numeric_limits<double>::infinity();
    if (v == "-Infinity") return -std::numeric_limits<double>::infinity();
    throw DbError("fleet server: '" + std::string(v) + "' is not a number");
}

bool PgConnection::RowView::boolean(int column) const {
    const std::string_view v = text(column);
    if (PQfformat(result_, column) == 1) {
        if (PQftype(result_, column) != kBoolOid || v.size() != 1) not_a("a boolean", result_, column, v);
        return v[0] != 0;
    }
    return v == "t";
}

void PgConnection::each_row(const std::vector<Query>& queries) {
    if (PQenterPipelineMode(conn_) != 1) fail(conn_, nullptr, "pipeline mode");
    std::string error;
    const auto leave = [&] {
        // Every result up to the sync point, then out of pipeline mode: the connection is as before.
        for (int nulls = 0; nulls < 2;) {
            PGresult* r = PQgetResult(conn_);
            if (r == nullptr) {  // between two queries' results; twice in a row: nothing is left
                ++nulls;
                continue;
            }
            nulls = 0;
            const auto status = PQresultStatus(r);
            PQclear(r);
            if (status == PGRES_PIPELINE_SYNC) break;
            if (status == PGRES_FATAL_ERROR && PQstatus(conn_) == CONNECTION_BAD) break;
        }
        PQexitPipelineMode(conn_);
    };
    std::size_t sent = 0;
    for (const auto& q : queries) {
        std::vector<const char*> values;
        values.reserve(q.params.size());
        for (const auto& p : q.params) values.push_back(p ? p->c_str() : nullptr);
        if (PQsendQueryParams(conn_, q.sql.c_str(), static_cast<int>(values.size()), nullptr, values.data(), nullptr, nullptr,
                              q.binary ? 1 : 0) != 1) {
            error = error_of(conn_, nullptr, short_sql(q.sql));
            break;
        }
        ++sent;
    }
    if (PQpipelineSync(conn_) != 1 && error.empty()) error = error_of(conn_, nullptr, "pipeline sync");
    for (std::size_t i = 0; i < sent; ++i) {
        // One query's result, then the null that ends it.
        Result res(PQgetResult(conn_));
        const auto status = PQresultStatus(res.get());
        if (status == PGRES_TUPLES_OK || status == PGRES_COMMAND_OK) {
            if (error.empty()) {
                const int n = PQntuples(res.get());
                try {
                    for (int row = 0; row < n; ++row) queries[i].on_row(RowView(res.get(), row));
                } catch (...) {
                    res.reset();
                    while (PGresult* r = PQgetResult(conn_)) PQclear(r);
                    leave();
                    throw;
                }
            }
        } else if (error.empty()) {
            error = status == PGRES_PIPELINE_ABORTED ? "fleet server: " + short_sql(queries[i].sql) + ": not run after an earlier error"
                                                     : error_of(conn_, res.get(), short_sql(queries[i].sql));
        }
        res.reset();
        while (PGresult* r = PQgetResult(conn_)) PQclear(r);
    }
    leave();
    if (!error.empty()) throw DbError(error, DbErrorKind::Other);
}

void PgConnection::each_row(const std::string& sql, const std::vector<std::optional<std::string>>& params,
                            const std::function<void(const RowView&)>& f) {
    const Result res = exec_params(conn_, sql, params);
    const int n = PQntuples(res.get());
    for (int i = 0; i < n; ++i) f(RowView(res.get(), i));
}

void PgConnection::exec(const std::string& sql) {
    Result res(PQexec(conn_, sql.c_str()));
    const auto status = PQresultStatus(res.get());
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) fail(conn_, res.get(), short_sql(sql));
}

void PgConnection::copy_in(const std::string& table_and_columns,
                           const std::function<void(const std::function<void(const std::string&)>&)>& fill) {
    constexpr std::size_t kFlushBytes = 1 << 20;
    const std::string sql = "COPY " + table_and_columns + " FROM STDIN";
    {
        Result res(PQexec(conn_, sql.c_str()));
        if (PQresultStatus(res.get()) != PGRES_COPY_IN) fail(conn_, res.get(), sql);
    }
    std::string buf;
    bool ok = true;
    const auto flush = [&] {
        if (!buf.empty() && ok && PQputCopyData(conn_, buf.data(), static_cast<int>(buf.size())) != 1) ok = false;
        buf.clear();
    };
    try {
        fill([&](const std::string& line) {
            buf += line;
            if (buf.size() >= kFlushBytes) flush();
        });
    } catch (...) {
        PQputCopyEnd(conn_, "client error");
        while (PGresult* r = PQgetResult(conn_)) PQclear(r);
        throw;
    }
    flush();
    if (!ok || PQputCopyEnd(conn_, nullptr) != 1) fail(conn_, nullptr, sql);
    Result res(PQgetResult(conn_));
    const bool done = PQresultStatus(res.get()) == PGRES_COMMAND_OK;
    std::string msg = done ? "" : error_of(conn_, res.get(), sql);
    while (PGresult* r = PQgetResult(conn_)) PQclear(r);
    if (!done) throw DbError(msg, DbErrorKind::Other);
}

std::string copy_field(const std::string& text) {
    std::string out;
    out.reserve(text.size() + 2);
    for (char c : text) {
        switch (c) {
            case '\\': out += "\\\\"; break;
            case '\t': out += "\\t"; break;
            case '\n': out += "\\n"; break;
            case '\r': out += "\\r"; break;
            default: out += c;
        }
    }
    return out;
}
std::string copy_field(const std::optional<std::string>& text) { return text ? copy_field(*text) : "\\N"; }

int migrate_fleet_server(PgConnection& pg) {
    pg.exec("CREATE TABLE IF NOT EXISTS fleet_schema_version (version integer NOT NULL)");
    const int newest = static_cast<int>(std::size(kPgSchemaMigrations));
    for (;;) {
        pg.exec("BEGIN");
        try {
            pg.exec("LOCK TABLE fleet_schema_version IN EXCLUSIVE MODE");
            const auto rows = pg.query("SELECT coalesce(max(version), 0) FROM fleet_schema_version");
            const int have = std::stoi(*rows.at(0).at(0));
            if (have > newest)
                throw DbError("fleet server " + pg.uri() + " has schema version " + std::to_string(have) + ", newer than this emadiag (" +
                                  std::to_string(newest) + ")",
                              DbErrorKind::Invalid);
            if (have == newest) {
                pg.exec("COMMIT");
                return have;
            }
            pg.exec(kPgSchemaMigrations[have]);
            pg.exec("DELETE FROM fleet_schema_version; INSERT INTO fleet_schema_version VALUES (" + std::to_string(have + 1) + ")");
            pg.exec("GRANT SELECT ON fleet_schema_version TO emadiag_station");
            pg.exec("COMMIT");
        } catch (...) {
            try {
                pg.exec("ROLLBACK");
            } catch (...) {
            }
            throw;
        }
    }
}

void add_station_role(PgConnection& pg, const std::string& role) {
    bool ok = !role.empty() && role.size() <= 63;
    for (char c : role) ok = ok && ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_');
    if (!ok) throw DbError("station role '" + role + "': use 1 to 63 of a-z, 0-9 and '_'", DbErrorKind::Invalid);
    const auto exists = pg.query("SELECT 1 FROM pg_roles WHERE rolname = $1", {role});
    if (exists.empty()) pg.exec("CREATE ROLE " + role + " LOGIN NOSUPERUSER NOCREATEDB NOCREATEROLE NOBYPASSRLS");
    pg.exec("GRANT emadiag_station TO " + role);
}

}  // namespace emadiag::db
