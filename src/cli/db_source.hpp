#pragma once
// --db for the reports: a station's SQLite file, or a fleet server as postgresql://... (libpq URI,
// never with a password in it: ~/.pgpass, PGPASSFILE or a service file hold that).
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/io/uri.hpp"

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
            if (!std::filesystem::exists(st)) return "database file does not exist: " + io::escape_text(value);
            if (std::filesystem::is_directory(st)) return io::escape_text(value) + " is a directory, not a database file";
            if (!std::filesystem::is_regular_file(st)) return io::escape_text(value) + " is not a regular file (a device, FIFO or socket)";
            return {};
        },
        "FILE or postgresql://...");
}

/// Why `value` is no SQLite file path (a URI: postgresql://..., any scheme://), without repeating its
/// password; empty when it may be one.
inline std::string uri_given_for_sqlite(const std::string& value) {
    if (!io::has_uri_scheme(value)) return {};
    return "this command works on a station's SQLite file only, not a URI (" + io::escape_text(io::redact_uri_passwords(value)) + ")";
}

/// A SQLite file that may not exist yet (import, history-sim, test-run, recover create it): a URI is
/// refused and nothing is created.
inline CLI::Validator sqlite_path() { return CLI::Validator(uri_given_for_sqlite, "FILE"); }

/// An existing SQLite file, for the commands that work on the station's file only (verify, export,
/// sync's station, discover): a URI is refused.
inline CLI::Validator sqlite_file() {
    return CLI::Validator(
        [](std::string& value) -> std::string {
            if (auto problem = uri_given_for_sqlite(value); !problem.empty()) return problem;
            std::error_code ec;
            if (!std::filesystem::is_regular_file(value, ec)) return "File does not exist: " + io::escape_text(value);
            return {};
        },
        "FILE");
}

}  // namespace emadiag::cli
