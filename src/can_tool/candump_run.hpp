#pragma once
// Reads a session's candump log (emadiag record's RUN.log, or a `candump -l` recording) into a Run.
#include "core/run.hpp"

#include <string>

namespace emadiag {

/// Decodes a session log into a Run, with the constants from the identification message.
/// Throws EmadiagError (or the CAN library's error for a malformed log) naming the file.
[[nodiscard]] Run read_run_candump(const std::string& path);

}  // namespace emadiag
