// emadiag sync --db station.db --to postgresql://HOST/DB [--batch 20000] [--verbose]:
//   pushes every session of the station the fleet server does not have yet (maintenance_db/pg,
//   docs/fleet-server.md); whole sessions per PostgreSQL transaction, recorded in the station file.
// emadiag fleet-server --to postgresql://HOST/DB [--add-station ROLE]...:
//   as the fleet database's owner: brings its schema to the newest version and creates station roles.
// A URI with a password is refused: ~/.pgpass, PGPASSFILE or a service file hold passwords.
#include "cli/command.hpp"
#include "cli/db_source.hpp"

#include "emadiag/db/database.hpp"
#include "emadiag/db/pg_fleet.hpp"

#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

struct SyncCliOptions {
    std::string db = "maintenance.db";
    std::string to;
    std::size_t batch = 20000;
    bool verbose = false;
};

CLI::Validator fleet_uri() {
    return CLI::Validator(
        [](std::string& value) -> std::string {
            if (!db::is_fleet_uri(value)) return "expected a fleet server URI postgresql://HOST/DATABASE (docs/fleet-server.md)";
            try {
                db::check_fleet_uri(value);
            } catch (const db::DbError& e) {
                return e.what();
            }
            return {};
        },
        "postgresql://...");
}

const bool registered_sync = register_command(Command{
    "sync", "Push the station's sessions (runs, raw logs, estimates, findings, installations, discoveries) to the fleet server (PostgreSQL)",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<SyncCliOptions>();
        sub.add_option("--db", o->db, "The station's maintenance database (SQLite)")->capture_default_str()->check(sqlite_file());
        sub.add_option("--to", o->to, "Fleet server: postgresql://HOST[:PORT]/DATABASE?user=ROLE (no password in it)")
            ->required()
            ->check(fleet_uri());
        sub.add_option("--batch", o->batch, "Whole sessions per PostgreSQL transaction")->capture_default_str()->check(CLI::Range(1, 1000000));
        sub.add_flag("--verbose", o->verbose, "One line per committed batch, and one per batch read ahead while the server inserts the one before");
        return [o] {
            db::Database station(o->db);
            db::SyncOptions so;
            so.batch_sessions = o->batch;
            if (o->verbose) so.progress = [](const std::string& line) { std::cout << "sync: " << line << '\n' << std::flush; };
            const db::SyncResult r = db::sync_to_fleet(station, o->to, so);
            std::ostringstream rate;
            rate << std::fixed << std::setprecision(0) << (r.seconds > 0 ? static_cast<double>(r.sessions_pushed) / r.seconds : 0.0);
            std::cout << "sync: station " << r.station_uuid << " (" << io::escape_text(o->db) << ") -> " << io::escape_text(io::redact_uri_passwords(o->to)) << ": " << r.sessions_pushed
                      << " session(s) pushed in " << r.batches << " transaction(s) (" << r.runs << " runs, " << r.samples << " samples, "
                      << r.raw_log_bytes << " raw-log bytes), " << r.sessions_recovered
                      << " already on the server from an earlier sync and now recorded, " << r.discovery_findings
                      << " discovery finding(s); " << r.retries << " retries; " << std::fixed << std::setprecision(2) << r.seconds << " s ("
                      << rate.str() << " sessions/s)\n";
            return 0;
        };
    }});

const bool registered_server = register_command(Command{
    "fleet-server", "As the fleet database's owner: create or migrate the fleet server's schema (PostgreSQL) and add station roles",
    [](CLI::App& sub) -> std::function<int()> {
        auto to = std::make_shared<std::string>();
        auto roles = std::make_shared<std::vector<std::string>>();
        sub.add_option("--to", *to, "Fleet server: postgresql://HOST[:PORT]/DATABASE?user=OWNER (no password in it)")->required()->check(fleet_uri());
        sub.add_option("--add-station", *roles, "Create this station login role (member of emadiag_station: insert its own, read all)");
        return [to, roles] {
            db::PgConnection pg(*to);
            const int v = db::migrate_fleet_server(pg);
            std::cout << "fleet-server: " << *to << " at schema version " << v << '\n';
            for (const auto& r : *roles) {
                db::add_station_role(pg, r);
                std::cout << "fleet-server: station role " << r << " (insert its own sessions, read the fleet; no update, no delete)\n";
            }
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
