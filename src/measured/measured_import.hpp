#pragma once
// Reads a rig's CSV file into a MeasuredRun through a column map (issue 23 part 2; docs/column-map.md).
// Streaming: the file is read in blocks of kMeasuredReadBlockBytes, hashed (SHA-256) as it is read,
// and parsed line by line with std::from_chars; only the mapped signals and labels are kept.
// Every problem names the file, the line, the column and the value; a reader finding problems in
// rows goes on to list up to kMeasuredMaxReportedProblems of them (all are counted) and throws
// MeasuredError at the end, or as soon as kMeasuredMaxProblems are found or a limit is crossed.
#include "measured/column_map.hpp"
#include "measured/measured_run.hpp"

#include <cstddef>
#include <string>

namespace emadiag::measured {

/// Bytes kept of one line; a longer line is an error (the rest is not read into memory).
inline constexpr std::size_t kMeasuredMaxLineBytes = 4096;
/// Fields in one line.
inline constexpr std::size_t kMeasuredMaxColumns = 256;
/// Values held: rows x (signals + time + labels + derived signals). 40 M: 320 MB of doubles at most.
inline constexpr std::size_t kMeasuredMaxValues = 40'000'000;
/// Distinct texts of one label column (labels name states, not samples).
inline constexpr std::size_t kMeasuredMaxLabelValues = 65'536;
/// Problems listed in one error (all are counted), and the count that stops the reader.
inline constexpr std::size_t kMeasuredMaxReportedProblems = 20;
inline constexpr std::size_t kMeasuredMaxProblems = 1000;
/// Bytes read at a time.
inline constexpr std::size_t kMeasuredReadBlockBytes = std::size_t{1} << 20;

/// Imports `csv_path` through `map` (load_column_map). Throws MeasuredError.
[[nodiscard]] MeasuredRun import_measured_csv(const std::string& csv_path, const ColumnMap& map);

}  // namespace emadiag::measured
