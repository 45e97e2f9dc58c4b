#pragma once
// What a trend (prognostics::ParameterTrend) needs to become a plot of the HTML report: the fit
// sampled from the first session to past the last (far enough to show the crossing when it is near),
// with its 90 % band from the fit's covariance (the same uncertainty the RUL interval is drawn from),
// each parameter's datasheet nominal and unit. The documents themselves are made per position and
// per serial from the maintenance record (record_adapter.hpp), for `report` and `trend` alike: a tail's
// sessions are never pooled into one section.
#include "prognostics/trend_report.hpp"
#include "report/report_document.hpp"

#include <string>
#include <vector>

namespace emadiag::report {

/// The fit band's two-sided level and its normal quantile.
inline constexpr double kFitBandLevel = 0.90;
inline constexpr double kZ90 = 1.6448536269514722;
/// Points along each fitted curve.
inline constexpr int kCurveSamples = 80;
/// How far past the last session the fit is drawn: at least this fraction of the sessions' span
/// (and at least kMinProjectionDays), far enough for a predicted crossing and its interval, at most
/// kMaxProjectionSpans spans.
inline constexpr double kMinProjectionFraction = 0.25;
inline constexpr double kMinProjectionDays = 30.0;
inline constexpr double kMaxProjectionSpans = 3.0;

struct TrendAdapterOptions {
    std::string generated_utc;  ///< when the report was made
    std::string tool_version;
    std::string data_source;    ///< e.g. the database file
};

/// The datasheet nominal of a health parameter (sim::EmaParams defaults, ema-reference.md section 8)
/// and its unit ("N m" for friction, "" for efficiencies). Throws EmadiagError on an unknown name.
[[nodiscard]] double datasheet_nominal(const std::string& parameter);
[[nodiscard]] std::string parameter_unit(const std::string& parameter);

/// The fit of `p` sampled on the report's date axis (x = origin + t days). Empty without a fit.
[[nodiscard]] std::optional<ReportCurve> sample_fit(const prognostics::ParameterTrend& p, double origin_days);

}  // namespace emadiag::report
