#pragma once
// A reliability engineer's trend report for one tail number (`emadiag trend`, docs/trend-report.md):
// per actuator (each position with the serial installed there now, or one serial) and per health
// parameter the measurements of the test sessions (trend_series), the degradation fits and the
// chosen model (degradation_fit), the predicted limit crossing and the remaining useful life with its
// 90 % interval (rul_estimate). The sessions are grouped as the maintenance record groups them
// (fleet_record): two actuators are never fitted as one line. Pure computation; to_json gives the
// documented schema.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_source.hpp"
#include "emadiag/db/session_store.hpp"
#include "prognostics/degradation_fit.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/trend_series.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

struct FleetRecord;  // fleet_record.hpp (which builds on this file's ParameterTrend)

/// The JSON schema name and version (docs/trend-report.md).
inline constexpr const char* kTrendSchema = "emadiag-trend";
inline constexpr int kTrendSchemaVersion = 2;
/// Trends are given per this many days.
inline constexpr double kTrendPeriodDays = 100.0;
/// The phase filter that keeps every session.
inline constexpr const char* kPhaseAll = "all";

struct TrendOptions {
    std::string phase = "pre-flight";  ///< "pre-flight", "post-flight" or kPhaseAll
    RulOptions rul;
    std::string position;  ///< only this position of the tail ("" = every position)
    std::string serial;    ///< only this actuator serial, across its places ("" = per position)
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

/// One actuator's trend: a position of the tail (the serial installed there now, since its
/// installation) or one actuator serial (its whole history, across positions and tails). A trend
/// never spans two actuators: the sessions of a serial that was replaced at a position are in its
/// own series (`--serial`), not in the position's.
struct TrendSeries {
    std::string kind;      ///< "position" or "serial"
    std::string position;  ///< the position ("(none)" for sessions stored without one); serials: where last seen
    std::string serial;    ///< the actuator serial the trends are of ("" when the sessions carry none)
    std::string place;     ///< serials: "TAIL POSITION" where last seen
    int sessions_total = 0;     ///< sessions of the position (every serial) or of the serial (every place)
    int sessions_in_trend = 0;  ///< the sessions the trends are fitted to (this serial, this phase)
    std::vector<std::int64_t> trend_session_ids;
    std::optional<double> origin_days_since_epoch;  ///< day 0: the series' first trend session
    std::string origin_utc;
    std::optional<double> last_session_days_since_epoch;
    std::vector<ParameterTrend> parameters;  ///< FDJ_Nm, FSJ_Nm, eta_O, eta_A
    std::vector<std::string> notes;          ///< earlier serials at the position, sessions of another phase
};

struct TrendReport {
    std::string tail_number;
    std::string phase;
    int sessions_total = 0;  ///< of the tail, any phase (amended sessions left out)
    std::string position_filter, serial_filter;
    RulOptions rul_options;
    std::vector<TrendSeries> series;  ///< one per position (sorted), or the one asked for
    std::vector<std::string> notes;   ///< about the report as a whole (e.g. no session)
};

/// One parameter's trend from its series.
[[nodiscard]] ParameterTrend analyse_parameter(ParameterSeries series, const RulOptions& options);

/// The views of `record` that `position` and `serial` select ("" = any): neither gives every
/// position; a position gives that position; a serial gives that serial's own view; both give the
/// position when that serial is installed there now. Throws EmadiagError naming the position or
/// serial that is not in the record (listing those it holds), or the serial installed instead.
[[nodiscard]] FleetRecord select_views(const FleetRecord& record, const std::string& position, const std::string& serial);

/// The trend report of a tail from its maintenance record (positions and serials as `emadiag report`
/// groups them: one series per actuator, never two pooled), restricted by options.position and
/// options.serial (select_views). The record must have been built with options.phase and options.rul.
[[nodiscard]] TrendReport trend_report_of(const FleetRecord& record, const TrendOptions& options);

/// The tail numbers in the database (table aircraft), sorted.
[[nodiscard]] std::vector<std::string> list_tail_numbers(db::Database& database);

/// The record `trend` reads: build_fleet_record with the trend's phase and RUL options.
[[nodiscard]] FleetRecord load_trend_record(db::RecordSource& source, const std::string& tail_number, const TrendOptions& options);

/// The report of one tail from the database. Throws EmadiagError naming the tail and listing the
/// tails the database holds when it has no such aircraft, or naming an unknown position or serial.
[[nodiscard]] TrendReport load_trend_report(db::Database& database, const std::string& tail_number, const TrendOptions& options);
/// The same from any record source (the station's SQLite file or a fleet server).
[[nodiscard]] TrendReport load_trend_report(db::RecordSource& source, const std::string& tail_number, const TrendOptions& options);

/// The documented JSON form (schema kTrendSchema, version kTrendSchemaVersion), keys in document order.
[[nodiscard]] nlohmann::ordered_json to_json(const TrendReport& report);

}  // namespace emadiag::prognostics
