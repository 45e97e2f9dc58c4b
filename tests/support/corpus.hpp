#pragma once
// Test support: where the CAN corpus (real DBC files and candump logs with reference answers, issue
// 25 part 5) is. It is not in the repository: it sits in shared/corpus beside the checkout, as CI has
// shared/ beside its clean clone (EMADIAG_CORPUS_DIR overrides, for a worktree elsewhere). Missing in
// CI (CI=true) it is a failure, never a skip.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace emadiag::test {

inline std::string corpus_dir() {
    if (const char* env = std::getenv("EMADIAG_CORPUS_DIR"); env != nullptr && *env != '\0') return env;
    return std::string(EMADIAG_SOURCE_DIR) + "/../shared/corpus";
}

inline bool running_in_ci() {
    const char* ci = std::getenv("CI");
    return ci != nullptr && std::string(ci) == "true";
}

}  // namespace emadiag::test

/// In a test body: fails in CI, skips elsewhere, when the corpus is not there.
#define EMADIAG_REQUIRE_CORPUS()                                                                                       \
    do {                                                                                                               \
        const std::string corpus_dir_ = ::emadiag::test::corpus_dir();                                                 \
        if (!std::filesystem::is_directory(corpus_dir_ + "/dbc") || !std::filesystem::is_directory(corpus_dir_ + "/candump")) { \
            if (::emadiag::test::running_in_ci())                                                                      \
                FAIL() << "the CAN corpus is missing: no " << corpus_dir_                                              \
                       << "/{dbc,candump} (CI has shared/ beside the clone; EMADIAG_CORPUS_DIR overrides)";           \
            GTEST_SKIP() << "the CAN corpus is not at " << corpus_dir_ << " (set EMADIAG_CORPUS_DIR)";                 \
        }                                                                                                              \
    } while (false)
