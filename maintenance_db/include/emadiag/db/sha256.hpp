#pragma once
// SHA-256 (FIPS 180-4), for the hash chain of the maintenance record and the hashes of the model
// files and limits a session used. Incremental: update() any number of times, then hex().
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace emadiag::db {

class Sha256 {
public:
    Sha256();
    Sha256& update(std::string_view bytes);
    /// The digest as 64 lowercase hex digits. Ends the computation: call once.
    [[nodiscard]] std::string hex();

private:
    void block(const unsigned char* p);
    std::array<std::uint32_t, 8> h_{};
    std::array<unsigned char, 64> buf_{};
    std::size_t buf_len_ = 0;
    std::uint64_t total_bytes_ = 0;
};

/// SHA-256 of `bytes` as 64 lowercase hex digits.
[[nodiscard]] std::string sha256_hex(std::string_view bytes);
/// SHA-256 of a file's bytes. Throws DbError naming the file when it cannot be read.
[[nodiscard]] std::string sha256_file_hex(const std::string& path);

}  // namespace emadiag::db
