#pragma once
// Closing the loop with measured data (docs/discovery.md): the residual between a run and the
// datasheet model with the run's estimated health, traced to an effect the model lacks, that
// effect added and fitted by re-simulation, and the error before and after.
// discover() runs seven stages on one context (src/discovery/README.md has the diagram):
//   1. Baseline: datasheet + estimate_physics(run) (FDJ, eta where identifiable, FSJ on BRK runs;
//      the datasheet value otherwise, said in the health note). Re-simulated, noise none.
//   2. Torque rounds: the candidate library (candidate_effect.hpp) and the generated terms screened
//      on the model-consistent residual with the BIC and an effect-size floor (effect_screen.hpp);
//      the winner fitted with FDJ (and eta_O) by re-simulation (resimulation.hpp), confirmed by the
//      fit (the same BIC on the re-simulated cost, peak torque >= kMinEffectPeakNm), its hypotheses
//      told apart by the trajectory; screening repeats with it in the base, up to max_effects.
//   3. Efficiency or friction, 4. position sensor, 5. low-speed friction and 6. ripple by the
//      trajectory, 7. a final refit on the trajectory and the residual structure.
// Only the Run's samples, constants, case and sequence are read: never true_* / effect_* metadata.
#include "core/run.hpp"
#include "discovery/model/augmented_model.hpp"
#include "discovery/screening/effect_screen.hpp"
#include "discovery/model/resimulation.hpp"
#include "discovery/screening/sparse_select.hpp"
#include "discovery/model/trajectory.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::discovery {

/// At most this many effects are added (the criterion usually stops earlier).
inline constexpr int kMaxEffects = 3;

/// Most samples of one run discovery analyses (issue 21 item 12): a longer run is analysed on its
/// first kMaxAnalysedSamples samples (1 s at 2 kHz: a whole DYN run is 1000 samples, a BRK run 1600,
/// so normal runs are analysed whole; the re-simulations start from rest at t = 0, so the window is
/// the run's start), and the report says so (analysis_text). The re-simulations' cost grows with
/// the samples analysed (a 4000-sample run took 52 s of CPU, docs/discovery.md), so this bounds the
/// time and memory of any run within the run CSV's row limit.
inline constexpr std::size_t kMaxAnalysedSamples = 2'000;

/// The run's first `max_samples` samples (the whole run when it is not longer), with its metadata.
[[nodiscard]] Run analysis_window(const Run& run, std::size_t max_samples = kMaxAnalysedSamples);

struct DiscoveryOptions {
    std::size_t max_samples = kMaxAnalysedSamples;  ///< a longer run is analysed on its first max_samples
    int max_effects = kMaxEffects;
    bool open_world = true;  ///< screen the generated term library and the sensor stage (issue 10)
};

/// Two hypotheses are told apart by the trajectory when the worse one's cost is at least this many
/// times the better one's (and above it by a margin, stages/hypotheses.cpp); cost 1 = the noise floor.
inline constexpr double kHypothesisRatio = 1.25;
/// ... and only when the worse cost is also at least this far above the better one.
inline constexpr double kHypothesisMinCostGap = 0.1;
/// Two trajectory costs the trajectory does not tell apart: the worse below `ratio` times the better,
/// or within kHypothesisMinCostGap of it.
[[nodiscard]] bool not_told_apart(double cost_a, double cost_b, double ratio);

/// One explanation of a signature in the torque residual, re-simulated: a library effect, or terms.
/// Hypotheses that leave the same torque residual (a sensor offset and a real torque) are told
/// apart by the re-simulated trajectory (current, speed, angle, load: trajectory.hpp).
struct Hypothesis {
    std::string key, text;           ///< physics_names.hpp key ("current_sensor_offset") and text
    std::string change;              ///< what the model gains ("current: 0.1", "hinge_offset = -80")
    double cost = 0;                 ///< trajectory cost after its fit (1 = at the noise floor)
    TrajectoryError error;
    int simulations = 0;
    double tell_apart_ratio = kHypothesisRatio;  ///< cost ratio by which the trajectory tells it from the one found
    bool refit_on_trajectory = false;  ///< cost after a refit on the trajectory (close hypotheses, stages/hypotheses.cpp)
};

