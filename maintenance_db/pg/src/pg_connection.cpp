#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"

#include "pg_schema_sql.hpp"

#include <libpq-fe.h>

#include <iterator>
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
        throw DbError("fleet server address is not a valid PostgreSQL connection URI: " + m, DbErrorKind::Invalid);
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
        const std::string msg = error_of(conn_, nullptr, "cannot connect to " + uri);
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

bool PgConnection::RowView::is_null(int column) const { return PQgetisnull(result_, row_, column) != 0; }
std::string_view PgConnection::RowView::text(int column) const {
    return {PQgetvalue(result_, row_, column), static_cast<std::size_t>(PQgetlength(result_, row_, column))};
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
