#pragma once
// Input validation for the estimators (issue 4 part 5): a run that cannot be analysed is a clear
// error naming what is wrong and where (the constant, or the sample row and column).
#include "core/run.hpp"

namespace emadiag {

/// Smallest plausible value of each constant (they must be finite and positive).
inline constexpr double kMinConstant = 0.0;
/// Relative tolerance between the sample spacing and the declared sample period.
inline constexpr double kSamplePeriodTolerance = 0.05;
/// Fewest samples an estimator can use.
inline constexpr std::size_t kMinRunSamples = 20;

/// Throws EmadiagError listing every problem found: a missing or non-positive constant (k_t, J,
/// tau, sample period), a NaN or infinite value ("sample row 12 (t_s=0.006): current_A is nan"),
/// time that does not increase, irregular sample spacing, or too few samples.
/// Rows are numbered from 1 in sample order (the CSV reader's data rows).
void check_run(const Run& run);

}  // namespace emadiag
