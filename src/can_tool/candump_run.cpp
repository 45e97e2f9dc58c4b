#include "can_tool/candump_run.hpp"

#include "can_tool/session_decoder.hpp"
#include "emadiag/can/candump_log.hpp"

namespace emadiag {

Run read_run_candump(const std::string& path) {
    const auto records = can::read_candump_file(path);
    can_tool::SessionDecoder decoder;
    for (const auto& r : records) decoder.feed(r.frame);
    Run run = decoder.build_run(path);
    run.set_meta("source", "candump log");
    run.set_meta("log_file", path);
    return run;
}

}  // namespace emadiag
