#include "estimation/run_checks.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/number_text.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace emadiag {
namespace {
constexpr std::size_t kMaxListedProblems = 20;

}  // namespace

CheckedRun check_run(Run run) {
    std::vector<std::string> problems;
    std::size_t hidden = 0;
    auto problem = [&](std::string p) {
        if (problems.size() < kMaxListedProblems) problems.push_back(std::move(p)); else ++hidden;
    };
    const auto& c = run.constants;
    const struct { const char* name; double value; } constants[] = {
        {"k_t_Nm_per_A", c.k_t_nm_per_a}, {"J_kgm2", c.j_kgm2}, {"tau", c.tau}, {"sample_period_s", c.sample_period_s}};
    for (const auto& k : constants) {
        if (!std::isfinite(k.value) || k.value <= kMinConstant) {
            problem("constant " + std::string(k.name) + " is missing or not positive (value " + number_text(k.value) +
                    "); give it as a '# " + k.name + "=...' header line");
        }
    }
    if (run.samples.size() < kMinRunSamples) {
        problem("run has " + std::to_string(run.samples.size()) + " samples; at least " +
                std::to_string(kMinRunSamples) + " are needed");
    }
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const auto& s = run.samples[i];
        const std::string row = "sample row " + std::to_string(i + 1) + " (t_s=" + number_text(s.t_s) + ")";
        const struct { const char* name; double value; } cols[] = {
            {"t_s", s.t_s}, {"current_A", s.current_a}, {"speed_rad_s", s.speed_rad_s},
            {"theta_m_rad", s.theta_m_rad}, {"hinge_moment_Nm", s.hinge_moment_nm}, {"command_deg", s.command_deg}};
        for (const auto& col : cols) {
            if (!std::isfinite(col.value)) problem(row + ": " + col.name + " is " + number_text(col.value));
        }
        if (i > 0 && std::isfinite(s.t_s) && std::isfinite(run.samples[i - 1].t_s)) {
            const double dt_s = s.t_s - run.samples[i - 1].t_s;
            if (!(dt_s > 0)) {
                problem(row + ": time does not increase (previous row t_s=" + number_text(run.samples[i - 1].t_s) + ")");
            } else if (c.sample_period_s > 0 &&
                       std::abs(dt_s - c.sample_period_s) > kSamplePeriodTolerance * c.sample_period_s) {
                problem(row + ": spacing " + number_text(dt_s) + " s differs from sample_period_s " + number_text(c.sample_period_s) +
                        " by more than " + number_text(100 * kSamplePeriodTolerance) + " %");
            }
        }
    }
    if (problems.empty()) return CheckedRun(std::move(run));
    std::string msg = "run cannot be analysed (" + std::to_string(problems.size() + hidden) + " problem" +
                      (problems.size() + hidden == 1 ? "" : "s") + "):";
    for (const auto& p : problems) msg += "\n  " + p;
    if (hidden > 0) msg += "\n  ... and " + std::to_string(hidden) + " more";
    throw EmadiagError(msg);
}

}  // namespace emadiag
