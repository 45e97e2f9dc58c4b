#pragma once
// The maintenance record of one aircraft as the reports show it (`emadiag report`,
// docs/fleet-record.md): per position the session history across the serials installed there, per
// actuator serial its history across tails; for each, every parameter's trend against flight cycles
// and against days (degradation fit, limit crossing, RUL with its 90 % interval), the preferred
// axis (cycles when every session of the series has them), the installations and the open
// discovery findings. A position's trend and RUL are those of the serial installed now, since its
// installation there (a new actuator starts a new degradation); its history shows every serial.
// Pure data for the text/JSON/CSV writers here and the HTML writer (src/report).
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_source.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "prognostics/trend_report.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

inline constexpr const char* kReportSchema = "emadiag-report";
inline constexpr int kReportSchemaVersion = 1;
/// The position of sessions stored without one.
inline constexpr const char* kNoPosition = "(none)";
inline constexpr const char* kAxisCycles = "cycles";
inline constexpr const char* kAxisDays = "days";
/// The horizon of a crossing on the cycles axis, after the last session.
inline constexpr double kDefaultHorizonCycles = 20000.0;

struct FleetRecordOptions {
    std::string phase = kPhaseAll;  ///< "pre-flight", "post-flight", "in-flight", "load-rig" or "all"
    RulOptions rul;                 ///< horizon_days is the days axis' horizon
    double horizon_cycles = kDefaultHorizonCycles;
};

/// One parameter's trend on one axis (t in days or cycles since the series' first session; for a
/// serial, cycles are the actuator's own: the sum of the aircraft cycles flown between its sessions
/// on each tail).
struct AxisTrend {
    std::string axis;  ///< kAxisCycles or kAxisDays
    ParameterTrend trend;
};

struct ParameterHistory {
    std::string parameter;
    std::vector<AxisTrend> axes;  ///< cycles first (when the series has them), then days
    std::string preferred_axis;   ///< cycles when every session of the series carries cycles
    [[nodiscard]] const AxisTrend* preferred() const;
};

/// A list that views showing the same sessions share, read-only: a serial that never left its
/// position has that position's history and trends, held once (copying 5,840 sessions with their
/// findings, and 46,720 trend points, was a third of a report's computation). Reads as a const vector.
template <class T>
class SharedList {
public:
    SharedList() = default;
    explicit SharedList(std::vector<T> items) : items_(std::make_shared<const std::vector<T>>(std::move(items))) {}
    [[nodiscard]] const std::vector<T>& items() const { return items_ ? *items_ : no_items(); }
    [[nodiscard]] auto begin() const { return items().begin(); }
    [[nodiscard]] auto end() const { return items().end(); }
    [[nodiscard]] std::size_t size() const { return items().size(); }
    [[nodiscard]] bool empty() const { return items().empty(); }
    [[nodiscard]] const T& operator[](std::size_t i) const { return items()[i]; }
    [[nodiscard]] const T& at(std::size_t i) const { return items().at(i); }
    [[nodiscard]] const T& back() const { return items().back(); }
    /// Whether both are the same list (not only equal ones).
    [[nodiscard]] bool shares_with(const SharedList& other) const { return items_ != nullptr && items_ == other.items_; }

private:
    static const std::vector<T>& no_items() {
        static const std::vector<T> none;
        return none;
    }
    std::shared_ptr<const std::vector<T>> items_;
};

/// One position of the aircraft (across serials) or one actuator serial (across tails).
struct HistoryView {
    std::string kind;  ///< "position" or "serial"
    std::string key;   ///< e.g. "LH-ELEV" or "SN-0042"
    std::string ata_reference, description;  ///< positions
    std::string current_serial;              ///< positions: the serial installed now
    std::string current_place;               ///< serials: "N123EM LH-ELEV", where it was last seen
    SharedList<db::StoredTestSession> sessions;  ///< every session of the view, oldest first (amended ones left out)
    std::vector<std::int64_t> trend_session_ids;  ///< the sessions the trends are fitted to
    /// Days since 1970 of the first and the last of them (the days axis' t = 0 and the last session).
    std::optional<double> trend_first_days, trend_last_days;
    std::vector<db::StoredInstallation> installations;
    SharedList<ParameterHistory> parameters;  ///< FDJ_Nm, FSJ_Nm, eta_O, eta_A
    std::string last_verdict;
    std::vector<std::string> notes;
};

struct FleetRecord {
    std::string tail_number;
    std::string database;
    FleetRecordOptions options;
    std::vector<HistoryView> positions;  ///< sorted by position; sessions without a position under "(none)"
    std::vector<HistoryView> serials;    ///< every serial seen on the tail, sorted
    std::vector<db::StoredInstallation> installations;
    std::vector<db::StoredDiscoveryFinding> open_findings;
    std::vector<std::int64_t> amended_session_ids;  ///< superseded by a correction, left out of the trends
    std::int64_t sessions_total = 0;
    std::string chain_head_sha256;
};

/// The record of one tail. Throws EmadiagError for an invalid or unknown tail (listing the tails the
/// database holds) or a bad option.
[[nodiscard]] FleetRecord build_fleet_record(db::Database& database, const std::string& tail_number, const FleetRecordOptions& options);
/// The same from any record source (the station's SQLite file or a fleet server).
[[nodiscard]] FleetRecord build_fleet_record(db::RecordSource& source, const std::string& tail_number, const FleetRecordOptions& options);

/// The documented JSON (schema kReportSchema, version kReportSchemaVersion; docs/fleet-record.md).
[[nodiscard]] nlohmann::ordered_json to_json(const FleetRecord& record);

}  // namespace emadiag::prognostics
