// emadiag dataset: simulated runs with random health parameters for training the paper's network.
#include "cli/command.hpp"
#include "cli/numeric_option.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "estimation/dataset.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <thread>

namespace emadiag::cli {
namespace {

struct DatasetOptions {
    std::string load_case = "B";
    std::string sequence = "dyn";
    int count = 500;
    std::uint64_t seed = 1;
    std::string noise = "none";
    std::string out;
    unsigned threads = 0;
};

constexpr int kProgressBarWidth = 40;
/// Most simulation threads asked for (the batched path runs one group per thread).
constexpr unsigned kMaxSimulationThreads = 1024;

void draw_progress(int simulated, int accepted, int wanted) {
    const double f = std::min(1.0, static_cast<double>(accepted) / std::max(1, wanted));
    const int filled = static_cast<int>(f * kProgressBarWidth);
    std::fprintf(stderr, "\r[%.*s%*s] %d/%d accepted, %d simulated", filled, "########################################",
                 kProgressBarWidth - filled, "", accepted, wanted, simulated);
    std::fflush(stderr);
}

const bool registered = register_command(Command{
    "dataset", "Simulate runs with random health parameters (section 8) and write a dataset file",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<DatasetOptions>();
        sub.add_option("--case", o->load_case, "Load case: A, A-ext or B")->default_val("B");
        sub.add_option("--sequence", o->sequence, "Sequence: dyn, brk or sweep")->default_val("dyn");
        sub.add_option("--count", o->count, "Runs that pass the bad-simulation filter")->required()
            ->check(in_range(1, kMaxDatasetCount, "kMaxDatasetCount"));
        sub.add_option("--seed", o->seed, "Seed of the health parameters and the noise")->default_val(1);
        sub.add_option("--noise", o->noise, "Noise profile: none or typical")->default_val("none");
        sub.add_option("--out", o->out, "Output dataset file (docs/dataset-format.md)")->required();
        sub.add_option("--threads", o->threads, "Simulation threads (default: all cores)")
            ->check(in_range(0u, kMaxSimulationThreads, "kMaxSimulationThreads"));
        return [o] {
            // Checked before the simulations (minutes), not only when the file is written.
            if (const auto problem = io::output_path_problem(o->out, "dataset")) throw EmadiagError(*problem);
            DatasetSpec spec;
            spec.load_case = sim::parse_load_case(o->load_case);
            spec.sequence = sim::parse_sequence(o->sequence);
            spec.noise = sim::parse_noise(o->noise);
            spec.count = o->count;
            spec.seed = o->seed;
            const unsigned threads = o->threads > 0 ? o->threads : std::max(1u, std::thread::hardware_concurrency());
            const bool tty = isatty(STDERR_FILENO) != 0;
            DatasetProgress progress;
            if (tty) progress = draw_progress;
            const Dataset d = generate_dataset(spec, threads, progress);
            if (tty) std::fprintf(stderr, "\n");
            write_dataset(o->out, d);
            std::cout << "dataset: case " << sim::to_string(spec.load_case) << ", sequence "
                      << sim::to_string(spec.sequence) << ", noise " << sim::to_string(spec.noise) << ", seed "
                      << spec.seed << ", " << threads << " threads\n"
                      << "filter: simulated " << d.filter.simulated << ", accepted " << d.filter.accepted
                      << ", rejected non-finite " << d.filter.non_finite << ", limit cycle " << d.filter.limit_cycle
                      << ", non-physical " << d.filter.non_physical << '\n'
                      << "wrote " << d.runs.size() << " runs of " << (d.runs.empty() ? 0 : d.runs.front().samples.size())
                      << " samples to " << io::escape_text(o->out) << '\n';
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
