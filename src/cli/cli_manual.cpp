// The CLI's manual pages, completion scripts and `help` command, generated from the CLI11 tree that
// main.cpp builds from the registered subcommands (command.hpp): one source for the options, their
// descriptions, defaults and enumerated values (CLI::IsMember), so the manual cannot drift from the
// parser. Written at build time by the hidden `emadiag generate-docs` (src/CMakeLists.txt).
#include "cli/cli_manual.hpp"

#include "cli/output_file.hpp"
#include "cli/version.hpp"
#include "core/data_location.hpp"
#include "core/emadiag_error.hpp"

#include <emadiag/sim/simulator.hpp>

#include <filesystem>
#include <iostream>
#include <memory>
#include <regex>
#include <sstream>

namespace emadiag::cli {
namespace {

constexpr const char* kHelpCommand = "help";
constexpr const char* kGenerateDocsCommand = "generate-docs";

/// What the generators need to know of one option.
struct OptionInfo {
    std::vector<std::string> names;  ///< "--db", "-h"; empty for a positional
    std::string positional_name;     ///< "RUN" for a positional
    std::string type;                ///< "TEXT", "INT", ... (CLI11's type name without its validators)
    std::string description;
    std::string default_value;
    std::vector<std::string> values;  ///< the enumerated values (CLI::IsMember), if any
    bool takes_value = false;
    bool required = false;
};

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : s) {
        if (c == sep) {
            out.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    out.push_back(cur);
    return out;
}

OptionInfo info_of(const CLI::Option& o) {
    OptionInfo i;
    for (const auto& n : o.get_snames()) i.names.push_back("-" + n);
    for (const auto& n : o.get_lnames()) i.names.push_back("--" + n);
    if (i.names.empty()) i.positional_name = o.get_name(true);
    const std::string type = o.get_type_name();
    i.type = type.substr(0, type.find(':'));
    i.description = o.get_description();
    i.default_value = o.get_default_str();
    i.takes_value = o.get_items_expected_max() > 0;
    i.required = o.get_required();
    // CLI::IsMember describes itself as {a,b,c} in the type name ("TEXT:{text,json,csv}").
    static const std::regex member_set(":\\{([^{}]*)\\}");
    std::smatch m;
    if (std::regex_search(type, m, member_set)) i.values = split(m[1].str(), ',');
    return i;
}

std::vector<OptionInfo> options_of(const CLI::App& app) {
    std::vector<OptionInfo> out;
    for (const CLI::Option* o : app.get_options()) out.push_back(info_of(*o));
    return out;
}

/// The subcommands a user sees (a hidden one has an empty group).
std::vector<const CLI::App*> visible_commands(const CLI::App& app) {
    return app.get_subcommands([](const CLI::App* s) { return !s->get_group().empty(); });
}

std::string upper(std::string s) {
    for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

/// Text for roff: backslashes escaped, a leading '.' or '\'' made literal.
std::string roff(const std::string& s) {
    std::string out;
    for (char c : s) out += c == '\\' ? std::string("\\e") : std::string(1, c);
    if (!out.empty() && (out[0] == '.' || out[0] == '\'')) out = "\\&" + out;
    return out;
}

/// An option name in roff: bold, with the minus signs as minus signs.
std::string roff_option(const std::string& name) {
    std::string out = "\\fB";
    for (char c : name) out += c == '-' ? std::string("\\-") : std::string(1, c);
    return out + "\\fR";
}

std::string joined(const std::vector<std::string>& v, const std::string& sep) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
    return s;
}

std::string th(const std::string& title) {
    return ".TH " + upper(title) + " 1 \"\" \"emadiag " + build_info::kRelease + "\" \"emadiag manual\"\n";
}

void man_options(std::ostringstream& os, const std::vector<OptionInfo>& options) {
    for (const auto& o : options) {
        os << ".TP\n";
        if (o.names.empty()) {
            os << "\\fI" << roff(o.positional_name) << "\\fR\n";
        } else {
            std::vector<std::string> names;
            for (const auto& n : o.names) names.push_back(roff_option(n));
            os << joined(names, ", ") << (o.takes_value ? " \\fI" + roff(o.type) + "\\fR" : "") << '\n';
        }
        os << roff(o.description.empty() ? "(no description)" : o.description) << '\n';
        if (!o.values.empty()) os << ".br\nValues: " << roff(joined(o.values, ", ")) << ".\n";
        if (!o.default_value.empty()) os << ".br\nDefault: " << roff(o.default_value) << ".\n";
        if (o.required) os << ".br\nRequired.\n";
    }
}

std::string synopsis_of(const CLI::App& sub) {
    std::string s = ".B emadiag " + roff(sub.get_name()) + "\n";
    bool optional = false;
    for (const auto& o : options_of(sub)) {
        if (o.names.empty()) {
            s += o.required ? "\\fI" + roff(o.positional_name) + "\\fR\n" : "[\\fI" + roff(o.positional_name) + "\\fR]\n";
        } else if (o.required) {
            s += roff_option(o.names.back()) + (o.takes_value ? " \\fI" + roff(o.type) + "\\fR" : "") + "\n";
        } else {
            optional = true;
        }
    }
    if (optional) s += "[\\fIOPTIONS\\fR]\n";
    return s;
}

/// A word list for a shell script (the names and values are plain words; quotes are dropped).
std::string words(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& w : v) {
        std::string clean;
        for (char c : w)
            if (c != '"' && c != '\'' && c != '\\' && c != '$' && c != '`') clean += c;
        s += (s.empty() ? "" : " ") + clean;
    }
    return s;
}

/// Text inside a zsh single-quoted _arguments description: quotes closed and reopened, brackets escaped.
std::string zsh_description(const std::string& d) {
    std::string out;
    for (char c : d) {
        if (c == '\'') out += "'\\''";
        else if (c == '[' || c == ']') out += std::string("\\") + c;
        else out += c;
    }
    return out;
}

std::string zsh_message(const std::string& type) {
    std::string out;
    for (char c : type)
        if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ' ') out += c;
    return out.empty() ? "value" : out;
}

}  // namespace

