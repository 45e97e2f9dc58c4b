#pragma once
// The one record of a test run (ARCHITECTURE.md): the section-6 samples of ema-reference.md,
// the actuator's constants and the run's metadata. Every source produces it (simulator,
// CAN recorder, CSV and candump readers); every consumer reads it.
#include "emadiag/record/run_sample.hpp"
#include "emadiag/sim/simulator.hpp"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

/// A double with 17 significant digits: reading it back gives the same double.
[[nodiscard]] std::string format_exact(double v);


/// Characterised constants of the actuator (from the identification message or the CSV header).
struct RunConstants {
    double k_t_nm_per_a = 0;
    double j_kgm2 = 0;
    double tau = 0;
    double sample_period_s = 0;
};

struct Run {
    /// Every `# key=value` header line, in file order (keys are unique).
    std::vector<std::pair<std::string, std::string>> meta;
    RunConstants constants;
    /// Parsed and printed by sim::parse_load_case / sim::to_string ("A", "A-ext", "B") at the edges.
    sim::LoadCase load_case = sim::LoadCase::B;
    /// Parsed and printed by sim::parse_sequence / sim::to_string ("dyn", "brk", "sweep") at the edges.
    sim::Sequence sequence = sim::Sequence::Dyn;
    std::vector<RunSample> samples;
    /// Columns after the six required ones, by name, one value per sample.
    std::vector<std::pair<std::string, std::vector<double>>> extra_columns;

    [[nodiscard]] std::optional<std::string> meta_value(const std::string& key) const;
    void set_meta(const std::string& key, const std::string& value);
    /// Sets the required keys of the run CSV (k_t_Nm_per_A, J_kgm2, tau, sample_period_s, case,
    /// sequence) from `constants`, `load_case` and `sequence`, keeping the position of keys already set.
    void set_required_meta();
    /// Metadata safe for analysis: everything except the simulator's true_* and effect_* keys.
    [[nodiscard]] std::vector<std::pair<std::string, std::string>> analysis_meta() const;
};

}  // namespace emadiag
