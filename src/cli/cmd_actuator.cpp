// emadiag actuator list|show|check [FILE|PART_NUMBER...] (issue 23 part 1): the actuator profiles
// (docs/actuator-profile.md). list: the installed profiles (part number, drive, output, file);
// show: one profile, every value with its unit ("unknown" for null; EMA-REF-1 when none is named);
// check: each file's problems (field, value, allowed range), exit 1 when one is not a valid profile.
#include "cli/actuator_option.hpp"
#include "cli/command.hpp"

#include "actuator/actuator_error.hpp"
#include "emadiag/io/text_field.hpp"

#include <iostream>
#include <memory>

namespace emadiag::cli {
namespace {

struct ActuatorOptions {
    std::string action;
    std::vector<std::string> targets;
};

int list_action(const ActuatorOptions& o) {
    if (!o.targets.empty()) throw actuator::ActuatorError("actuator list takes no FILE or PART_NUMBER (use show or check)");
    const auto folder = actuator::profile_folder(actuator_locations());
    if (!folder) throw actuator::ActuatorError("no actuator profile folder (installed or in the build tree)");
    std::cout << "actuator profiles in " << io::escape_text(folder->dir.string()) << " (" << folder->how << "):\n";
    std::size_t valid = 0, invalid = 0;
    for (const actuator::ListedProfile& l : actuator::list_profiles(folder->dir)) {
        const std::string file = io::escape_text(l.file.filename().string());
        if (!l.profile) {
            std::cout << "  INVALID  " << file << "  (emadiag actuator check " << io::escape_text(l.file.string()) << " says why)\n";
            ++invalid;
            continue;
        }
        const actuator::ActuatorProfile& p = *l.profile;
        std::cout << "  " << io::escape_text(p.part_number) << "  " << actuator::to_string(p.drive.kind) << "  "
                  << actuator::to_string(p.transmission.output) << "  " << file << "  " << io::escape_text(p.name) << '\n';
        ++valid;
    }
    std::cout << valid << " profile" << (valid == 1 ? "" : "s") << ", " << invalid << " invalid; default "
              << actuator::kDefaultPartNumber << '\n';
    return 0;
}

int show_action(const ActuatorOptions& o) {
    if (o.targets.size() > 1) throw actuator::ActuatorError("actuator show takes one FILE or PART_NUMBER, not " + std::to_string(o.targets.size()));
    const actuator::ActuatorProfile p = load_actuator_option(o.targets.empty() ? "" : o.targets[0]);
    for (const std::string& line : actuator::describe_profile(p)) std::cout << io::escape_text(line) << '\n';
    return 0;
}

int check_action(const ActuatorOptions& o) {
    if (o.targets.empty()) throw actuator::ActuatorError("actuator check needs at least one FILE or PART_NUMBER");
    int failed = 0;
    for (const std::string& t : o.targets) {
        try {
            const actuator::ActuatorProfile p = load_actuator_option(t);
            const std::vector<std::string> unknown = actuator::unknown_fields(p);
            std::cout << io::escape_text(p.path) << ": ok: " << io::escape_text(p.part_number) << " (" << actuator::to_string(p.drive.kind)
                      << " drive, " << actuator::to_string(p.transmission.output) << " output), sha256 " << p.sha256 << "; "
                      << unknown.size() << " value" << (unknown.size() == 1 ? "" : "s") << " unknown (null)";
            for (std::size_t i = 0; i < unknown.size(); ++i) std::cout << (i == 0 ? ": " : ", ") << unknown[i];
            std::cout << '\n';
        } catch (const actuator::ActuatorError& e) {
            std::cout << io::escape_text(e.what(), true) << '\n';
            ++failed;
        }
    }
    if (failed > 0) std::cerr << "emadiag: " << failed << " of " << o.targets.size() << " profiles refused\n";
    return failed > 0 ? 1 : 0;
}

const bool registered = register_command(Command{
    "actuator", "Actuator profiles: list the installed ones, show one with its units, check files (docs/actuator-profile.md)",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<ActuatorOptions>();
        sub.add_option("action", o->action, "list: the installed profiles; show: one profile with units (default EMA-REF-1); check: each file's problems")
            ->required()
            ->check(CLI::IsMember({"list", "show", "check"}));
        sub.add_option("profiles", o->targets, "FILE (a path, or a name ending in .json) or PART_NUMBER (looked up among the installed profiles)");
        return [o] {
            if (o->action == "list") return list_action(*o);
            if (o->action == "show") return show_action(*o);
            return check_action(*o);
        };
    }});

}  // namespace
}  // namespace emadiag::cli
