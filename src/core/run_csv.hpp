#pragma once
// The CSV hand-over format (issue 2 part 6, documented in README.md):
//   # key=value lines (must include k_t_Nm_per_A, J_kgm2, tau, sample_period_s, case, sequence)
//   t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg[,more...]
//   one row per sample
#include "core/run.hpp"
#include "emadiag/io/output_path.hpp"

#include <iosfwd>
#include <string>

namespace emadiag {

inline constexpr const char* kCsvRequiredColumns[] = {"t_s", "current_A", "speed_rad_s", "theta_m_rad",
                                                      "hinge_moment_Nm", "command_deg"};

/// Limits of read_run_csv (docs/limits.md): numbers in the sample rows (12 million doubles, 96 MB:
/// 2 million rows of the six required columns, 1000 s at the 2 kHz sample rate; fewer rows when
/// the file has extra columns), bytes per line, columns, metadata lines, and bad rows after which
/// the reader stops. Each, when exceeded, is a problem that names the limit.
inline constexpr std::size_t kCsvMaxValues = 12'000'000;
inline constexpr std::size_t kCsvMaxLineBytes = 4096;
inline constexpr std::size_t kCsvMaxColumns = 64;
inline constexpr std::size_t kCsvMaxMetaLines = 1000;
inline constexpr std::size_t kCsvMaxBadRows = 1000;

/// Writes a run; numbers with 17 significant digits so a read gives back the same doubles.
void write_run_csv(std::ostream& out, const Run& run);
void write_run_csv_file(const std::string& path, const Run& run, const io::OutputInputs& inputs = {});

/// Reads a run; throws EmadiagError listing every problem as "name:line: message".
[[nodiscard]] Run read_run_csv(std::istream& in, const std::string& name);
[[nodiscard]] Run read_run_csv_file(const std::string& path);

}  // namespace emadiag
