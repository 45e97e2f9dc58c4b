#pragma once
// Reading a run file by its extension: RUN.csv (the run CSV) or RUN.log (a candump log of a session).
#include "can_tool/candump_run.hpp"
#include "core/emadiag_error.hpp"
#include "core/run.hpp"
#include "core/run_csv.hpp"

#include <cstdio>
#include <string>

namespace emadiag::cli {

inline bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

inline Run read_run_any(const std::string& path) {
    // A session log keeps its good frames; what was skipped is said on stderr (issue 25 part 4).
    if (ends_with(path, ".log"))
        return read_run_candump(path, [](const std::string& w) { std::fprintf(stderr, "emadiag: warning: %s\n", w.c_str()); });
    if (!ends_with(path, ".csv")) throw EmadiagError(path + ": unknown run format; expected RUN.csv (run CSV) or RUN.log (candump)");
    return read_run_csv_file(path);
}

}  // namespace emadiag::cli