/// One round: the screening, and the effect it added (if any) with the error after it.
struct DiscoveryStep {
    ScreenResult screen;
    GenericScreen generic;           ///< the generated library's screening (open world)
    std::optional<EffectShape> added;  ///< a library effect was added
    std::vector<sim::Term> added_terms;  ///< generated terms were added (fitted coefficients)
    std::string name_key, name_text;   ///< what the added effect is (after the hypotheses)
    std::vector<Hypothesis> hypotheses;  ///< best trajectory first, when alternatives exist
    bool equivalent = false;           ///< the best two hypotheses are not told apart by the trajectory
    double trajectory_before = 0, trajectory_after = 0;
    std::vector<FittedValue> fitted;  ///< values and standard errors of the re-simulation fit
    std::string rejected_by_fit;      ///< why the winner was not added after its fit (empty if added)
    std::string withheld;             ///< why the winner was not even fitted: a better explanation of the
                                      ///< same structure is below kMinEffectPeakNm (empty otherwise)
    double fit_delta_bic = 0;         ///< the criterion on the re-simulated cost, without vs with the effect
    int simulations = 0;
    ErrorMetrics error_after;
};

/// A term added by the sensor stage (theta offset or drift: invisible in the torque residual).
struct SensorFinding {
    std::string key, text;
    sim::Term term;
    double cost_before = 0, cost_after = 0;
};

/// One Stribeck speed of the low-speed friction stage: the trajectory (current, speed, angle, load in
/// noise floors) regressed on the health columns and the Stribeck column at that speed, linearised
/// around the model by one re-simulation each.
struct LowSpeedEvidence {
    double stribeck_speed_rad_s = 0;
    double amplitude_nm = 0, amplitude_se_nm = 0;
    double delta_bic = 0;  ///< N ln(RSS_0 / RSS_1) - 2 ln N - 2 ln G over the N trajectory rows
    bool sign_ok = true;
};

/// Low-speed friction by the trajectory (docs/discovery.md): friction that acts only while the speed
/// crosses zero (Stribeck) lasts a few samples, which the torque residual drops (slipping samples away
/// from kinks) or sees through its derivative noise; the speed step it leaves persists through the
/// saturated acceleration and the angle integrates it, so the trajectory sees it 30 times as well.
/// Screened on the trajectory, fitted on it by re-simulation with the health, and added only when the
/// fit confirms it and explains most of the trajectory's excess over the noise floor.
struct LowSpeedStage {
    bool ran = false;
    std::string skipped;                   ///< why the stage did not run
    std::size_t rows = 0;                  ///< trajectory rows (4 channels x samples)
    double cost_before = 0;                ///< trajectory cost of the model before the stage
    double base_cost = 0;                  ///< the same after the health columns (linearised)
    std::vector<LowSpeedEvidence> ranking;  ///< best delta BIC first
    bool screen_passes = false;
    /// The profile over w_s (re-simulated, each point corrected by one linear step): speed, amplitude
    /// and trajectory cost, finest around the best.
    std::vector<std::array<double, 3>> profile;
    double cost_health_only = 0;           ///< trajectory cost after the health alone is fitted on it
    double cost_with = 0;                  ///< ... and after the health with the Stribeck friction
    double fit_delta_bic = 0;
    double explained = 0;                  ///< share of the excess over the floor (cost_health_only - 1) explained
    double peak_nm = 0;
    std::vector<FittedValue> fitted;
    int simulations = 0;
    bool added = false;
    bool refit_of_torque = false;          ///< the torque rounds had found it: added = replaced their fit
    std::string verdict;
};

