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
            const auto st = std::filesystem::status(value, ec);
            if (!std::filesystem::exists(st)) return "database file does not exist: " + value;
            if (std::filesystem::is_directory(st)) return value + " is a directory, not a database file";
            if (!std::filesystem::is_regular_file(st)) return value + " is not a regular file (a device, FIFO or socket)";
            return {};
        },
        "FILE or postgresql://...");
}

}  // namespace emadiag::cli
