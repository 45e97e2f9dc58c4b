#pragma once
// The tool's identity (issue 26): the release, the git description of the sources it was built from,
// the build type and the ELF build id of the binary. tool_version() is what every stored session,
// report and export names (EMADIAG_VERSION in the command files expands to it); version_text() is
// `emadiag --version`.
#include <string>

namespace emadiag::cli {

namespace build_info {
// Defined in the build_info.cpp generated at each build (src/cli/build_info.cmake).
extern const char* const kRelease;         ///< project(VERSION), e.g. "0.1.0"
extern const char* const kGitDescription;  ///< git describe --always --dirty, or a fallback without git
extern const char* const kBuildType;       ///< CMAKE_BUILD_TYPE
}  // namespace build_info

/// The GNU build id of the running binary (hex), or "" when it was linked without one.
[[nodiscard]] const std::string& elf_build_id();

/// "0.1.0 (git c165b7f-dirty, Release, build-id 3f2a...)": the release and the build id in one line.
[[nodiscard]] const std::string& tool_version();

/// The text of `emadiag --version`: the release, the git description, the build type, the build id,
/// the SIMD targets compiled in and the one this CPU runs, and where the data are looked for (no final newline).
[[nodiscard]] std::string version_text();

/// The models folder chosen explicitly: `--models DIR` (given: it sets EMADIAG_MODELS_DIR) or the
/// environment variable. Says so on stderr, naming what it overrides; throws EmadiagError when the
/// folder does not exist (an explicit choice never falls back silently).
void apply_models_override(const std::string& models_option);

}  // namespace emadiag::cli