std::string man_page(const CLI::App& app, const CLI::App* sub) {
    std::ostringstream os;
    if (sub) {
        const std::string name = "emadiag-" + sub->get_name();
        os << th(name) << ".SH NAME\n" << roff(name) << " \\- " << roff(sub->get_description()) << '\n'
           << ".SH SYNOPSIS\n" << synopsis_of(*sub) << ".SH DESCRIPTION\n" << roff(sub->get_description()) << ".\n"
           << ".PP\nThis page is generated from the command's own option definitions (\\fBemadiag help " << roff(sub->get_name())
           << "\\fR prints the same).\n";
        if (!sub->get_footer().empty()) os << ".PP\n" << roff(sub->get_footer()) << '\n';
        os << ".SH OPTIONS\n";
        man_options(os, options_of(*sub));
        os << ".SH SEE ALSO\n.BR emadiag (1)\n";
        return os.str();
    }
    os << th("emadiag") << ".SH NAME\nemadiag \\- " << roff(app.get_description().substr(app.get_description().find(':') + 1 + 1)) << '\n'
       << ".SH SYNOPSIS\n.B emadiag\n[" << roff_option("--models") << " \\fIDIR\\fR] \\fICOMMAND\\fR [\\fIOPTIONS\\fR]\n.br\n"
       << ".B emadiag help\n[\\fICOMMAND\\fR]\n.br\n.B emadiag\n" << roff_option("--version") << '\n'
       << ".SH DESCRIPTION\n" << roff(app.get_description()) << ".\n.PP\nEach command has its own page, "
       << "\\fBemadiag\\-\\fR\\fICOMMAND\\fR(1); \\fBemadiag help\\fR \\fICOMMAND\\fR prints its options.\n"
       << ".SH OPTIONS\n";
    man_options(os, options_of(app));
    os << ".SH COMMANDS\n";
    for (const CLI::App* c : visible_commands(app))
        os << ".TP\n.BR emadiag\\-" << roff(c->get_name()) << " (1)\n" << roff(c->get_description()) << '\n';
    os << ".SH ENVIRONMENT\n.TP\n.B " << kModelsDirEnvVar
       << "\nThe folder of the shipped network models, instead of the installed one (as \\fB\\-\\-models\\fR; the tool says so on "
          "standard error).\n"
       << ".TP\n.B " << sim::kSimdEnvVar << "\nThe SIMD target of the batched simulator: best, scalar, "
       << roff(joined(sim::compiled_simd_targets(), ", ")) << " (one this CPU has).\n"
       << ".SH FILES\n.TP\n.I PREFIX/share/emadiag/models\nThe shipped network models (\\fI/usr/share/emadiag/models\\fR in the Debian "
          "package), found from the binary's own location, never from the current directory.\n"
       << ".TP\n.I PREFIX/share/emadiag/can_dbc/ema.dbc\nThe EMA's CAN interface (DBC).\n"
       << ".TP\n.I PREFIX/share/doc/emadiag\nThe documentation: README, docs/ (test run, record format, reports, fleet server).\n"
       << ".SH VERSION\n\\fBemadiag \\-\\-version\\fR prints the release, the git description, the build type, the build id and the "
          "SIMD targets; every stored session records the same tool version.\n"
       << ".SH SEE ALSO\n";
    std::vector<std::string> refs;
    for (const CLI::App* c : visible_commands(app)) refs.push_back(".BR emadiag\\-" + roff(c->get_name()) + " (1)");
    os << joined(refs, ",\n") << '\n';
    return os.str();
}

