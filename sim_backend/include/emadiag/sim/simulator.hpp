#pragma once
// The EMA-REF-1 plant and controller (ema-reference.md sections 3 to 7), integrated at dt.
// One step function serves the scalar and the batched paths; they differ only in lane width.
#include "emadiag/record/run_sample.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag::sim {

enum class LoadCase { A, AExt, B };
enum class Sequence { Dyn, Brk, Sweep };
enum class NoiseProfile { None, Typical };

[[nodiscard]] std::string to_string(LoadCase c);
[[nodiscard]] std::string to_string(Sequence s);
[[nodiscard]] std::string to_string(NoiseProfile n);
/// Parse "A", "A-ext", "B" (case-insensitive); throws SimError naming the value.
[[nodiscard]] LoadCase parse_load_case(const std::string& s);
/// Parse "dyn", "brk", "sweep".
[[nodiscard]] Sequence parse_sequence(const std::string& s);
/// Parse "none", "typical".
[[nodiscard]] NoiseProfile parse_noise(const std::string& s);

/// Default length of a sequence: DYN and SWEEP 0.5 s, BRK 0.8 s (ema-reference.md section 5).
[[nodiscard]] double default_duration_s(Sequence s);
/// Surface-angle command in degrees at time t (section 5). BRK commands 0.
[[nodiscard]] double command_deg(Sequence s, double t_s);

/// The BRK breakaway sequence (section 5): a position hold, then torque-mode current ramps until
/// the shaft has moved kBrkMoveRad, with a hold between the two directions. The tool side reads the
/// same definition to analyse BRK runs.
inline constexpr double kBrkFirstHoldS = 0.05;
inline constexpr double kBrkMidHoldS = 0.1;
inline constexpr double kBrkRampAPerS = 10.0;
inline constexpr double kBrkMoveRad = 0.01;

/// Samples per controller period: 0.5 ms at dt (section 6).
inline constexpr double kSamplePeriodS = 5e-4;
/// Aircraft update period in case B (section 3 step 7).
inline constexpr double kAircraftPeriodS = 1e-4;

/// Sensor resolutions; they are the CAN telemetry resolutions (can_dbc/ema.dbc).
inline constexpr double kCurrentResolutionA = 0.002;
inline constexpr double kSpeedResolutionRadS = 0.05;
inline constexpr double kThetaResolutionRad = 0.001;
inline constexpr double kHingeResolutionNm = 0.5;
/// Noise profile `typical` (section 6).
inline constexpr double kTypicalSigmaCurrentA = 0.02;
inline constexpr double kTypicalSigmaSpeedRadS = 0.2;
inline constexpr double kTypicalSigmaThetaRad = 1e-3;
inline constexpr double kTypicalSigmaHingeNm = 1.0;

struct SimConfig {
    EmaParams params = EmaParams::datasheet();
    LoadCase load_case = LoadCase::B;
    Sequence sequence = Sequence::Dyn;
    NoiseProfile noise = NoiseProfile::None;
    std::uint64_t seed = 1;
    double duration_s = 0.0;  ///< 0 means default_duration_s(sequence)
    bool record_truth = false;  ///< also record per-sample exact friction/motor torque and energies
};

/// One 2 kHz sample (section 6): time at the end of the period, period means of I, w and H,
/// theta_m at the end of the period, and the command. The simulator's sample is the run's sample
/// (emadiag/record/run_sample.hpp): one shape from the simulator to the maintenance record.
using Sample = ::emadiag::RunSample;

/// What the simulator knows and a measurement does not: period means of the exact torques.
struct SampleTruth {
    double friction_torque_nm = 0;  ///< mean T_F (signed, acting against motion)
    double motor_torque_nm = 0;     ///< mean T_M after saturation and ripple
    double load_torque_nm = 0;      ///< mean F_R actually applied to the motor side
    bool stuck_all_period = false;  ///< the shaft was stuck for the whole period
};

