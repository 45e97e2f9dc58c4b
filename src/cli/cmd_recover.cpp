// emadiag recover --db FILE: stores the test sessions spooled beside the maintenance database
// that were never stored (the tool was killed mid-run, the database was locked or the disk full).
// The next `emadiag test-run` on the same database does the same before it starts. A manifest that
// names a file outside its spool directory, or is otherwise bad, is reported (name and reason) and
// left in place; the others are stored; the exit status is 1 when any was refused.
#include "cli/command.hpp"
#include "cli/db_source.hpp"

#include "diagnosis/session_spool.hpp"

#include <iostream>
#include <memory>

namespace emadiag::cli {
namespace {

const bool registered = register_command(Command{
    "recover", "Store the test sessions left in the spool beside the database (killed run, locked database, full disk)",
    [](CLI::App& sub) -> std::function<int()> {
        auto db = std::make_shared<std::string>("maintenance.db");
        sub.add_option("--db", *db, "Maintenance database (SQLite); its spool is DB.spool/")->capture_default_str()->check(sqlite_path());
        return [db] {
            const auto dir = spool_dir_for(*db);
            const auto recovered = recover_spooled_sessions(*db, [](const std::string& line) { std::cout << line << '\n' << std::flush; });
            std::size_t stored = 0, empty = 0, refused = 0;
            for (const auto& r : recovered) {
                stored += r.db_session_id > 0 ? 1 : 0;
                empty += r.nothing_recorded ? 1 : 0;
                refused += r.refused ? 1 : 0;
            }
            std::cout << "recover: " << stored << " spooled session(s) stored in " << io::escape_text(*db) << ", " << recovered.size() - stored - empty - refused
                      << " found already stored, " << empty << " with nothing recorded, " << refused << " refused (left in place); spool "
                      << io::escape_text(dir.string()) << '\n';
            for (const auto& r : recovered)
                if (r.refused) std::cerr << "emadiag: recover: " << io::escape_text(r.manifest.filename().string()) << ": " << io::escape_text(r.note) << '\n';
            return refused == 0 ? 0 : 1;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
