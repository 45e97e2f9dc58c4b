#pragma once
// What the CLI says about itself, generated from its own CLI11 definitions so that it cannot drift
// (issue 26): `emadiag help [COMMAND]`, the manual pages (emadiag(1) and emadiag-COMMAND(1), roff) and
// the bash and zsh completion scripts, written at build time by the hidden `emadiag generate-docs`.
#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace emadiag::cli {

/// `emadiag help [COMMAND]`: the help of the app or of one subcommand. Add after every subcommand.
/// Sets `action` to print the help when chosen.
void add_help_command(CLI::App& app, std::function<int()>& action);

/// The hidden `emadiag generate-docs --man-dir DIR --bash FILE --zsh FILE`; sets `action` when chosen.
void add_generate_docs_command(CLI::App& app, std::function<int()>& action);

/// emadiag.1 (the app) or emadiag-NAME.1 (`sub` given): roff text.
[[nodiscard]] std::string man_page(const CLI::App& app, const CLI::App* sub);

/// The bash completion script: subcommands, their options, and the values of enumerated options
/// (CLI::IsMember) and positionals.
[[nodiscard]] std::string bash_completion(const CLI::App& app);

/// The zsh completion script (_emadiag), same content.
[[nodiscard]] std::string zsh_completion(const CLI::App& app);

}  // namespace emadiag::cli
