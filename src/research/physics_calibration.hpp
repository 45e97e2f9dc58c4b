#pragma once
// Accuracy and calibration of the physics estimator on seeded simulated runs (issue 4 goals):
// the normalised test MSE in the space of ema-reference.md section 8, relative errors, and the
// coverage of the 95 % intervals (+/-1.96 se), which must lie in [kCoverageMin, kCoverageMax].
// Research code (src/research, library emadiag_research): used by tests/src/research/calibration_test.cpp
// and bench/calibration_bench.cpp.
#include "emadiag/sim/simulator.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag {

inline constexpr double kCoverageMin = 0.90;
inline constexpr double kCoverageMax = 0.98;

struct CalibrationSpec {
    sim::LoadCase load_case = sim::LoadCase::B;
    sim::Sequence sequence = sim::Sequence::Dyn;
    sim::NoiseProfile noise = sim::NoiseProfile::None;
    int count = 40;
    std::uint64_t seed = 1;  ///< labels from draw_health_labels on std::mt19937_64(seed); noise seed = seed * 1000003 + i
    unsigned threads = 1;
};

struct ParameterScore {
    std::string name;
    int estimated = 0;           ///< runs where the estimator gave a value
    int not_estimated = 0;       ///< runs where it reported "not identifiable"
    int covered = 0;             ///< |error| <= 1.96 se
    double mse_normalised = 0;   ///< mean of (error / range width)^2 (section 8 space)
    double max_rel_error = 0;    ///< max |error| / truth
    double mean_rel_error = 0;
    double mean_z2 = 0;          ///< mean of (error / se)^2 (1 when se is right on average)
    int within_1pct = 0;         ///< runs with |error| / truth <= 1 %
    int within_3pct = 0;         ///< runs with |error| / truth <= 3 %
    [[nodiscard]] double coverage() const { return estimated ? static_cast<double>(covered) / estimated : 0.0; }
};

struct CalibrationResult {
    CalibrationSpec spec;
    std::vector<ParameterScore> scores;  ///< FDJ, FSJ, eta_O, eta_A
    int failures = 0;                    ///< runs where the estimator threw
    std::vector<std::string> failure_messages;
    double seconds = 0;                  ///< wall time of simulation + estimation (not a test figure)
    [[nodiscard]] const ParameterScore& score(const std::string& name) const;
};

/// Simulates spec.count runs with labels drawn as in section 8 (simulate_batch), estimates each
/// with estimate_physics and scores the estimates against the labels.
[[nodiscard]] CalibrationResult evaluate_physics(const CalibrationSpec& spec);

/// One line per parameter: coverage, normalised MSE, relative errors.
[[nodiscard]] std::string format_calibration(const CalibrationResult& r);

/// The floor the eta confound sets on the normalised MSE of FDJ in case A (section 4: |F_R| =
/// 5 N m / tau): the expected posterior variance of FDJ given FDJ + c |F_R| exactly, with FDJ and
/// eta_A uniform over section 8 (numerical, on a grid of `grid` x `grid` points).
[[nodiscard]] double case_a_fdj_floor_normalised(double tau, int grid = 600);

}  // namespace emadiag