std::string bash_completion(const CLI::App& app) {
    std::ostringstream os;
    std::vector<std::string> commands;
    for (const CLI::App* c : visible_commands(app)) commands.push_back(c->get_name());
    std::vector<std::string> global;
    std::vector<std::string> global_valued;
    for (const auto& o : options_of(app)) {
        for (const auto& n : o.names) {
            global.push_back(n);
            if (o.takes_value) global_valued.push_back(n);
        }
    }
    os << "# bash completion for emadiag: generated by `emadiag generate-docs` from the CLI's own definitions; do not edit.\n"
       << "_emadiag() {\n"
       << "    local cur prev cmd i\n"
       << "    cur=\"${COMP_WORDS[COMP_CWORD]}\"\n"
       << "    prev=\"${COMP_WORDS[COMP_CWORD-1]}\"\n"
       << "    cmd=\"\"\n"
       << "    for ((i = 1; i < COMP_CWORD; i++)); do\n"
       << "        case \"${COMP_WORDS[i]}\" in\n"
       << (global_valued.empty() ? "" : "            " + joined(global_valued, "|") + ") ((i++)) ;;\n")
       << "            -*) ;;\n"
       << "            *) cmd=\"${COMP_WORDS[i]}\"; break ;;\n"
       << "        esac\n"
       << "    done\n"
       << "    case \"$cmd\" in\n"
       << "    \"\")\n";
    if (!global_valued.empty())
        os << "        case \"$prev\" in\n            " << joined(global_valued, "|")
           << ") COMPREPLY=($(compgen -d -- \"$cur\")); return ;;\n        esac\n";
    os << "        COMPREPLY=($(compgen -W \"" << words(commands) << ' ' << words(global) << "\" -- \"$cur\"))\n"
       << "        ;;\n";
    for (const CLI::App* c : visible_commands(app)) {
        const auto opts = options_of(*c);
        std::vector<std::string> names, positional_values, file_valued;
        os << "    " << c->get_name() << ")\n        case \"$prev\" in\n";
        for (const auto& o : opts) {
            if (o.names.empty()) {
                positional_values.insert(positional_values.end(), o.values.begin(), o.values.end());
                continue;
            }
            names.insert(names.end(), o.names.begin(), o.names.end());
            if (!o.takes_value) continue;
            if (!o.values.empty())
                os << "            " << joined(o.names, "|") << ") COMPREPLY=($(compgen -W \"" << words(o.values) << "\" -- \"$cur\")); return ;;\n";
            else
                file_valued.insert(file_valued.end(), o.names.begin(), o.names.end());
        }
        if (!file_valued.empty()) os << "            " << joined(file_valued, "|") << ") COMPREPLY=($(compgen -f -- \"$cur\")); return ;;\n";
        os << "        esac\n"
           << "        if [[ -z \"$cur\" || \"$cur\" == -* ]]; then\n"
           << "            COMPREPLY=($(compgen -W \"" << words(names) << ' ' << words(positional_values) << "\" -- \"$cur\"))\n"
           << "        else\n"
           << "            COMPREPLY=($(compgen -W \"" << words(positional_values) << "\" -- \"$cur\"))\n"
           << "            [[ ${#COMPREPLY[@]} -eq 0 ]] && COMPREPLY=($(compgen -f -- \"$cur\"))\n"
           << "        fi\n"
           << "        ;;\n";
    }
    os << "    esac\n"
       << "}\n"
       << "complete -o filenames -F _emadiag emadiag\n";
    return os.str();
}

