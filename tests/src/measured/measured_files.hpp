#pragma once
// Test support for the measured-run import: files written beside the build, and where the rig's
// real measurements are (shared/data beside the checkout, as the CAN corpus; EMADIAG_DATA_DIR
// overrides, for a worktree elsewhere). Missing in CI (CI=true) they are a failure, never a skip.
#include "support/corpus.hpp"
#include "support/text_files.hpp"

#include <cstdlib>
#include <string>

namespace emadiag::test {

inline std::string measured_file(const std::string& name, const std::string& text) {
    return write_test_file("measured_test_", name, text);
}

inline std::string rig_data_dir() {
    if (const char* env = std::getenv("EMADIAG_DATA_DIR"); env != nullptr && *env != '\0') {
        return std::string(env) + "/cranfield-linear-actuator";
    }
    return std::string(EMADIAG_SOURCE_DIR) + "/../shared/data/cranfield-linear-actuator";
}

}  // namespace emadiag::test

/// In a test body: fails in CI, skips elsewhere, when the rig's files are not there.
#define EMADIAG_REQUIRE_RIG_DATA()                                                                                   \
    do {                                                                                                             \
        if (!std::filesystem::is_regular_file(::emadiag::test::rig_data_dir() + "/normal.csv")) {                   \
            if (::emadiag::test::running_in_ci())                                                                    \
                FAIL() << "the rig's measurements are missing: no " << ::emadiag::test::rig_data_dir()               \
                       << "/normal.csv (CI has shared/ beside the clone; EMADIAG_DATA_DIR overrides)";              \
            GTEST_SKIP() << "the rig's measurements are not at " << ::emadiag::test::rig_data_dir()                 \
                         << " (set EMADIAG_DATA_DIR)";                                                               \
        }                                                                                                            \
    } while (false)
