#include "report/health_index.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace emadiag::report {
namespace {

std::string num(double v) {
    std::ostringstream os;
    os.precision(4);
    os << v;
    return os.str();
}

std::string whole_days(double v) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(0);
    os << v;
    return os.str();
}

}  // namespace

const char* to_string(HealthStatus s) {
    switch (s) {
        case HealthStatus::NoData: return "NO DATA";
        case HealthStatus::Ok: return "OK";
        case HealthStatus::Monitor: return "MONITOR";
        case HealthStatus::Plan: return "PLAN";
        case HealthStatus::Replace: return "REPLACE";
    }
    return "?";
}

double health_index(const std::string& parameter, double value, double nominal, const prognostics::TrendLimit& limit) {
    if (!std::isfinite(value) || !std::isfinite(nominal) || !std::isfinite(limit.value)) {
        throw EmadiagError("health index of " + parameter + ": value " + num(value) + ", nominal " + num(nominal) + " and limit " +
                           num(limit.value) + " must be finite");
    }
    const bool max_side = limit.side == prognostics::LimitSide::Max;
    const double span = max_side ? limit.value - nominal : nominal - limit.value;
    if (!(span > 0)) {
        throw EmadiagError("health index of " + parameter + ": nominal " + num(nominal) + " is not " + (max_side ? "below" : "above") +
                           " its " + prognostics::to_string(limit.side) + " limit " + num(limit.value));
    }
    const double h = (max_side ? limit.value - value : value - limit.value) / span;
    return std::clamp(h, 0.0, 1.0);
}

ParameterHealth assess_parameter(const ParameterHealthInput& in) {
    ParameterHealth out;
    out.parameter = in.parameter;
    if (in.limit_already_exceeded) {
        out.status = HealthStatus::Replace;
        out.reason = in.parameter + " has exceeded its limit";
    }
    if (!in.value || !in.limit) {
        if (out.status == HealthStatus::NoData) out.reason = in.parameter + ": " + (!in.value ? "no measurement" : "no limit");
        return out;
    }
    const double se = in.std_error.value_or(0.0);
    if (!std::isfinite(se) || se < 0) {
        throw EmadiagError("health index of " + in.parameter + ": standard error " + num(se) + " must be finite and not negative");
    }
    const bool max_side = in.limit->side == prognostics::LimitSide::Max;
    const double y = *in.value;
    const double h = health_index(in.parameter, y, in.nominal, *in.limit);
    const double y95 = max_side ? y + kZ95 * se : y - kZ95 * se;
    const double h95 = health_index(in.parameter, y95, in.nominal, *in.limit);
    out.index = h;
    out.index_lower_95 = h95;
    if (out.status == HealthStatus::Replace) return out;
    if (h <= 0) {
        out.status = HealthStatus::Replace;
        out.reason = in.parameter + " " + num(y) + " is at or past its limit " + num(in.limit->value);
        return out;
    }
    const std::optional<double>& rl = in.rul_lower_days;
    if (h95 < kPlanIndex) {
        out.status = HealthStatus::Plan;
        out.reason = in.parameter + " 95 % lower index " + num(h95) + " < " + num(kPlanIndex);
    } else if (rl && *rl < kPlanWindowDays) {
        out.status = HealthStatus::Plan;
        out.reason = in.parameter + " RUL 90 % lower bound " + whole_days(*rl) + " days < " + whole_days(kPlanWindowDays);
    } else if (h95 < kMonitorIndex) {
        out.status = HealthStatus::Monitor;
        out.reason = in.parameter + " 95 % lower index " + num(h95) + " < " + num(kMonitorIndex);
    } else if (rl && *rl < kMonitorWindowDays) {
        out.status = HealthStatus::Monitor;
        out.reason = in.parameter + " RUL 90 % lower bound " + whole_days(*rl) + " days < " + whole_days(kMonitorWindowDays);
    } else {
        out.status = HealthStatus::Ok;
        out.reason = in.parameter + " index " + num(h) + " (95 % lower " + num(h95) + ")";
    }
    return out;
}

PositionHealth assess_position(const std::vector<ParameterHealthInput>& parameters) {
    PositionHealth p;
    for (const auto& in : parameters) p.parameters.push_back(assess_parameter(in));
    for (const auto& h : p.parameters) {
        if (h.index && (!p.index || *h.index < *p.index)) {
            p.index = h.index;
            p.index_lower_95 = h.index_lower_95;
            p.index_parameter = h.parameter;
        }
        if (h.status > p.status) {
            p.status = h.status;
            p.status_parameter = h.parameter;
            p.reason = h.reason;
        }
    }
    // The 95 % lower index of the position is the minimum of the parameters' too (it may come from another one).
    for (const auto& h : p.parameters)
        if (h.index_lower_95 && (!p.index_lower_95 || *h.index_lower_95 < *p.index_lower_95)) p.index_lower_95 = h.index_lower_95;
    if (p.status == HealthStatus::NoData) p.reason = "no parameter has both a measurement and a limit";
    return p;
}

}  // namespace emadiag::report
