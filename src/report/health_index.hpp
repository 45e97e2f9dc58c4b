#pragma once
// The health index of an actuator, from 1 (as new) down to 0 (at its serviceability limit), and the
// status a planner acts on (docs/health-index.md).
//
// Per parameter, with nominal N (the datasheet value), limit L and the latest measurement y +/- se:
//   h      = (L - y) / (L - N)             for a maximum (friction),
//   h      = (y - L) / (N - L)             for a minimum (efficiency),
// clamped to [0, 1]: the fraction of the nominal-to-limit margin that is left. The 95 % lower index
// h_95 is h at the 95 % bound of y towards the limit (y + 1.96 se for a maximum, y - 1.96 se for a
// minimum). The actuator's index is the minimum over its parameters, and its status the worst of the
// parameters' statuses:
//   REPLACE  y is at or past its limit (h = 0), or the trend says the limit was already exceeded;
//   PLAN     h_95 < kPlanIndex, or the lower bound of the 90 % RUL interval < kPlanWindowDays;
//   MONITOR  h_95 < kMonitorIndex, or the lower bound of the 90 % RUL interval < kMonitorWindowDays;
//   OK       otherwise;
//   NO DATA  no parameter has both a measurement and a limit.
#include "prognostics/trend_series.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag::report {

/// The 95 % lower index below which replacement is planned, and below which the actuator is watched.
inline constexpr double kPlanIndex = 0.25;
inline constexpr double kMonitorIndex = 0.5;
/// RUL windows (days): a crossing that cannot be ruled out within them calls for planning / watching.
inline constexpr double kPlanWindowDays = 180.0;
inline constexpr double kMonitorWindowDays = 365.0;

/// Ordered from best to worst (NoData is not a judgement and sorts first).
enum class HealthStatus { NoData, Ok, Monitor, Plan, Replace };
/// "NO DATA", "OK", "MONITOR", "PLAN", "REPLACE".
[[nodiscard]] const char* to_string(HealthStatus s);

struct ParameterHealthInput {
    std::string parameter;
    std::optional<double> value, std_error;  ///< the latest measurement and its 1-se uncertainty
    double nominal = 0;                      ///< the datasheet value
    std::optional<prognostics::TrendLimit> limit;
    bool limit_already_exceeded = false;       ///< the trend says so (RulStatus::AlreadyExceeded)
    std::optional<double> rul_lower_days;      ///< lower bound of the 90 % RUL interval, when computed
};

struct ParameterHealth {
    std::string parameter;
    std::optional<double> index;           ///< h in [0, 1]; empty without a measurement or a limit
    std::optional<double> index_lower_95;  ///< h at the 95 % bound of the measurement towards the limit
    HealthStatus status = HealthStatus::NoData;
    std::string reason;                    ///< one line: why this status
};

struct PositionHealth {
    std::optional<double> index, index_lower_95;  ///< minimum over the parameters
    std::string index_parameter;                  ///< the parameter with the lowest index
    HealthStatus status = HealthStatus::NoData;
    std::string status_parameter;                 ///< the parameter that sets the status
    std::string reason;
    std::vector<ParameterHealth> parameters;
};

/// h of a measurement: the fraction of the nominal-to-limit margin left, clamped to [0, 1]. Throws
/// EmadiagError naming the parameter when the nominal is not on the healthy side of the limit or a
/// number is not finite.
[[nodiscard]] double health_index(const std::string& parameter, double value, double nominal, const prognostics::TrendLimit& limit);

/// One parameter's index and status. Throws EmadiagError naming the parameter on a negative or
/// non-finite se or a bad nominal/limit.
[[nodiscard]] ParameterHealth assess_parameter(const ParameterHealthInput& in);

/// The actuator's index (minimum over parameters) and status (the worst), naming the parameter behind each.
[[nodiscard]] PositionHealth assess_position(const std::vector<ParameterHealthInput>& parameters);

}  // namespace emadiag::report
