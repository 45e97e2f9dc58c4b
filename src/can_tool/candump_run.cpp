#include "can_tool/candump_run.hpp"

#include "can_tool/session_decoder.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/can/candump_log.hpp"

#include <fstream>

namespace emadiag {

Run read_run_candump(const std::string& path, const CandumpWarning& warn) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw EmadiagError(path + ": cannot open the candump log");
    // Streamed: memory is one line plus the decoder's telemetry (at most 65536 samples).
    can_tool::SessionDecoder decoder;
    const can::CandumpReport rep = can::for_each_candump_record(
        in, path, [&](can::CandumpRecord&& r) { decoder.feed(r.frame); }, can::CandumpMode::Lenient);
    if (warn && !rep.clean()) {
        for (const auto& m : rep.messages) warn(m);
        if (rep.messages_left_out > 0) warn(path + ": " + std::to_string(rep.messages_left_out) + " more such lines not listed");
        warn(path + ": read " + rep.summary());
    }
    Run run = decoder.build_run(path);
    run.set_meta("source", "candump log");
    run.set_meta("log_file", path);
    run.set_meta("log_lines", std::to_string(rep.lines));
    run.set_meta("log_frames", std::to_string(rep.frames + rep.error_frames));
    run.set_meta("log_lines_skipped", std::to_string(rep.skipped_lines + rep.can_xl_lines + rep.dropcount_lines));
    return run;
}

}  // namespace emadiag
