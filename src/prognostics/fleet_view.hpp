#pragma once
// The reliability engineer's fleet view (`emadiag fleet`, docs/fleet-record.md): every tail and
// position with the serial installed now, ranked by urgency: the lower bound of the 90 % RUL
// interval (in days; a RUL in cycles is converted at the position's own rate of cycles per day),
// then the status of the last session. Each row names the parameter that drives it.
// Read from the summary tables the store keeps (series_stats, position_status), not from every
// session: each parameter's trend is the weighted linear fit those sums give (the same fit as
// fit_linear over the same points; `report` also weighs a log-linear model), its RUL interval by
// estimate_rul's Monte Carlo.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_source.hpp"
#include "emadiag/db/record_store.hpp"
#include "prognostics/degradation_fit.hpp"
#include "prognostics/rul_estimate.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

inline constexpr const char* kFleetSchema = "emadiag-fleet";
inline constexpr int kFleetSchemaVersion = 1;
/// Fewer draws than a report: the ranking needs the lower bound to a few percent.
inline constexpr int kDefaultFleetDraws = 1000;

struct FleetOptions {
    RulOptions rul{kDefaultHorizonDays, kDefaultFleetDraws, 1};
    double horizon_cycles = 20000.0;
};

struct FleetParameter {
    std::string parameter;
    std::string axis;  ///< "cycles" or "days"
    std::int64_t points = 0;
    double latest = 0, latest_se = 0;
    std::optional<double> slope_per_100;  ///< per 100 days or 100 cycles
    RulEstimate rul;                      ///< in the axis' unit
    std::optional<double> rul_lower_days;  ///< the 90 % lower bound in days (cycles converted); empty: beyond the horizon
};

struct FleetRow {
    int rank = 0;
    std::string tail_number, position, ata_reference, actuator_serial;
    std::int64_t sessions = 0;
    std::string last_utc, last_verdict;
    std::optional<std::int64_t> last_cycles;
    std::vector<FleetParameter> parameters;
    std::string driving_parameter;  ///< the parameter with the lowest RUL lower bound ("" when none predicts one)
    std::optional<double> urgency_days;  ///< its lower bound in days; empty: nothing within the horizon
    std::string status;  ///< e.g. "limit exceeded", "crossing predicted", "no crossing", "insufficient data"
};

/// The linear weighted least-squares fit from a series' sums on one axis (cycles when `cycles`).
/// Not fitted (with a note) below kMinTrendPoints points or for a singular design.
[[nodiscard]] DegradationFit fit_from_stats(const db::SeriesStats& s, bool cycles);

/// Every tail and position, most urgent first.
[[nodiscard]] std::vector<FleetRow> build_fleet_view(db::Database& database, const FleetOptions& options);
/// The same from any record source (the station's SQLite file or a fleet server).
[[nodiscard]] std::vector<FleetRow> build_fleet_view(db::RecordSource& source, const FleetOptions& options);

[[nodiscard]] nlohmann::ordered_json to_json(const std::vector<FleetRow>& rows, const FleetOptions& options);

}  // namespace emadiag::prognostics
