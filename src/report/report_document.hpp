#pragma once
// What an HTML maintenance report shows (html_report.hpp, docs/report-html.md): per position of an
// aircraft and per actuator serial one section with the installations, the session history, each
// parameter's trend (points with 95 % bars, the fitted degradation with its band, the limit, the
// crossing), the RUL with its 90 % interval in days and/or flight cycles, the health index and status,
// and the open discovery findings. Plain data, filled by whoever holds the record: from_trend_report
// (trend_adapter.hpp) for today's trend report, the maintenance database's report for the full record.
// Every string is shown escaped; numbers must be finite (the writer names any that is not).
#include "prognostics/trend_series.hpp"
#include "report/health_index.hpp"

#include <optional>
#include <string>
#include <vector>

namespace emadiag::report {

/// What the x axis of the trends counts.
enum class TimeAxis {
    Date,    ///< x in days since 1970-01-01 (UTC): plotted as dates
    Cycles,  ///< x in flight cycles
};

struct ReportInstallation {
    std::string serial;
    std::string tail_number;
    std::string position;
    std::string from_utc, to_utc;  ///< to_utc empty: still installed
    std::string note;
};

struct ReportSession {
    std::string id;
    std::string started_utc;
    std::string tail_number, position, serial;
    std::string phase;       ///< pre-flight, post-flight, in-flight, load-rig, ...
    std::string kind;        ///< e.g. "test-run", "import", "history-sim"
    std::string operator_id;
    std::optional<double> cycles, hours;
    std::string verdict;
    std::string note;
    std::string tool_version;  ///< the emadiag that made the session (its release and build id)
};

struct ReportPoint {
    double x = 0;          ///< on the document's time axis
    double value = 0;      ///< in the parameter's unit
    double std_error = 0;  ///< 1 se; the plot's bar is +/- kZ95 se
    std::string session_id;
};

/// The fitted degradation sampled along x: the mean and its band (lower <= mean <= upper).
struct ReportCurve {
    std::string model;        ///< e.g. "linear", "log-linear"
    std::string band_label;   ///< e.g. "90 % band of the fit"
    std::vector<double> x, mean, lower, upper;
};

/// A remaining useful life in one unit.
struct ReportRul {
    std::string unit;                          ///< "days" or "cycles"
    std::string status;                        ///< e.g. "predicted", "no_crossing" (prognostics::to_string(RulStatus))
    std::string summary;                       ///< one line
    std::optional<double> estimate;            ///< empty: none (no crossing, no fit, no limit)
    std::optional<double> lower, upper;        ///< 90 % interval; a bound empty when beyond the horizon
    bool interval_computed = false;
    double horizon = 0;                        ///< in `unit`
};

struct ReportParameter {
    std::string name;  ///< e.g. "FDJ_Nm"
    std::string unit;  ///< e.g. "N m", "" for a ratio
    double nominal = 0;
    std::optional<prognostics::TrendLimit> limit;
    std::vector<ReportPoint> points;
    std::optional<ReportCurve> fit;
    std::string model_note;                    ///< why this model, or why none
    std::optional<double> crossing_x;          ///< where the fitted mean meets the limit (time axis)
    std::string crossing_label;                ///< e.g. "2027-02-22" or "cycle 5120"
    std::optional<double> trend_per_period, trend_per_period_se;
    std::string trend_period;                  ///< e.g. "100 days"
    std::vector<ReportRul> rul;                ///< per unit, most useful first (cycles, then days)
    ParameterHealth health;
    std::vector<std::string> notes;
};

struct ReportFinding {
    std::string id;
    std::string session_id;
    std::string found_utc;
    std::string effect;    ///< e.g. "viscous friction"
    std::string summary;   ///< the finding's text
    std::string status;    ///< e.g. "open"
};

/// One position of the aircraft, or one actuator serial across tails and positions.
struct ReportSection {
    std::string name;          ///< the position (e.g. "LH-ELEV") or the serial
    std::string kind;          ///< "position" or "serial"
    std::string ata_reference; ///< e.g. "ATA 27-30" (positions)
    std::string current;       ///< the serial installed (positions) or the tail/position it is in (serials)
    std::vector<ReportInstallation> installations;
    std::vector<ReportSession> sessions;  ///< oldest first
    std::vector<ReportParameter> parameters;
    PositionHealth health;
    std::vector<ReportFinding> findings;  ///< open discovery findings
    std::vector<std::string> notes;
};

struct ReportDocument {
    std::string title = "emadiag maintenance report";
    std::string tail_number;
    std::string generated_utc;
    std::string tool_version;
    std::string data_source;   ///< e.g. the database file
    TimeAxis time_axis = TimeAxis::Date;
    std::string method_note;   ///< how the measurements, fits and intervals were made (one paragraph)
    std::vector<ReportSection> positions;
    std::vector<ReportSection> serials;
    std::vector<std::string> notes;
};

}  // namespace emadiag::report
