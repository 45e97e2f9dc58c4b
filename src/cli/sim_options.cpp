#include "cli/sim_options.hpp"

#include "cli/numeric_option.hpp"

#include "emadiag/sim/sim_error.hpp"

#include <stdexcept>

namespace emadiag::cli {

void add_simulation_options(CLI::App& sub, SimulateOptions& o) {
    sub.add_option("--case", o.load_case, "Load case: A, A-ext or B")->capture_default_str();
    sub.add_option("--sequence", o.sequence, "Test sequence: dyn, brk or sweep")->capture_default_str();
    sub.add_option("--fdj", o.fdj, "Dynamic dry friction FDJ, N m (motor side)");
    sub.add_option("--fsj", o.fsj, "Static dry friction FSJ, N m (motor side)");
    sub.add_option("--eta-a", o.eta_a, "Efficiency under aiding load (eta_O from eq. 4)");
    sub.add_option("--eta-o", o.eta_o, "Efficiency under opposing load (eta_A from eq. 4)");
    sub.add_option("--params", o.params_file, "Parameter JSON file (datasheet by default)")->check(CLI::ExistingFile);
    sub.add_option("--effect", o.effects, "Effect beyond the datasheet, NAME=VALUE (repeatable)");
    sub.add_option("--term", o.terms,
                   "Extra torque or sensor term, e.g. 'torque: 0.02*sgn(w)*abs(theta_u)' or 'current: 0.05' (repeatable; "
                   "docs/discovery.md)");
    sub.add_option("--noise", o.noise, "Noise profile: none or typical")->capture_default_str();
    sub.add_option("--seed", o.seed, "Noise seed")->capture_default_str();
}

/// Builds a SimConfig from the options shared by simulate, dataset and ema-sim.
sim::SimConfig config_from(const SimulateOptions& o) {
    sim::SimConfig c;
    c.params = o.params_file.empty() ? sim::EmaParams::datasheet() : sim::EmaParams::from_json_file(o.params_file);
    if (o.eta_a && o.eta_o) throw sim::SimError("give --eta-a or --eta-o, not both (eq. 4 links them)");
    if (o.fdj) c.params.fdj_nm = *o.fdj;
    if (o.fsj) c.params.fsj_nm = *o.fsj;
    if (o.eta_o) {
        c.params.eta_o = *o.eta_o;
        c.params.eta_a = sim::eta_a_from_eta_o(*o.eta_o, c.params.tau);
    }
    if (o.eta_a) {
        c.params.eta_a = *o.eta_a;
        c.params.eta_o = sim::eta_o_from_eta_a(*o.eta_a, c.params.tau);
    }
    for (const auto& e : o.effects) {
        const auto eq = e.find('=');
        if (eq == std::string::npos) throw sim::SimError("--effect '" + e + "': expected NAME=VALUE");
        double v = 0;
        try {
            std::size_t used = 0;
            v = std::stod(e.substr(eq + 1), &used);
            if (used != e.size() - eq - 1) throw std::invalid_argument("trailing");
        } catch (const std::exception&) {
            throw sim::SimError("--effect '" + e + "': value '" + e.substr(eq + 1) + "' is not a number");
        }
        c.params.effects.set(e.substr(0, eq), v);
    }
    if (o.terms.size() > kMaxTerms) {
        throw sim::SimError("--term given " + std::to_string(o.terms.size()) + " times, more than the limit kMaxTerms = " +
                            std::to_string(kMaxTerms));
    }
    for (const auto& t : o.terms) {
        // The term grammar nests one function call deep; a longer text is refused before parsing, so
        // the message stays short (it quotes at most kMaxQuotedOptionChars characters).
        if (t.size() > kMaxTermChars) {
            throw sim::SimError("--term " + quote_option_text(t) + " is longer than the limit kMaxTermChars = " +
                                std::to_string(kMaxTermChars) + " characters");
        }
        c.params.terms.push_back(sim::parse_term(t));
    }
    c.params.validate();
    c.load_case = sim::parse_load_case(o.load_case);
    c.sequence = sim::parse_sequence(o.sequence);
    c.noise = sim::parse_noise(o.noise);
    c.seed = o.seed;
    return c;
}


}  // namespace emadiag::cli
