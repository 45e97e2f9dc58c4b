#pragma once
// The CSV hand-over format (issue 2 part 6, documented in README.md):
//   # key=value lines (must include k_t_Nm_per_A, J_kgm2, tau, sample_period_s, case, sequence)
//   t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg[,more...]
//   one row per sample
#include "core/run.hpp"

#include <iosfwd>
#include <string>

namespace emadiag {

inline constexpr const char* kCsvRequiredColumns[] = {"t_s", "current_A", "speed_rad_s", "theta_m_rad",
                                                      "hinge_moment_Nm", "command_deg"};

/// Writes a run; numbers with 17 significant digits so a read gives back the same doubles.
void write_run_csv(std::ostream& out, const Run& run);
void write_run_csv_file(const std::string& path, const Run& run);

/// Reads a run; throws EmadiagError listing every problem as "name:line: message".
[[nodiscard]] Run read_run_csv(std::istream& in, const std::string& name);
[[nodiscard]] Run read_run_csv_file(const std::string& path);

}  // namespace emadiag