/// An efficiency change the run cannot tell from a friction the model lacks (docs/discovery.md
/// "Efficiency or friction"): eta_O enters the model as friction proportional to the load, sgn(w) |F_R|;
/// a friction proportional to another signal that follows the load on this run (|theta_u| under an
/// aerodynamic load that grows with the deflection, case B) is absorbed into eta_O, the residual is
/// then at the floor, and the estimate departs from the datasheet. The alternative keeps eta_O at the
/// datasheet value and screens the friction-like terms of the generated library on the torque residual
/// that leaves; the best is fitted by re-simulation and the trajectory compares the two.
struct EfficiencyAlternative {
    bool ran = false;
    std::string skipped;                 ///< why it did not run (eta_O not estimated, or at the datasheet)
    double eta_o = 0, eta_o_se = 0;      ///< the model's
    double eta_o_datasheet = 0;
    std::string key, text, change;       ///< the friction found with eta_O at the datasheet value
    std::vector<sim::Term> terms;        ///< ... as terms (fitted)
    double cost_model = 0, cost_alternative = 0;  ///< trajectory costs (1 = noise floor)
    bool equivalent = false;             ///< not told apart by the trajectory
    bool favoured = false;               ///< the trajectory favours the friction over the efficiency change
    std::string verdict;
};

struct DiscoveryReport {
    sim::LoadCase load_case = sim::LoadCase::B;
    sim::Sequence sequence = sim::Sequence::Dyn;
    std::size_t samples = 0;         ///< samples analysed
    std::size_t total_samples = 0;   ///< samples in the run (more than `samples` when it was windowed)
    double analysed_end_s = 0;       ///< time of the last sample analysed
    /// "" when the whole run was analysed; else "analysed 10000 of 2000000 samples in 1 window (t = ...)".
    [[nodiscard]] std::string analysis_text() const;
    NoiseFloor floor;                            ///< the run's own noise floor (trajectory.hpp)
    std::vector<SensorFinding> sensor_findings;
    LowSpeedStage low_speed;                     ///< Stribeck friction found by the trajectory (library effect)
    EfficiencyAlternative efficiency;            ///< an efficiency change the run cannot tell from a friction
    std::vector<StructureReport> structure;      ///< the residual of the final model, per channel
    TrajectoryError trajectory_before, trajectory_after;
    std::vector<HealthValue> baseline_health;  ///< step 1: estimated or datasheet
    AugmentedModel model;                      ///< health refit with the added effects
    std::vector<DiscoveryStep> steps;
    std::vector<std::string> notes;

    /// Names of the added effects, in order: library names ("viscous", ...) or physics_names.hpp
    /// keys of generated terms and of the hypotheses chosen ("friction_deflection", ...).
    [[nodiscard]] std::vector<std::string> added_effects() const;
    /// The structure report of the most significant channel when the final model leaves the residual
    /// significantly above the noise floor; nullptr when it is consistent with noise.
    [[nodiscard]] const StructureReport* unexplained() const;
    /// One line: the effects found, the unexplained structure, or "no significant discrepancy".
    [[nodiscard]] std::string summary() const;
    /// The model's value of a term by sim::Effects name ("viscous"); nullopt when not in the model.
    [[nodiscard]] std::optional<double> term_value(const std::string& sim_name) const;
    [[nodiscard]] nlohmann::json to_json() const;
};

/// d T_R,model / d parameter (FDJ, eta_O) per sample, by a forward difference of two
/// re-simulations of `p` (`model` is the re-simulation of `p`).
[[nodiscard]] std::vector<double> sensitivity(const Run& run, const sim::EmaParams& p, const RunSignals& model,
                                              const FitParameter& parameter);
/// sensitivity for each of `names`, the re-simulations side by side (resimulate_many).
[[nodiscard]] std::vector<std::vector<double>> sensitivities(const Run& run, const sim::EmaParams& p, const RunSignals& model,
                                                             const std::vector<FitParameter>& names);

/// Throws EmadiagError on a run that cannot be analysed (NaN, too few samples or screening
/// samples, unknown case/sequence), naming the field, the value and the limit.
[[nodiscard]] DiscoveryReport discover(const Run& run, const DiscoveryOptions& options = {});

}  // namespace emadiag::discovery