std::string zsh_completion(const CLI::App& app) {
    std::ostringstream os;
    const auto spec = [](const OptionInfo& o) {
        std::string s;
        for (const auto& n : o.names) {
            s += " \\\n        '" + n + "[" + zsh_description(o.description) + "]";
            if (o.takes_value)
                s += ":" + zsh_message(o.type) + ":" + (o.values.empty() ? std::string("_files") : "(" + words(o.values) + ")");
            s += "'";
        }
        if (o.names.empty())
            s += " \\\n        '*:" + zsh_message(o.positional_name) + ":" + (o.values.empty() ? std::string("_files") : "(" + words(o.values) + ")") + "'";
        return s;
    };
    os << "#compdef emadiag\n# zsh completion for emadiag: generated by `emadiag generate-docs` from the CLI's own definitions; do not edit.\n"
       << "_emadiag() {\n    local curcontext=\"$curcontext\" state line\n    typeset -A opt_args\n    local -a commands\n    commands=(\n";
    for (const CLI::App* c : visible_commands(app)) os << "        '" << c->get_name() << ":" << zsh_description(c->get_description()) << "'\n";
    os << "    )\n    _arguments -C";
    for (const auto& o : options_of(app))
        if (!o.names.empty()) os << spec(o);
    os << " \\\n        '1:command:->command' \\\n        '*::argument:->argument'\n"
       << "    case $state in\n    command) _describe -t commands 'emadiag command' commands ;;\n    argument)\n        case $words[1] in\n";
    for (const CLI::App* c : visible_commands(app)) {
        os << "        " << c->get_name() << ")\n            _arguments";
        for (const auto& o : options_of(*c)) os << spec(o);
        os << " ;;\n";
    }
    os << "        esac ;;\n    esac\n}\n_emadiag \"$@\"\n";
    return os.str();
}

void add_help_command(CLI::App& app, std::function<int()>& action) {
    std::vector<std::string> names;
    for (const CLI::App* c : visible_commands(app)) names.push_back(c->get_name());
    CLI::App* help = app.add_subcommand(kHelpCommand, "Print the options of a command (or list the commands)");
    auto command = std::make_shared<std::string>();
    help->add_option("COMMAND", *command, "The command whose options to print")->check(CLI::IsMember(names));
    help->callback([&app, &action, command] {
        action = [&app, command] {
            std::cout << (command->empty() ? app.help() : app.get_subcommand(*command)->help("emadiag"));
            return 0;
        };
    });
}

void add_generate_docs_command(CLI::App& app, std::function<int()>& action) {
    CLI::App* gen = app.add_subcommand(kGenerateDocsCommand, "Write the manual pages and completion scripts (build step)");
    gen->group("");  // hidden: not listed, not completed, no manual page
    struct Out {
        std::string man_dir, bash, zsh;
    };
    auto o = std::make_shared<Out>();
    gen->add_option("--man-dir", o->man_dir, "Folder for emadiag.1 and emadiag-COMMAND.1")->required();
    gen->add_option("--bash", o->bash, "The bash completion script")->required();
    gen->add_option("--zsh", o->zsh, "The zsh completion script (_emadiag)")->required();
    gen->callback([&app, &action, o] { action = [&app, o] {
        std::error_code ec;
        std::filesystem::create_directories(o->man_dir, ec);
        if (ec) throw EmadiagError(o->man_dir + ": cannot create the manual folder: " + ec.message());
        const std::filesystem::path dir(o->man_dir);
        write_output((dir / "emadiag.1").string(), man_page(app, nullptr));
        int pages = 1;
        for (const CLI::App* c : visible_commands(app)) {
            write_output((dir / ("emadiag-" + c->get_name() + ".1")).string(), man_page(app, c));
            ++pages;
        }
        write_output(o->bash, bash_completion(app));
        write_output(o->zsh, zsh_completion(app));
        std::cerr << "generate-docs: " << pages << " manual pages in " << o->man_dir << ", completion " << o->bash << " and " << o->zsh << '\n';
        return 0;
    }; });
}

}  // namespace emadiag::cli
