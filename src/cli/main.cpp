// emadiag: ground-maintenance diagnostics for EMA transmissions.
#include "cli/command.hpp"
#include "emadiag/can/ema_icd.hpp"

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
    app.require_subcommand(1);
    // The actuator's own ICD for every command that speaks CAN (issue 25 part 1); given before or
    // after the command name (fallthrough).
    std::string dbc_path;
    bool dbc_strict = false;
    app.add_option("--dbc", dbc_path, "the actuator's DBC (ICD) instead of the built-in ema.dbc; refused when it lacks a message or signal the tool needs");
    app.add_flag("--dbc-strict", dbc_strict, "read --dbc strictly: a problem cantools' lenient mode lets pass refuses the file");
    app.fallthrough();
    auto& cmds = registry();
    std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) { return a.name < b.name; });
    std::function<int()> action;
    for (auto& c : cmds) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        auto run = c.setup(*sub);
        sub->callback([&action, run] { action = run; });
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    try {
        if (!dbc_path.empty())
            for (const auto& w : emadiag::can::use_ema_dbc_file(dbc_path, dbc_strict ? emadiag::can::DbcMode::Strict : emadiag::can::DbcMode::Lenient))
                std::cerr << "emadiag: warning: " << w << '\n';
        return action ? action() : 1;
    } catch (const std::exception& e) {
        std::cerr << "emadiag: error: " << e.what() << '\n';
        return 1;
    }
}
