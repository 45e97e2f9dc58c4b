// emadiag simulate: one run of the reference EMA (sim_backend) written as a run CSV.
#include "cli/command.hpp"
#include "core/run_csv.hpp"
#include "core/run_summary.hpp"
#include "core/sim_run.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "emadiag/sim/simulator.hpp"

#include <iostream>
#include <optional>

namespace emadiag::cli {
namespace {

struct SimulateOptions {
    std::string load_case = "B";
    std::string sequence = "dyn";
    std::optional<double> fdj, fsj, eta_a, eta_o;
    std::string params_file;
    std::vector<std::string> effects;
    std::string noise = "none";
    std::uint64_t seed = 1;
    std::string out;
};

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
    c.params.validate();
    c.load_case = sim::parse_load_case(o.load_case);
    c.sequence = sim::parse_sequence(o.sequence);
    c.noise = sim::parse_noise(o.noise);
    c.seed = o.seed;
    return c;
}

const bool registered = register_command(Command{
    "simulate", "Simulate the reference EMA (sim_backend) and write a run CSV",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<SimulateOptions>();
        sub.add_option("--case", o->load_case, "Load case: A, A-ext or B")->capture_default_str();
        sub.add_option("--sequence", o->sequence, "Test sequence: dyn, brk or sweep")->capture_default_str();
        sub.add_option("--fdj", o->fdj, "Dynamic dry friction FDJ, N m (motor side)");
        sub.add_option("--fsj", o->fsj, "Static dry friction FSJ, N m (motor side)");
        sub.add_option("--eta-a", o->eta_a, "Efficiency under aiding load (eta_O from eq. 4)");
        sub.add_option("--eta-o", o->eta_o, "Efficiency under opposing load (eta_A from eq. 4)");
        sub.add_option("--params", o->params_file, "Parameter JSON file (datasheet by default)")->check(CLI::ExistingFile);
        sub.add_option("--effect", o->effects, "Effect beyond the datasheet, NAME=VALUE (repeatable)");
        sub.add_option("--noise", o->noise, "Noise profile: none or typical")->capture_default_str();
        sub.add_option("--seed", o->seed, "Noise seed")->capture_default_str();
        sub.add_option("--out", o->out, "Output run CSV (summary only when omitted)");
        return [o] {
            const sim::SimConfig config = config_from(*o);
            const sim::SimResult result = sim::simulate(config);
            if (!result.finite) throw sim::SimError("the simulation diverged (NaN or inf in the samples)");
            const Run run = make_run(config, result);
            if (!o->out.empty()) write_run_csv_file(o->out, run);
            std::cout << "EMA-REF-1 simulation: case " << run.load_case << ", sequence " << run.sequence << ", noise "
                      << o->noise << ", seed " << o->seed << '\n';
            std::cout << format_summary(summarise(run));
            if (!o->out.empty()) std::cout << "wrote " << run.samples.size() << " samples to " << o->out << '\n';
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
