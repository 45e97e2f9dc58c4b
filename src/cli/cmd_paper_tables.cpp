// emadiag paper-tables: the seed paper's Tables 2 to 8 regenerated on fresh data, paper beside ours.
#include "cli/command.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "research/paper_tables.hpp"

#include <algorithm>
#include <iostream>
#include <memory>
#include <thread>

namespace emadiag::cli {
namespace {

struct PaperTablesCli {
    std::string out;
    bool quick = false;
    std::uint64_t seed = 2026;
    bool no_physics = false;
};

const bool registered = register_command(Command{
    "paper-tables", "Regenerate the paper's Tables 2-8 on fresh data (network and physics, paper beside ours)",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<PaperTablesCli>();
        sub.add_option("--out", o->out, "Markdown file to write")->required();
        sub.add_flag("--quick", o->quick, "Small counts (seconds), for tests; not the paper's setting");
        sub.add_option("--seed", o->seed, "Seed of every dataset, split and initialisation")->default_val(2026);
        sub.add_flag("--no-physics", o->no_physics, "Skip the physics estimator");
        return [o] {
            // Checked before the tables are computed (minutes), not when they are written.
            io::check_output_path<EmadiagError>(o->out, "paper tables");
            PaperTablesOptions p;
            p.quick = o->quick;
            p.seed = o->seed;
            p.physics = !o->no_physics;
            p.threads = std::max(1u, std::thread::hardware_concurrency());
            const std::string md = paper_tables_markdown(p, [](const std::string& line) { std::cerr << line << '\n'; });
            io::write_output_file<EmadiagError>(o->out, "paper tables", {}, md);
            std::cout << md;
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
