// emadiag: ground-maintenance diagnostics for EMA transmissions.
#include "cli/command.hpp"
#include "cli/numeric_option.hpp"

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
    auto& cmds = registry();
    std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) { return a.name < b.name; });
    std::function<int()> action;
    for (auto& c : cmds) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        auto run = c.setup(*sub);
        sub->callback([&action, run] { action = run; });
    }
    check_every_number(app);  // one strict parser for every numeric option (numeric_option.hpp)
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    try {
        return action ? action() : 1;
    } catch (const std::exception& e) {
        std::cerr << "emadiag: error: " << e.what() << '\n';
        return 1;
    }
}
