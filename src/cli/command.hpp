#pragma once
// Each subcommand lives in its own cli/cmd_<name>.cpp and registers itself here.
#include "cli/version.hpp"  // EMADIAG_VERSION (src/CMakeLists.txt) expands to tool_version()

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace emadiag::cli {

struct Command {
    std::string name;
    std::string summary;
    /// Adds options to `sub`; returns the action to run when the subcommand is chosen (exit code).
    std::function<std::function<int()>(CLI::App& sub)> setup;
};

std::vector<Command>& registry();

/// Use at namespace scope in a command file: `static const bool registered = register_command({...});`
bool register_command(Command c);

}  // namespace emadiag::cli
