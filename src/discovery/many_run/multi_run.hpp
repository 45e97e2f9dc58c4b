#pragma once
// Discovery over many runs at once (issue 10 part 5; docs/discovery.md "Many runs"):
//   1. each run on its own (discovery.hpp);
//   2. a joint screening of the generated term library on the residuals that remain after each
//      run's own model, stacked (each run keeps its own FDJ / eta_O columns: block-diagonal base),
//      so an effect too weak for one run but common to all is found; it is confirmed when adding it
//      to every run's model and fitting it there by re-simulation brings the summed trajectory cost
//      down;
//   3. the effects found in two runs or more compared across the runs in the order given (oldest
//      first, e.g. sessions over days): the weighted mean, the chi-square of consistency and the
//      weighted slope per run, so an effect that changes over sessions shows as a trend;
//   4. each BRK run's breakaway thresholds against the model of the nearest DYN run
//      (breakaway_across.hpp): an offset at rest sized by the BRK run and named by the DYN run;
//   5. across load cases (across_loads.hpp): an efficiency change and a friction that follows the
//      load on one run, told apart by runs at other loads.
#include "discovery/many_run/across_loads.hpp"
#include "discovery/many_run/breakaway_across.hpp"
#include "discovery/discovery.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::discovery {

/// One named effect's value in each run where it was found.
struct AcrossRunsEffect {
    std::string key, text;
    std::string parameter;                 ///< the compared value: a term's basis or a sim::Effects field
    std::vector<std::size_t> runs;         ///< indices into the run list
    std::vector<double> values, std_errors;
    double mean = 0, chi2 = 0, slope_per_run = 0, slope_se = 0;
    bool changes = false;                  ///< chi2 says the runs disagree (z > kStructureMinZ / 2) and the slope is significant
};

struct AcrossRunsReport {
    std::vector<std::string> labels;
    std::vector<DiscoveryReport> reports;
    std::vector<std::string> skipped;      ///< "label: reason" for runs discovery cannot analyse
    GenericScreen joint;                   ///< step 2
    std::vector<sim::Term> joint_terms;    ///< the joint finding (empty when none)
    std::string joint_key, joint_text;
    std::vector<double> joint_cost_before, joint_cost_after;  ///< per analysed run
    bool joint_confirmed = false;
    std::vector<AcrossRunsEffect> effects;  ///< step 3
    std::vector<BreakawayAcross> breakaways;  ///< step 4: each BRK run against a DYN run (breakaway_across.hpp)
    AcrossLoads loads;                        ///< step 5: efficiency or friction, across load cases (across_loads.hpp)

    [[nodiscard]] std::string summary() const;
    [[nodiscard]] nlohmann::json to_json() const;
};

/// Runs must have distinct labels (paths, or run ids); a run discovery cannot analyse is skipped with
/// its reason. A BRK run is compared with the nearest analysed run in the order given (step 4). Throws EmadiagError when no run can be analysed.
[[nodiscard]] AcrossRunsReport discover_runs(const std::vector<Run>& runs, const std::vector<std::string>& labels,
                                             const DiscoveryOptions& options = {});

/// What the lead stores with a finding in the maintenance database: the model JSON of the run
/// with the most significant finding (or of the first run), and the summary text.
struct FindingRecord {
    nlohmann::json model;
    std::string summary;
};
[[nodiscard]] FindingRecord finding_record(const DiscoveryReport& report);
[[nodiscard]] FindingRecord finding_record(const AcrossRunsReport& report);

}  // namespace emadiag::discovery
