#pragma once
// Writing a command's output to --out FILE whole (a temporary file renamed into place: a reader
// never sees half a report) or to stdout when no file is given.
#include "core/emadiag_error.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

namespace emadiag::cli {

inline void write_output(const std::string& path, const std::string& text) {
    if (path.empty()) {
        std::cout << text << std::flush;
        return;
    }
    const std::string tmp = path + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw EmadiagError(path + ": cannot write the output (cannot create " + tmp + ")");
        out << text;
        out.flush();
        if (!out) {
            std::error_code ignored;
            std::filesystem::remove(tmp, ignored);
            throw EmadiagError(path + ": writing the output failed (disk full?)");
        }
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        throw EmadiagError(path + ": cannot move the output into place");
    }
}

/// A CSV field: quoted when it holds a comma, quote or line break (RFC 4180).
inline std::string csv_field(const std::string& s) {
    if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
    std::string out = "\"";
    for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

}  // namespace emadiag::cli
