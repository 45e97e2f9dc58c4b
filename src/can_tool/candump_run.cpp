#include "can_tool/candump_run.hpp"

#include "can_tool/session_decoder.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/can/candump_log.hpp"

#include <fstream>

namespace emadiag {

Run read_run_candump(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw EmadiagError(path + ": cannot open the candump log");
    // Streamed: memory is one line plus the decoder's telemetry (at most 65536 samples).
    can_tool::SessionDecoder decoder;
    can::for_each_candump_record(in, path, [&](can::CandumpRecord&& r) { decoder.feed(r.frame); });
    Run run = decoder.build_run(path);
    run.set_meta("source", "candump log");
    run.set_meta("log_file", path);
    return run;
}

}  // namespace emadiag
