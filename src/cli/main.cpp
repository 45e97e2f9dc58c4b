// emadiag: ground-maintenance diagnostics for EMA transmissions.
#include "cli/cli_manual.hpp"
#include "cli/command.hpp"
#include "cli/version.hpp"

#include <algorithm>
#include <exception>
#include <iostream>
#include <memory>

namespace emadiag::cli {

std::vector<Command>& registry() {
    static std::vector<Command> commands;
    return commands;
}

bool register_command(Command c) {
    registry().push_back(std::move(c));
    return true;
}

}  // namespace emadiag::cli

int main(int argc, char** argv) {
    using namespace emadiag::cli;
    CLI::App app{"emadiag: ground-maintenance diagnostics for electromechanical flight-control actuators"};
    app.name("emadiag");
    app.require_subcommand(1);
    app.set_version_flag("--version", [] { return version_text(); }, "Print the release, git description, build type, build id and SIMD targets");
    std::string models_dir;
    app.add_option("--models", models_dir, "Folder of the shipped network models, instead of the installed one (as EMADIAG_MODELS_DIR)");
    auto& cmds = registry();
    std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) { return a.name < b.name; });
    std::function<int()> action;
    for (auto& c : cmds) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        auto run = c.setup(*sub);
        sub->callback([&action, run] { action = run; });
    }
    add_help_command(app, action);
    add_generate_docs_command(app, action);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    try {
        apply_models_override(models_dir);
        return action ? action() : 1;
    } catch (const std::exception& e) {
        std::cerr << "emadiag: error: " << e.what() << '\n';
        return 1;
    }
}
