#pragma once
// Datasets of simulated runs for the paper's network (paper sections 2.7 and 2.8; issue 4 part 2).
// Health parameters are drawn as in ema-reference.md section 8 (FDJ, FSJ, eta_A uniform within
// +/-20 % of nominal, eta_O from the inverse of eq. (4)), from uniforms taken on top of
// std::mt19937_64 by hand so a seed gives the same dataset with every standard library.
// Runs are simulated noiseless on the batched SIMD path, filtered for bad simulations (the paper's
// "numerical limit cycles, numerical divergence, non-physical scenarios"), then the noise profile is
// applied per run with its own recorded seed. The file keeps every raw sample and the labels; the
// format is documented in docs/dataset-format.md.
#include "core/run.hpp"
#include "estimation/health_parameter.hpp"
#include "emadiag/sim/simulator.hpp"

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace emadiag {

/// Ranges of the health parameters (ema-reference.md section 8); normalised value 0 at lo, 1 at hi.
struct HealthRange {
    double lo = 0;
    double hi = 1;
    [[nodiscard]] double normalise(double v) const { return (v - lo) / (hi - lo); }
    [[nodiscard]] double denormalise(double u) const { return lo + u * (hi - lo); }
};
/// Range of kParamFdj, kParamFsj, kParamEtaA or kParamEtaO (eta_O: eq. (4) inverse of the eta_A
/// range). Throws EmadiagError on another name.
[[nodiscard]] HealthRange health_range(const std::string& param);
[[nodiscard]] HealthRange health_range(HealthParameter param);

/// The true health parameters of a simulated run (the labels).
struct HealthLabels {
    double fdj_nm = 0;
    double fsj_nm = 0;
    double eta_o = 0;
    double eta_a = 0;
    /// Value of a kParam* name.
    [[nodiscard]] double get(const std::string& param) const;
    [[nodiscard]] double get(HealthParameter param) const;
    /// Sets FDJ, FSJ, eta_O and eta_A of `params` to these labels.
    void apply_to(sim::EmaParams& params) const;
};

/// Uniform in [0, 1) from the top 53 bits of a std::mt19937_64 draw.
[[nodiscard]] double uniform01(std::uint64_t draw);

/// Draws one set of labels (FDJ, FSJ, eta_A in that order; eta_O by eq. (4) inverse).
template <class Rng>
HealthLabels draw_health_labels(Rng& rng, double tau);

struct DatasetSpec {
    sim::LoadCase load_case = sim::LoadCase::B;
    sim::Sequence sequence = sim::Sequence::Dyn;
    sim::NoiseProfile noise = sim::NoiseProfile::None;
    int count = 100;          ///< accepted runs wanted
    std::uint64_t seed = 1;
};

/// Why simulations were dropped (paper section 2.8 "algorithm to exclude bad data").
struct FilterCounts {
    int simulated = 0;
    int accepted = 0;
    int non_finite = 0;     ///< NaN or inf anywhere in the samples (numerical divergence)
    int limit_cycle = 0;    ///< sustained speed oscillation (numerical limit cycle)
    int non_physical = 0;   ///< current, speed or angle beyond the actuator's physical limits
};

/// Thresholds of the bad-simulation filter. Speed is bounded by the no-load speed V_dc / k_t (the
/// speed demand w_max is a controller limit the speed may overshoot).
inline constexpr double kFilterCurrentMarginA = 1.0;      ///< |I| <= I_max + margin (chatter lifts the mean)
inline constexpr double kFilterAngleMarginDeg = 0.5;      ///< |theta_u| <= stop + margin
inline constexpr double kLimitCycleSpeedRadS = 20.0;      ///< reversals count only above this speed
inline constexpr int kLimitCycleMaxReversals = 12;        ///< more large-speed reversals = limit cycle

/// Classifies one simulation: "" when accepted, else "non_finite", "limit_cycle" or "non_physical".
[[nodiscard]] std::string classify_simulation(const sim::SimResult& result, const sim::EmaParams& params);

struct DatasetRun {
    HealthLabels labels;
    std::uint64_t noise_seed = 0;        ///< seed of apply_noise for this run (recorded even for none)
    std::vector<sim::Sample> samples;    ///< as measured (noise applied)
};

struct Dataset {
    DatasetSpec spec;
    RunConstants constants;
    FilterCounts filter;
    std::vector<DatasetRun> runs;

    /// Run i as a Run (analysis metadata only: no true_* keys).
    [[nodiscard]] Run run(std::size_t i) const;
    /// A copy with another noise profile applied to noiseless samples (this dataset must be
    /// noiseless); each run's noise_seed is kept.
    [[nodiscard]] Dataset with_noise(sim::NoiseProfile noise) const;
};

/// Called after each simulated chunk with (simulated so far, accepted so far, wanted).
using DatasetProgress = std::function<void(int simulated, int accepted, int wanted)>;

/// Largest number of simulations tried per accepted run wanted before giving up.
inline constexpr int kMaxSimulationsPerRun = 2;
/// Most runs a dataset is generated with (held in memory while simulated: a DYN run of case B is
/// about 1 MB, so this is about the kMaxDatasetBytes a dataset file may hold).
inline constexpr int kMaxDatasetCount = 16'000;

/// Simulates until spec.count runs pass the filter (at most kMaxSimulationsPerRun * count
/// simulations; throws EmadiagError naming the counts when too few pass). threads: simulate_batch.
[[nodiscard]] Dataset generate_dataset(const DatasetSpec& spec, unsigned threads, const DatasetProgress& progress = {});

/// Binary file (docs/dataset-format.md). Throws EmadiagError naming the file and the problem.
void write_dataset(const std::string& path, const Dataset& dataset);
[[nodiscard]] Dataset read_dataset(const std::string& path);
/// Reads a dataset from a stream (`name` in messages). A seekable stream must hold exactly the
/// bytes its header announces; nothing is allocated beyond what the stream holds.
[[nodiscard]] Dataset read_dataset(std::istream& in, const std::string& name);
/// Limits of read_dataset (docs/limits.md): samples per run, and bytes of the whole body.
inline constexpr std::size_t kMaxDatasetSamplesPerRun = 1'000'000;
/// Fewest samples per run read_dataset accepts: eq. (7)'s central difference needs a sample on each
/// side of one. Each run is also checked as it is read: every sample finite, t_s increasing, and
/// every label inside its health_range (with kLabelRangeTolerance of the range's width for rounding).
inline constexpr std::size_t kMinDatasetSamplesPerRun = 3;
inline constexpr double kLabelRangeTolerance = 1e-9;
inline constexpr std::uint64_t kMaxDatasetBytes = std::uint64_t{16} << 30;

/// Seeded shuffle split of n items into train/validation/test index lists (the paper's 75/15/10).
struct Split {
    std::vector<int> train, validation, test;
};
inline constexpr double kTrainFraction = 0.75;
inline constexpr double kValidationFraction = 0.15;
[[nodiscard]] Split split_indices(int n, std::uint64_t seed);

// ---- template definition
template <class Rng>
HealthLabels draw_health_labels(Rng& rng, double tau) {
    HealthLabels h;
    h.fdj_nm = health_range(HealthParameter::Fdj).denormalise(uniform01(rng()));
    h.fsj_nm = health_range(HealthParameter::Fsj).denormalise(uniform01(rng()));
    h.eta_a = health_range(HealthParameter::EtaA).denormalise(uniform01(rng()));
    h.eta_o = sim::eta_o_from_eta_a(h.eta_a, tau);
    return h;
}

}  // namespace emadiag
