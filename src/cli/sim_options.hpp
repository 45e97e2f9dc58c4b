#pragma once
// Options shared by the commands that build a simulation (simulate, dataset, ema-sim).
#include "emadiag/sim/simulator.hpp"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::cli {

/// Longest --term text and most --term options (a term is one coefficient and a few factors).
inline constexpr std::size_t kMaxTermChars = 256;
inline constexpr std::size_t kMaxTerms = 64;

struct SimulateOptions {
    std::string load_case = "B";
    std::string sequence = "dyn";
    std::optional<double> fdj, fsj, eta_a, eta_o;
    std::string params_file;
    std::vector<std::string> effects;
    std::vector<std::string> terms;  ///< --term: terms as data (emadiag/sim/terms.hpp)
    std::string noise = "none";
    std::uint64_t seed = 1;
};

/// Adds --case --sequence --fdj --fsj --eta-a --eta-o --params --effect --noise --seed to `sub`.
void add_simulation_options(CLI::App& sub, SimulateOptions& o);

/// Builds and validates a SimConfig; throws SimError naming the bad option.
[[nodiscard]] sim::SimConfig config_from(const SimulateOptions& o);

}  // namespace emadiag::cli
