#pragma once
// Test support: runs the emadiag binary (EMADIAG_CLI, set for tests/src/cli) with arguments through
// the shell and returns its exit code and output; every CLI test drives the binary this way.
#include <array>
#include <cstdio>
#include <string>
#include <sys/wait.h>

namespace emadiag::test {

struct CliResult {
    int exit_code = -1;  ///< -1 when the shell could not run it or it died of a signal
    std::string output;  ///< stdout, and stderr unless left out
};

/// A shell command line's exit code and standard output.
inline CliResult run_shell(const std::string& cmd) {
    CliResult r;
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf{};
    std::size_t n;
    while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    const int status = pclose(p);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

/// `emadiag ARGS`; stderr is merged into the output, or discarded when merge_stderr is false.
inline CliResult run_cli(const std::string& args, bool merge_stderr = true) {
    return run_shell(std::string(EMADIAG_CLI) + " " + args + (merge_stderr ? " 2>&1" : " 2>/dev/null"));
}

}  // namespace emadiag::test