/// Energy accounts over a run, in joules (for the energy-balance check).
struct EnergyAccount {
    double electrical_in_j = 0;   ///< sum V I dt
    double copper_loss_j = 0;     ///< sum R I^2 dt
    double friction_work_j = 0;   ///< sum T_F w dt
    double load_work_j = 0;       ///< sum F_R w dt
    double saturation_loss_j = 0; ///< sum (k_t I - T_M) w dt, torque clipped by T_max
    double stop_loss_j = 0;       ///< kinetic energy removed by the end stops and the reversal stop
    double stored_start_j = 0;    ///< 1/2 L I^2 + 1/2 J w^2 at the start
    double stored_end_j = 0;
};

struct SimResult {
    std::vector<Sample> samples;
    std::vector<SampleTruth> truth;  ///< filled when SimConfig::record_truth
    EnergyAccount energy;            ///< filled when SimConfig::record_truth
    bool finite = true;              ///< false when the integration produced NaN or inf
};

/// One simulation on the scalar path (lane width 1).
[[nodiscard]] SimResult simulate(const SimConfig& config);

/// Many simulations that differ only in FDJ, FSJ, eta_O, eta_A, noise seed (and noise profile),
/// run on the batched SIMD path (structure of arrays, simd_target().lanes lanes x groups) over
/// `threads` threads. The results are those of simulate, bit for bit, on every instruction set.
/// All other fields of the configs must be equal; throws SimError naming the first that is not.
[[nodiscard]] std::vector<SimResult> simulate_batch(const std::vector<SimConfig>& configs, unsigned threads = 1);
/// The widest lane count of the batched path (AVX-512: 8 doubles); simd_target().lanes is the one in use.
inline constexpr int kBatchLanes = 8;
/// The most lane groups a target steps together (AVX2, AVX-512: 4); simd_target().groups is the one in use.
inline constexpr int kBatchGroups = 4;

/// The instruction set simulate_batch runs on: one binary built for baseline x86-64 picks the
/// widest the CPU has at run time (Google Highway dynamic dispatch).
struct SimdTarget {
    std::string name;  ///< "scalar", "sse4", "avx2", "avx512" (or "neon", "emu128": Highway's portable fallback)
    int lanes = 1;     ///< doubles per vector
    int groups = 1;    ///< vectors stepped together; a batch group is lanes * groups simulations
};
/// The environment variable that narrows the batched path at first use (same values as set_simd_target).
inline constexpr const char* kSimdEnvVar = "EMADIAG_SIMD";
/// The target in use now. The first call reads EMADIAG_SIMD; throws SimError if it names an unknown
/// target or one this CPU lacks.
[[nodiscard]] SimdTarget simd_target();
/// The targets this CPU and this build support, narrowest first: always "scalar" (simulate, one run
/// at a time), then e.g. "sse4", "avx2", "avx512".
[[nodiscard]] std::vector<std::string> supported_simd_targets();
/// The targets this build holds code for, whatever the CPU: "scalar", then Highway's names of every
/// target compiled into the batched kernels (HWY_TARGETS), narrowest first (`emadiag --version`).
[[nodiscard]] std::vector<std::string> compiled_simd_targets();
/// Makes simulate_batch run on `name` (one of supported_simd_targets(), or "best" for the widest).
/// Throws SimError naming the value and the supported ones. Process-wide; call it while no batch runs.
void set_simd_target(const std::string& name);

/// What this process has simulated so far (simulate and simulate_batch), for time breakdowns: runs,
/// and the wall time spent in the calls, summed over the calling threads.
struct SimCounters {
    std::uint64_t scalar_runs = 0;   ///< simulate calls
    double scalar_s = 0;
    std::uint64_t batch_runs = 0;    ///< simulations run through simulate_batch
    double batch_s = 0;
};
[[nodiscard]] SimCounters sim_counters();

/// Adds the noise profile to samples in place (seeded; Gaussian on top of std::mt19937_64),
/// then quantises to the sensor resolutions. NoiseProfile::None leaves the samples untouched.
void apply_noise(std::vector<Sample>& samples, NoiseProfile profile, std::uint64_t seed);

}  // namespace emadiag::sim
