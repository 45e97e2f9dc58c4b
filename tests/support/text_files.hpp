#pragma once
// Test support: a file's bytes as a string, and a file written from a string (the CAN log tests).
#include <fstream>
#include <sstream>
#include <string>

namespace emadiag::test {

/// The whole file, byte for byte; empty when it cannot be read.
inline std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Writes `text` to EMADIAG_BINARY_DIR/<prefix><name> and returns the path.
inline std::string write_test_file(const std::string& prefix, const std::string& name, const std::string& text) {
    const std::string path = std::string(EMADIAG_BINARY_DIR) + "/" + prefix + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
}

}  // namespace emadiag::test
