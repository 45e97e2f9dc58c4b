#pragma once
// Ctrl-C (SIGINT) and SIGTERM for the commands that drive the EMA (record, test-run): the handler
// only sets a flag; the sequencer sees it, sends ABORT and keeps the partial log.
#include <atomic>

namespace emadiag::cli {

/// Installs the handler (idempotent) and returns the flag it sets.
[[nodiscard]] const std::atomic<bool>& install_interrupt_handler();

}  // namespace emadiag::cli
