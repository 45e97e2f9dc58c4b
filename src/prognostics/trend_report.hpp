#pragma once
// A reliability engineer's trend report for one tail number (`emadiag trend`, docs/trend-report.md):
// per health parameter the measurements of the test sessions (trend_series), the degradation fits
// and the chosen model (degradation_fit), the predicted limit crossing and the remaining useful life
// with its 90 % interval (rul_estimate). Pure computation; to_json gives the documented schema.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_source.hpp"
#include "emadiag/db/test_session_store.hpp"
#include "prognostics/degradation_fit.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/trend_series.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

/// The JSON schema name and version (docs/trend-report.md).
inline constexpr const char* kTrendSchema = "emadiag-trend";
inline constexpr int kTrendSchemaVersion = 1;
/// Trends are given per this many days.
inline constexpr double kTrendPeriodDays = 100.0;
/// The phase filter that keeps every session.
inline constexpr const char* kPhaseAll = "all";

struct TrendOptions {
    std::string phase = "pre-flight";  ///< "pre-flight", "post-flight" or kPhaseAll
    RulOptions rul;
};
/// Throws EmadiagError naming the phase or the RUL option that is wrong.
void check(const TrendOptions& o);

struct ParameterTrend {
    ParameterSeries series;
    ModelFits fits;        ///< fitted when the series has >= kMinTrendPoints points
    bool has_fit = false;  ///< the chosen model is fitted
    /// d mean / dt of the chosen model at the last session, per kTrendPeriodDays, and its se.
    std::optional<double> trend_per_period, trend_per_period_se;
    RulEstimate rul;
    std::optional<double> crossing_days_since_epoch;  ///< for the calendar date
};

struct TrendReport {
    std::string tail_number;
    std::string phase;
    int sessions_total = 0;        ///< of the tail, any phase
    int sessions_in_phase = 0;
    std::optional<double> origin_days_since_epoch;  ///< the tail's first session (t = 0)
    std::string origin_utc;
    std::optional<double> last_session_days_since_epoch;  ///< the last session in the phase
    RulOptions rul_options;
    std::vector<ParameterTrend> parameters;  ///< FDJ_Nm, FSJ_Nm, eta_O, eta_A
    std::vector<std::string> notes;          ///< about the report as a whole (e.g. no session in the phase)
};

/// One parameter's trend from its series.
[[nodiscard]] ParameterTrend analyse_parameter(ParameterSeries series, const RulOptions& options);

/// The report of `sessions` (one tail, oldest first, as db::list_test_sessions gives them). t = 0 is
/// the tail's first session in any phase; the phase filter then picks the sessions analysed.
/// Throws EmadiagError for a bad option or a session whose started_utc is not a UTC time.
[[nodiscard]] TrendReport build_trend_report(const std::string& tail_number, const std::vector<db::StoredTestSession>& sessions,
                                             const TrendOptions& options);

/// The tail numbers in the database (table aircraft), sorted.
[[nodiscard]] std::vector<std::string> list_tail_numbers(db::Database& database);

/// The report of one tail from the database. Throws EmadiagError naming the tail and listing the
/// tails the database holds when it has no such aircraft.
[[nodiscard]] TrendReport load_trend_report(db::Database& database, const std::string& tail_number, const TrendOptions& options);
/// The same from any record source (the station's SQLite file or a fleet server).
[[nodiscard]] TrendReport load_trend_report(db::RecordSource& source, const std::string& tail_number, const TrendOptions& options);

/// The documented JSON form (schema kTrendSchema, version kTrendSchemaVersion), keys in document order.
[[nodiscard]] nlohmann::ordered_json to_json(const TrendReport& report);

}  // namespace emadiag::prognostics
