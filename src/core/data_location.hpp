#pragma once
// Where the installed data are (issue 26): the shipped models, the DBC and the actuator profiles live
// under <prefix>/share/emadiag (GNUInstallDirs), found from the running binary (/proc/self/exe), never
// from the current directory. A binary still in its build tree (a CMakeCache.txt above it) reads the
// source tree's folders instead. $EMADIAG_MODELS_DIR (or the CLI's --models DIR, which sets it) is an
// explicit choice: it alone counts, and the CLI says so on stderr.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

/// The environment variable that names the models folder explicitly.
inline constexpr const char* kModelsDirEnvVar = "EMADIAG_MODELS_DIR";

/// A folder and how it was chosen, for messages and `emadiag --version`.
struct DataLocation {
    std::filesystem::path dir;
    std::string how;  ///< "EMADIAG_MODELS_DIR", "installed", "build tree (source ...)"
};

/// The running binary's own path (/proc/self/exe), if the system tells it.
[[nodiscard]] std::optional<std::filesystem::path> running_binary();

/// <prefix>/share/emadiag for a binary in <prefix>/bin (the install layout), if that folder exists.
[[nodiscard]] std::optional<std::filesystem::path> installed_data_dir();

/// The source tree of a binary that runs from its build tree (CMAKE_HOME_DIRECTORY of the nearest
/// CMakeCache.txt among the binary's first four parent folders), if it is one.
[[nodiscard]] std::optional<std::filesystem::path> build_tree_source_dir();

/// Where the shipped models are looked for, in order (the first that exists counts): only
/// $EMADIAG_MODELS_DIR when it is set; else <prefix>/share/emadiag/models of an installed binary,
/// else <source>/models of a binary in its build tree. Never ./models.
[[nodiscard]] std::vector<DataLocation> models_locations();

}  // namespace emadiag
