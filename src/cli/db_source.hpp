#pragma once
// --db for the reports: a station's SQLite file, or a fleet server as postgresql://... (libpq URI,
// never with a password in it: ~/.pgpass, PGPASSFILE or a service file hold that).
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace emadiag::cli {

/// An existing SQLite file, or a fleet server URI without a password. The message never repeats a URI.
inline CLI::Validator sqlite_file_or_fleet_uri() {
    return CLI::Validator(
        [](std::string& value) -> std::string {
            if (db::is_fleet_uri(value)) {
                try {
                    db::check_fleet_uri(value);
                } catch (const db::DbError& e) {
                    return e.what();
                }
                return {};
            }
            std::error_code ec;
            if (!std::filesystem::is_regular_file(value, ec)) return "File does not exist: " + value;
            return {};
        },
        "FILE or postgresql://...");
}

}  // namespace emadiag::cli
