#pragma once
// The column map (issue 23 part 2; schema in docs/column-map.md): how one rig's CSV files read as
// measured runs. Which column is which signal (by header name or 0-based index) with its unit,
// scale, offset and sign; which columns are labels (metadata strings, never signals); the format
// (delimiter, decimal mark, lines to skip, header, comment prefix); the time (a column or a rate);
// the cycles (a column or detected motion); the derived signals. Loaded and checked once by
// load_column_map: every problem is listed with the map's file, the field and its value.
#include "measured/units.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::measured {

/// The schema name a map file carries in "schema".
inline constexpr const char* kColumnMapSchema = "emadiag-column-map/1";
/// Longest signal or label name (names are [a-z][a-z0-9_]*).
inline constexpr std::size_t kMaxSignalNameChars = 64;
/// Most entries in "columns" and in "derived".
inline constexpr std::size_t kMaxMapEntries = 256;
/// Widest Savitzky-Golay window: half_window at most this (window 2 * half_window + 1).
inline constexpr int kMaxSavitzkyGolayHalfWindow = 50;
/// Default gap limit: a time step above this many nominal periods is a gap.
inline constexpr double kDefaultMaxStepFactor = 1.5;

/// A column named by its header text, or by its 0-based position.
struct ColumnRef {
    std::optional<std::string> name;
    std::optional<std::size_t> index;
    [[nodiscard]] std::string describe() const;  ///< "'current'" or "index 3"
};

struct SignalColumn {
    ColumnRef column;
    std::string signal;   ///< the run's signal name, e.g. "current"
    Unit unit;            ///< the unit of sign * (scale * raw + offset)
    double scale = 1.0;
    double offset = 0.0;
    double sign = 1.0;    ///< +1 or -1
    std::optional<double> noise;  ///< standard deviation in `unit`, when known
};

struct LabelColumnSpec {
    ColumnRef column;
    std::string label;
};

enum class TimeSource { rate, column };

struct TimeSpec {
    TimeSource source = TimeSource::rate;
    std::optional<double> rate_hz;   ///< required for source rate; the nominal rate for column
    ColumnRef column;                ///< source column
    Unit unit{"s", Quantity::time, 1.0, 0.0};
    bool restarts_per_cycle = false; ///< the column's time starts again in each cycle
    double max_step_factor = kDefaultMaxStepFactor;
};

enum class CycleSource { none, column, motion };
enum class MotionDirection { positive, negative, any };

struct CycleSpec {
    CycleSource source = CycleSource::none;
    ColumnRef column;                 ///< source column: a new cycle where its text changes
    std::string signal;               ///< source motion: the signal whose motion starts cycles
    double speed_threshold_si = 0.0;  ///< |d signal/dt| above this is motion (SI unit of the signal per s)
    double min_rest_s = 0.0;          ///< rest needed before a motion starts a cycle
    MotionDirection direction = MotionDirection::any;
};

enum class DerivedOp { difference, sum, derivative };
enum class Differentiator { central_difference, savitzky_golay };

struct DerivedSpec {
    std::string signal;
    DerivedOp op = DerivedOp::difference;
    std::vector<std::string> of;      ///< two operands (difference: of[0] - of[1]), or one (derivative)
    Differentiator method = Differentiator::central_difference;
    int half_window = 1;              ///< Savitzky-Golay: window 2 * half_window + 1
    bool per_cycle = true;            ///< differentiate each cycle apart (no difference across a cycle's edge)
};

struct CsvFormat {
    char delimiter = ',';
    char decimal = '.';
    std::size_t skip_lines = 0;       ///< lines before the header (or before the data without a header)
    bool header = true;
    std::string comment_prefix;       ///< a line starting with it is skipped (counted); empty: none
};

struct ColumnMap {
    std::string path;                 ///< the map file ("" when parsed from text)
    std::string sha256;               ///< of the map file's bytes
    std::string name;
    CsvFormat format;
    std::vector<SignalColumn> signals;
    std::vector<LabelColumnSpec> labels;
    std::vector<ColumnRef> ignored;
    bool ignore_unmapped = false;     ///< "unmapped_columns": "ignore" (default "error")
    TimeSpec time;
    CycleSpec cycles;
    std::vector<DerivedSpec> derived;
};

/// Reads and checks a map file (io::read_bounded_json_file). Throws MeasuredError listing every
/// problem as "PATH: /field: message".
[[nodiscard]] ColumnMap load_column_map(const std::string& path);
/// The same from text; `source` names it in messages.
[[nodiscard]] ColumnMap parse_column_map(std::string_view json_text, const std::string& source);

}  // namespace emadiag::measured
