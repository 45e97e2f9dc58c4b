#include "core/run_validity.hpp"

#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/simulator.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace emadiag {
namespace {

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

struct ColumnLimit {
    const char* column;
    double datasheet_limit;  ///< the datasheet value the margin multiplies
    std::string what;        ///< which datasheet value, for the message
};

/// The datasheet limits, read from the one home of the datasheet (sim::EmaParams::datasheet()).
std::vector<ColumnLimit> make_column_limits() {
    const sim::EmaParams p = sim::EmaParams::datasheet();
    const double stop_rad = p.stop_deg * std::numbers::pi / 180.0;
    return {
        {"current_A", p.i_max_a, "I_max = " + num(p.i_max_a) + " A"},
        {"speed_rad_s", p.w_max_rad_s, "w_max = " + num(p.w_max_rad_s) + " rad/s"},
        {"theta_m_rad", p.tau * stop_rad, "tau x stop = " + num(p.tau) + " x " + num(p.stop_deg) + " deg"},
        {"hinge_moment_Nm", p.tau * p.t_max_nm, "tau x T_max = " + num(p.tau) + " x " + num(p.t_max_nm) + " N m"},
        {"command_deg", p.stop_deg, "the stops, " + num(p.stop_deg) + " deg"},
    };
}

const std::vector<ColumnLimit>& column_limits() {
    static const std::vector<ColumnLimit> limits = make_column_limits();
    return limits;
}

template <std::size_t N>
std::string one_of(const char* const (&values)[N]) {
    std::string s;
    for (std::size_t i = 0; i < N; ++i) s += (i == 0 ? "" : ", ") + std::string(values[i]);
    return s;
}

template <std::size_t N>
bool is_one_of(const std::string& v, const char* const (&values)[N]) {
    for (const char* x : values)
        if (v == x) return true;
    return false;
}

}  // namespace

std::optional<double> sample_magnitude_limit(const std::string& column) {
    for (const auto& c : column_limits())
        if (column == c.column) return kImpossibleMargin * c.datasheet_limit;
    return std::nullopt;
}

std::optional<std::string> sample_value_problem(const std::string& column, double value) {
    for (const auto& c : column_limits()) {
        if (column != c.column) continue;
        const double limit = kImpossibleMargin * c.datasheet_limit;
        if (std::isfinite(value) && std::abs(value) <= limit) return std::nullopt;
        return column + " = " + num(value) + " is physically impossible: beyond +/-" + num(limit) + " (" + num(kImpossibleMargin) +
               " x " + c.what + ", ema-reference.md section 1)";
    }
    return std::nullopt;
}

std::optional<std::string> metadata_value_problem(const std::string& key, const std::string& value) {
    try {
        if (key == "case") (void)sim::parse_load_case(value);
        else if (key == "sequence") (void)sim::parse_sequence(value);
    } catch (const std::exception&) {
        return key + "=" + value + " is not one of " + (key == "case" ? "A, A-ext, B" : "dyn, brk, sweep");
    }
    if (key == "status" && !is_one_of(value, kRunStatuses)) return "status=" + value + " is not one of " + one_of(kRunStatuses);
    if (key == "valid" && !is_one_of(value, kRunValidValues)) return "valid=" + value + " is not one of " + one_of(kRunValidValues);
    return std::nullopt;
}

RunValidity run_validity(const Run& run) {
    const auto invalid = [](std::string why) { return RunValidity{false, std::move(why)}; };
    for (const char* key : {"case", "sequence", "status", "valid"}) {
        const auto v = run.meta_value(key);
        if (v)
            if (auto p = metadata_value_problem(key, *v)) return invalid("metadata " + *p);
    }
    // Every reason that holds, so a truncated log marked incomplete says both.
    std::vector<std::string> reasons;
    if (run.meta_value("valid").value_or("true") != "true") {
        const std::string why = run.meta_value("invalid_reason").value_or("");
        reasons.push_back("its metadata says valid=false" + (why.empty() ? std::string() : " (" + why + ")"));
    }
    else if (const std::string why = run.meta_value("invalid_reason").value_or(""); !why.empty()) {
        // The recorder and the session decoder write a reason only beside valid=false: a reason alone
        // is metadata that contradicts itself, and the run is not judged on the better half of it.
        reasons.push_back("its metadata gives invalid_reason=" + why + " (a valid run carries none)");
    }
    const std::string status = run.meta_value("status").value_or("complete");
    if (status != "complete" && run.meta_value("invalid_reason").value_or("") != "sequence " + status)
        reasons.push_back("its metadata says status=" + status + ": the " + sim::to_string(run.sequence) + " sequence did not complete");
    if (run.samples.empty()) reasons.push_back("the run has no samples");

    // Complete: the samples reach the end of the sequence.
    const double period_s = run.constants.sample_period_s;
    const double duration_s = sim::default_duration_s(run.sequence);
    if (!run.samples.empty() && std::isfinite(period_s) && period_s > 0) {
        const double last_t_s = run.samples.back().t_s;
        if (!(last_t_s >= duration_s - kRunEndToleranceSamples * period_s)) {
            const auto expected = static_cast<long long>(std::llround(duration_s / period_s));
            reasons.push_back("truncated: " + std::to_string(run.samples.size()) + " of " + std::to_string(expected) +
                              " samples, the last at t = " + num(last_t_s) + " s; the " + sim::to_string(run.sequence) + " sequence lasts " +
                              num(duration_s) + " s");
        }
    }
    // Physically possible: a value beyond the datasheet by kImpossibleMargin is no measurement.
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const RunSample& s = run.samples[i];
        const std::pair<const char*, double> cols[] = {{"current_A", s.current_a},
                                                       {"speed_rad_s", s.speed_rad_s},
                                                       {"theta_m_rad", s.theta_m_rad},
                                                       {"hinge_moment_Nm", s.hinge_moment_nm},
                                                       {"command_deg", s.command_deg}};
        bool found = false;
        for (const auto& [name, value] : cols) {
            if (auto p = sample_value_problem(name, value)) {
                reasons.push_back("sample " + std::to_string(i + 1) + ": " + *p);
                found = true;
                break;
            }
        }
        if (found) break;  // the first one names the problem
    }
    if (reasons.empty()) return {};
    std::string all;
    for (const auto& r : reasons) all += (all.empty() ? "" : "; ") + r;
    return invalid(all);
}

}  // namespace emadiag
