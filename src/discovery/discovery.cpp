// discover(): the stages of stages/stages.hpp run in order on one context (src/discovery/README.md).
#include "discovery/discovery.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/stages/stages.hpp"

#include <utility>

namespace emadiag::discovery {

bool not_told_apart(double cost_a, double cost_b, double ratio) {
    const double lo = std::min(cost_a, cost_b), hi = std::max(cost_a, cost_b);
    return hi < ratio * lo || hi - lo < kHypothesisMinCostGap;
}

Run analysis_window(const Run& run, std::size_t max_samples) {
    if (max_samples == 0) throw EmadiagError("discovery: the analysis window must hold at least one sample");
    if (run.samples.size() <= max_samples) return run;
    Run w;
    w.load_case = run.load_case;
    w.sequence = run.sequence;
    w.constants = run.constants;
    w.meta = run.meta;
    // Field by field, so the long run's samples are not copied whole first.
    w.samples.assign(run.samples.begin(), run.samples.begin() + static_cast<std::ptrdiff_t>(max_samples));
    for (const auto& [name, values] : run.extra_columns) {
        w.extra_columns.emplace_back(name, std::vector<double>(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(
                                                                                    std::min(max_samples, values.size()))));
    }
    return w;
}

DiscoveryReport discover(const Run& run, const DiscoveryOptions& options) {
    if (run.samples.size() > options.max_samples) {
        // Bounded work (issue 21 item 12): the run's start, as re-simulations start from rest at t = 0.
        DiscoveryReport windowed = discover(analysis_window(run, options.max_samples), options);
        windowed.total_samples = run.samples.size();
        windowed.notes.push_back(windowed.analysis_text());
        return windowed;
    }
    pipeline::Context ctx(run, options);
    pipeline::baseline_stage(ctx);       // 1. datasheet + the health the run identifies
    pipeline::torque_rounds_stage(ctx);  // 2. screen, fit, weigh the hypotheses, add; repeat
    pipeline::efficiency_stage(ctx);     // 3. eta_O off the datasheet, or a friction
    if (options.open_world) pipeline::sensor_stage(ctx);  // 4. position sensor offset and drift
    pipeline::low_speed_stage(ctx);      // 5. Stribeck friction by the trajectory
    pipeline::ripple_stage(ctx);         // 6. motor torque ripple by the trajectory
    pipeline::final_stage(ctx);          // 7. final refit on the trajectory, residual structure
    return std::move(ctx.rep);
}

}  // namespace emadiag::discovery
