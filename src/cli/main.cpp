// emadiag: ground-maintenance diagnostics for EMA transmissions.
#include "cli/cli_manual.hpp"
#include "cli/command.hpp"
#include "cli/version.hpp"

#include "emadiag/io/text_field.hpp"
#include "emadiag/io/uri.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "cli/numeric_option.hpp"

#include <algorithm>
#include <exception>
#include <iostream>
#include <memory>
#include <sstream>

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
    add_help_command(app, action);
    add_generate_docs_command(app, action);
    check_every_number(app);  // one strict parser for every numeric option (numeric_option.hpp)
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // CLI11 repeats what was typed (an unexpected argument, a value): no password, no escape sequence.
        std::ostringstream out, err;
        const int code = app.exit(e, out, err);
        std::cout << emadiag::io::redact_uri_passwords(out.str());  // help and version text: ours
        std::cerr << emadiag::io::escape_text(emadiag::io::redact_uri_passwords(err.str()), true);
        return code;
    }
    try {
        apply_models_override(models_dir);
        if (!dbc_path.empty())
            for (const auto& w : emadiag::can::use_ema_dbc_file(dbc_path, dbc_strict ? emadiag::can::DbcMode::Strict : emadiag::can::DbcMode::Lenient))
                std::cerr << "emadiag: warning: " << emadiag::io::escape_text(w, true) << '\n';
        return action ? action() : 1;
    } catch (const std::exception& e) {
        // Messages quote file names, CSV cells and URIs: printed with control characters made visible
        // (line breaks kept: a message may list several problems) and passwords redacted.
        std::cerr << "emadiag: error: " << emadiag::io::escape_text(emadiag::io::redact_uri_passwords(e.what()), true) << '\n';
        return 1;
    }
}
