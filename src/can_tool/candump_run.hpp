#pragma once
// Reads a session's candump log (emadiag record's RUN.log, or a `candump -l` recording) into a Run.
#include "core/run.hpp"

#include <functional>
#include <string>

namespace emadiag {

/// Called with one line per thing the reader skipped or noted ("RUN.log:69:48: expected data as
/// pairs of hex digits; line skipped"), then a one-line count; never called for a clean log.
using CandumpWarning = std::function<void(const std::string&)>;

/// Decodes a session log into a Run, with the constants from the identification message. A torn or
/// malformed line is skipped and reported through `warn`, and every good frame is kept: the run's
/// validity then follows the telemetry itself (lost samples, CRC failures, counter gaps), as on the
/// bus (issue 25 part 4). The meta records log_lines, log_frames and log_lines_skipped.
/// Throws EmadiagError (or the CAN library's error for a log with no good line, or plain `candump`
/// console output) naming the file.
[[nodiscard]] Run read_run_candump(const std::string& path, const CandumpWarning& warn = {});

}  // namespace emadiag
