#include "core/data_location.hpp"

#include <cstdlib>
#include <fstream>

#ifndef EMADIAG_BIN_TO_DATA
#define EMADIAG_BIN_TO_DATA "../share/emadiag"  // CMAKE_INSTALL_BINDIR -> CMAKE_INSTALL_DATADIR/emadiag
#endif

namespace emadiag {
namespace {

/// How many folders above the binary a build tree's CMakeCache.txt may be (build/src/emadiag: 1;
/// build/tests/src/cli/x_test: 3).
constexpr int kBuildTreeDepth = 4;
constexpr const char* kHomeDirKey = "CMAKE_HOME_DIRECTORY:INTERNAL=";

}  // namespace

std::optional<std::filesystem::path> running_binary() {
    std::error_code ec;
    auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec || exe.empty()) return std::nullopt;
    return exe;
}

std::optional<std::filesystem::path> installed_data_dir() {
    const auto exe = running_binary();
    if (!exe) return std::nullopt;
    std::error_code ec;
    const auto dir = std::filesystem::weakly_canonical(exe->parent_path() / EMADIAG_BIN_TO_DATA, ec);
    if (ec || !std::filesystem::is_directory(dir, ec)) return std::nullopt;
    return dir;
}

std::optional<std::filesystem::path> build_tree_source_dir() {
    const auto exe = running_binary();
    if (!exe) return std::nullopt;
    auto dir = exe->parent_path();
    for (int i = 0; i < kBuildTreeDepth && !dir.empty(); ++i, dir = dir.parent_path()) {
        std::ifstream cache(dir / "CMakeCache.txt");
        if (!cache) {
            if (dir == dir.root_path()) break;
            continue;
        }
        std::string line;
        while (std::getline(cache, line)) {
            if (line.rfind(kHomeDirKey, 0) == 0) return std::filesystem::path(line.substr(std::string(kHomeDirKey).size()));
        }
        return std::nullopt;
    }
    return std::nullopt;
}

std::vector<DataLocation> models_locations() {
    if (const char* env = std::getenv(kModelsDirEnvVar); env != nullptr && *env != '\0') return {{env, kModelsDirEnvVar}};
    std::vector<DataLocation> out;
    if (const auto data = installed_data_dir()) out.push_back({*data / "models", "installed"});
    if (const auto src = build_tree_source_dir()) out.push_back({*src / "models", "build tree"});
    return out;
}

}  // namespace emadiag
