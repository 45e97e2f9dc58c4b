#pragma once
// The file name of a tail's page in the fleet site (`emadiag site`, cmd_site.cpp): tail-<name>.html
// with [A-Za-z0-9-] kept and every other byte written as _XX (upper-case hex), '_' itself included,
// so the mapping is one-to-one and no name can leave tails/, hide as a dot file or collide with
// another tail's. The maintenance database only stores A-Z, 0-9 and '-' today; a fleet server or a
// later schema may not, and the site must not depend on it.
#include <string>

namespace emadiag::cli {

inline constexpr const char* kSiteTailFilePrefix = "tail-";
inline constexpr const char* kSitePageExtension = ".html";
/// The CSV list of every session of a summarised section, beside its tail's page (cmd_site.cpp).
inline constexpr const char* kSiteListExtension = ".csv";

[[nodiscard]] inline std::string site_tail_file_name(const std::string& tail) {
    static constexpr const char* kHex = "0123456789ABCDEF";
    std::string out = kSiteTailFilePrefix;
    for (const unsigned char c : tail) {
        if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-') {
            out += static_cast<char>(c);
        } else {
            out += '_';
            out += kHex[c >> 4];
            out += kHex[c & 0xF];
        }
    }
    return out + kSitePageExtension;
}

}  // namespace emadiag::cli
