#pragma once
// Today's trend report of one tail (prognostics::TrendReport) as a ReportDocument: one position "ALL"
// holding every session of the tail, time axis in dates, RUL in days. The fit is sampled from the
// first session to past the last (far enough to show the crossing when it is near), with its 90 %
// band from the fit's covariance (the same uncertainty the RUL interval is drawn from).
#include "emadiag/db/test_session_store.hpp"
#include "prognostics/trend_report.hpp"
#include "report/report_document.hpp"

#include <string>
#include <vector>

namespace emadiag::report {

/// The position name the adapter uses for a tail whose sessions carry no position.
inline constexpr const char* kAllPositions = "ALL";
/// Flight controls (ATA chapter 27) for the whole aircraft.
inline constexpr const char* kAta27 = "ATA 27 (flight controls)";
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

/// The document. `sessions` are the tail's stored test sessions (oldest first, as
/// db::list_test_sessions gives them) for the session history and the installed serials; the
/// trends come from `trend`.
[[nodiscard]] ReportDocument from_trend_report(const prognostics::TrendReport& trend, const std::vector<db::StoredTestSession>& sessions,
                                               const TrendAdapterOptions& options);

}  // namespace emadiag::report
