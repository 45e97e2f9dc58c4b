#pragma once
// Step 3 of a trend: when the fitted mean crosses the limit, and the remaining useful life
//   RUL = t_cross - t_last   (days after the last session of the series)
// with a 90 % interval by Monte Carlo over the fitted parameters: (a, b) ~ N(fit, covariance), each
// draw's crossing time computed like the fit's; draws that never cross within the horizon (slope
// flat or improving, or crossing later than t_last + horizon) count as beyond it, draws that crossed
// before the last session as RUL 0. The interval is the 5th to 95th percentile of the draws; when
// the 95th is beyond the horizon the upper bound is reported as "> horizon".
#include "prognostics/degradation_fit.hpp"
#include "prognostics/trend_series.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

inline constexpr double kDefaultHorizonDays = 3650.0;
inline constexpr int kDefaultMonteCarloDraws = 4000;
/// The two-sided level of the RUL interval and its percentiles.
inline constexpr double kRulIntervalLevel = 0.90;
inline constexpr double kRulLowerQuantile = 0.05;
inline constexpr double kRulUpperQuantile = 0.95;
/// Bounds of the options, checked with a message naming the value.
inline constexpr int kMinMonteCarloDraws = 100;
inline constexpr int kMaxMonteCarloDraws = 10'000'000;
inline constexpr double kMaxHorizonDays = 100.0 * 365.25;

struct RulOptions {
    double horizon_days = kDefaultHorizonDays;  ///< after the last session
    int draws = kDefaultMonteCarloDraws;
    std::uint64_t seed = 1;
};
/// Throws EmadiagError naming the field, its value and the allowed range.
void check(const RulOptions& o);

enum class RulStatus {
    InsufficientData,  ///< fewer than kMinTrendPoints sessions (or no fit)
    NoLimit,           ///< the findings give the parameter no limit
    AlreadyExceeded,   ///< the last measurement is already past the limit: RUL 0
    NoCrossing,        ///< flat or improving, or crossing later than the horizon
    Predicted,         ///< a crossing within the horizon
};
/// "insufficient_data", "no_limit", "already_exceeded", "no_crossing", "predicted" (the JSON values).
[[nodiscard]] const char* to_string(RulStatus s);

struct RulEstimate {
    RulStatus status = RulStatus::InsufficientData;
    std::string summary;  ///< one line, e.g. "no crossing predicted within the horizon (3650 days)"
    double horizon_days = kDefaultHorizonDays;
    double t_last_days = 0;                  ///< the last session of the series
    std::optional<double> crossing_t_days;   ///< the fitted mean at the limit (days since the first session)
    std::optional<double> rul_days;          ///< crossing - t_last (0 when already exceeded or crossed)
    /// The 90 % interval; a bound is empty when it lies beyond the horizon ("> horizon").
    std::optional<double> rul_lower_days, rul_upper_days;
    bool interval_computed = false;          ///< false: no Monte Carlo was run (no fit, no limit, exceeded)
    int draws = 0;
    int draws_beyond_horizon = 0;            ///< never crossed within t_last + horizon
    int draws_already_crossed = 0;           ///< crossed before t_last (RUL 0)
    std::uint64_t seed = 0;
    std::optional<std::int64_t> exceeded_session_id;
};

/// The RUL of a series under `fit` (the chosen model). `fit` may be unfitted (insufficient data).
/// In this order: the last point beyond the limit (whatever the number of points), no fit, no limit,
/// then the crossing and its interval.
[[nodiscard]] RulEstimate estimate_rul(const std::vector<TrendPoint>& points, const DegradationFit& fit,
                                       const std::optional<TrendLimit>& limit, const RulOptions& options);

/// The crossing time of the mean a + b t (linear) or e^(a + b t) (log-linear) with `limit`, when the
/// trend moves towards the limit; empty when it is flat or moves away.
[[nodiscard]] std::optional<double> crossing_time(DegradationModel model, double a, double b, const TrendLimit& limit);

}  // namespace emadiag::prognostics
