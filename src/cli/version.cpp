// The tool's identity: `emadiag --version` and the tool_version every stored session records.
#include "cli/version.hpp"

#include "core/data_location.hpp"
#include "core/emadiag_error.hpp"

#include <emadiag/sim/simulator.hpp>

#include <elf.h>
#include <link.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace emadiag::cli {
namespace {

std::string join(const std::vector<std::string>& items) {
    std::string s;
    for (const auto& i : items) s += (s.empty() ? "" : " ") + i;
    return s;
}

/// The NT_GNU_BUILD_ID note of the main program (the first object dl_iterate_phdr reports).
int find_build_id(dl_phdr_info* info, std::size_t, void* data) {
    auto* out = static_cast<std::string*>(data);
    for (int i = 0; i < info->dlpi_phnum; ++i) {
        const auto& ph = info->dlpi_phdr[i];
        if (ph.p_type != PT_NOTE) continue;
        const auto* p = reinterpret_cast<const unsigned char*>(info->dlpi_addr + ph.p_vaddr);
        const auto* end = p + ph.p_memsz;
        while (p + sizeof(ElfW(Nhdr)) <= end) {
            const auto* n = reinterpret_cast<const ElfW(Nhdr)*>(p);
            const auto* name = p + sizeof(ElfW(Nhdr));
            const auto* desc = name + ((n->n_namesz + 3) & ~3u);
            if (desc + n->n_descsz > end) break;
            if (n->n_type == NT_GNU_BUILD_ID && n->n_namesz == 4 && std::string(reinterpret_cast<const char*>(name), 3) == "GNU") {
                char hex[3];
                for (unsigned k = 0; k < n->n_descsz; ++k) {
                    std::snprintf(hex, sizeof hex, "%02x", desc[k]);
                    *out += hex;
                }
                return 1;
            }
            p = desc + ((n->n_descsz + 3) & ~3u);
        }
    }
    return 1;  // only the main program
}

}  // namespace

const std::string& elf_build_id() {
    static const std::string id = [] {
        std::string s;
        dl_iterate_phdr(find_build_id, &s);
        return s;
    }();
    return id;
}

const std::string& tool_version() {
    static const std::string v = std::string(build_info::kRelease) + " (git " + build_info::kGitDescription + ", " + build_info::kBuildType +
                                 (elf_build_id().empty() ? std::string{} : ", build-id " + elf_build_id()) + ")";
    return v;
}

std::string version_text() {
    std::ostringstream os;
    os << "emadiag " << build_info::kRelease << '\n'
       << "git:            " << build_info::kGitDescription << '\n'
       << "build type:     " << build_info::kBuildType << '\n'
       << "build id:       " << (elf_build_id().empty() ? "(none: linked without --build-id)" : elf_build_id()) << '\n'
       << "SIMD compiled:  " << join(sim::compiled_simd_targets()) << '\n';
    try {
        os << "SIMD this CPU:  " << join(sim::supported_simd_targets()) << "; in use: " << sim::simd_target().name << '\n';
    } catch (const std::exception& e) {
        os << "SIMD this CPU:  " << e.what() << '\n';
    }
    const auto models = models_locations();
    os << "models:         ";
    if (models.empty()) os << "none found (not installed, not in a build tree; set " << kModelsDirEnvVar << " or give --models DIR)";
    for (std::size_t i = 0; i < models.size(); ++i) os << (i ? "; then " : "") << models[i].dir.string() << " (" << models[i].how << ")";
    return os.str();  // CLI11 ends the --version output with its own newline
}

void apply_models_override(const std::string& models_option) {
    if (!models_option.empty()) ::setenv(kModelsDirEnvVar, models_option.c_str(), 1);
    const char* env = std::getenv(kModelsDirEnvVar);
    if (env == nullptr || *env == '\0') return;
    const std::string how = models_option.empty() ? std::string(kModelsDirEnvVar) + "=" + env : "--models " + models_option;
    std::error_code ec;
    if (!std::filesystem::is_directory(env, ec)) throw EmadiagError(how + ": no such folder (the models folder given explicitly)");
    const auto installed = installed_data_dir();
    const auto source = build_tree_source_dir();
    std::cerr << "emadiag: shipped models from " << how << ", instead of "
              << (installed ? (*installed / "models").string() + " (installed)"
                  : source ? (*source / "models").string() + " (build tree)"
                           : std::string("the installed ones")) << '\n';
}

}  // namespace emadiag::cli
