// emadiag simulate: one run of the reference EMA (sim_backend) written as a run CSV.
#include "cli/command.hpp"
#include "cli/sim_options.hpp"
#include "core/run_csv.hpp"
#include "core/run_summary.hpp"
#include "core/sim_run.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "emadiag/sim/simulator.hpp"

#include <iostream>
#include <optional>

namespace emadiag::cli {
namespace {

const bool registered = register_command(Command{
    "simulate", "Simulate the reference EMA (sim_backend) and write a run CSV",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<SimulateOptions>();
        auto out = std::make_shared<std::string>();
        add_simulation_options(sub, *o);
        sub.add_option("--out", *out, "Output run CSV (summary only when omitted)");
        return [o, out] {
            const sim::SimConfig config = config_from(*o);
            const sim::SimResult result = sim::simulate(config);
            if (!result.finite) throw sim::SimError("the simulation diverged (NaN or inf in the samples)");
            const Run run = make_run(config, result);
            if (!out->empty()) write_run_csv_file(*out, run, io::OutputInputs({o->params_file}));
            std::cout << "EMA-REF-1 simulation: case " << sim::to_string(run.load_case) << ", sequence " << sim::to_string(run.sequence) << ", noise "
                      << o->noise << ", seed " << o->seed << '\n';
            std::cout << format_summary(summarise(run));
            if (!out->empty()) std::cout << "wrote " << run.samples.size() << " samples to " << io::escape_text(*out) << '\n';
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
