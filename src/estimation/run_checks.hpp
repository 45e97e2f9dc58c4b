#pragma once
// Input validation for the estimators (issue 4 part 5): a run that cannot be analysed is a clear
// error naming what is wrong and where (the constant, or the sample row and column).
// A run is checked once, where it enters the analysis (read, import, simulate): check_run is the
// only way to make a CheckedRun, and the estimators and discovery take a CheckedRun, so the type
// says the run was checked and nothing downstream checks it again.
#include "core/run.hpp"

#include <utility>

namespace emadiag {

/// Smallest plausible value of each constant (they must be finite and positive).
inline constexpr double kMinConstant = 0.0;
/// Relative tolerance between the sample spacing and the declared sample period.
inline constexpr double kSamplePeriodTolerance = 0.05;
/// Fewest samples an estimator can use.
inline constexpr std::size_t kMinRunSamples = 20;

class CheckedRun;

/// Throws EmadiagError listing every problem found: a missing or non-positive constant (k_t, J,
/// tau, sample period), a NaN or infinite value ("sample row 12 (t_s=0.006): current_A is nan"),
/// time that does not increase, irregular sample spacing, or too few samples.
/// Rows are numbered from 1 in sample order (the CSV reader's data rows).
/// Otherwise returns the run as a CheckedRun (pass an rvalue to move it rather than copy it).
[[nodiscard]] CheckedRun check_run(Run run);

/// A run that passed check_run; read-only, and made by check_run alone.
class CheckedRun {
public:
    [[nodiscard]] const Run& run() const { return run_; }
    operator const Run&() const { return run_; }  // NOLINT(google-explicit-constructor): a checked run is a run
    const Run* operator->() const { return &run_; }

private:
    explicit CheckedRun(Run run) : run_(std::move(run)) {}
    friend CheckedRun check_run(Run run);
    Run run_;
};

}  // namespace emadiag
