#pragma once
// The technician's verdict from the estimates of a test session's runs against the limits.
// Each (parameter, estimator, run) gives a finding: its 95 % interval (value +/- kZ95 se) lies
// WITHIN the limit, BEYOND it, or STRADDLES it. The physics estimator, whose intervals are
// calibrated, decides; the paper's network is the independent cross-check:
//   - a run invalid, aborted or incomplete               -> NO_TEST (nothing is concluded)
//   - any physics finding BEYOND                         -> UNSERVICEABLE
//   - any physics finding STRADDLES                      -> INCONCLUSIVE (retest)
//   - the network BEYOND where physics says WITHIN       -> INCONCLUSIVE (the methods disagree)
//   - no physics finding WITHIN at all                   -> INCONCLUSIVE (nothing was measured)
//   - otherwise                                          -> SERVICEABLE
// Parameters the data cannot identify (eta on the ground in case A) are listed, not assessed.
#include "diagnosis/health_limits.hpp"
#include "estimation/run_estimator.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag {

enum class FindingStatus { Within, Beyond, Straddles, NotIdentifiable, NotEstimated };
enum class Verdict { Serviceable, Unserviceable, Inconclusive, NoTest };

[[nodiscard]] const char* to_string(FindingStatus s);
[[nodiscard]] const char* to_string(Verdict v);

struct Finding {
    std::string parameter;   ///< kParam*
    EstimatorId estimator;   ///< the method and the run's sequence, printed "physics:brk", "network:dyn", ...
    std::optional<double> value;
    std::optional<double> std_error;
    std::optional<ParameterLimit> limit;
    FindingStatus status = FindingStatus::NotEstimated;
    std::string note;
};

/// One run of the session as the verdict sees it.
struct AssessedRun {
    sim::Sequence sequence = sim::Sequence::Dyn;
    bool valid = false;
    std::string invalid_reason;    ///< when not valid
    std::optional<RunEstimates> estimates;  ///< empty when the run was not estimated
};

/// The run as the verdict sees it: estimated (estimate_run) when `valid`; an estimator that refuses
/// the run makes it not valid, "not estimated: " and the estimator's reason. One rule for import and
/// history-sim.
[[nodiscard]] AssessedRun assess_run(const Run& run, sim::Sequence sequence, bool valid, std::string invalid_reason);

struct Assessment {
    Verdict verdict = Verdict::NoTest;
    std::string reason;  ///< one line a technician can act on
    std::vector<Finding> findings;
};

/// A parameter's status against a limit: WITHIN when the whole 95 % interval is on the serviceable
/// side (a value exactly at the limit counts as within), BEYOND when the whole interval is past it.
[[nodiscard]] FindingStatus classify(double value, double std_error, const ParameterLimit& limit);

[[nodiscard]] Assessment assess(const std::vector<AssessedRun>& runs, const HealthLimits& limits);

}  // namespace emadiag
