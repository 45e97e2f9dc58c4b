// The fleet site's file names for hostile tail numbers (cli/site_file_name.hpp): a path, a parent
// reference, a dot file, bytes that are not text, and names that differ only in an escaped byte all
// become distinct plain names inside tails/. Property check: one-to-one over random byte strings
// (printed seed).
#include "cli/site_file_name.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <iostream>
#include <map>
#include <random>
#include <string>

namespace {

using emadiag::cli::site_tail_file_name;
using ::testing::MatchesRegex;

TEST(HostileSiteFileName, PathsDotsAndControlBytesBecomePlainNames) {
    EXPECT_EQ(site_tail_file_name("N123EM"), "tail-N123EM.html");
    EXPECT_EQ(site_tail_file_name("../N1"), "tail-_2E_2E_2FN1.html");
    EXPECT_EQ(site_tail_file_name("/etc/passwd"), "tail-_2Fetc_2Fpasswd.html");
    EXPECT_EQ(site_tail_file_name(".hidden"), "tail-_2Ehidden.html");
    EXPECT_EQ(site_tail_file_name(std::string("a\0b", 3)), "tail-a_00b.html");
    EXPECT_EQ(site_tail_file_name("\xff<script>"), "tail-_FF_3Cscript_3E.html");
    EXPECT_EQ(site_tail_file_name(""), "tail-.html");
    for (const char* t : {"../x", "a/b", "x y", "\n", "\xe2\x9c\x88", "index"})
        EXPECT_THAT(site_tail_file_name(t), MatchesRegex("tail-[A-Za-z0-9_-]*\\.html")) << t;
}

TEST(HostileSiteFileName, TheEscapeItselfIsEscapedSoNamesNeverCollide) {
    EXPECT_NE(site_tail_file_name("N_20"), site_tail_file_name("N 20"));
    EXPECT_EQ(site_tail_file_name("N_20"), "tail-N_5F20.html");
    EXPECT_EQ(site_tail_file_name("N 20"), "tail-N_2020.html");
}

TEST(HostileSiteFileName, OneToOneOverRandomNames) {
    constexpr std::uint64_t kSeed = 26;
    constexpr int kNames = 20000;
    constexpr int kMaxLength = 6;
    std::cout << "seed " << kSeed << ", " << kNames << " names\n";
    std::mt19937_64 rng(kSeed);
    const std::string alphabet = std::string("A_-/. 0\x7f\xff", 9) + std::string(1, '\0');
    std::map<std::string, std::string> seen;
    for (int i = 0; i < kNames; ++i) {
        std::string name;
        const auto length = static_cast<int>(rng() % (kMaxLength + 1));
        for (int k = 0; k < length; ++k) name += alphabet[rng() % alphabet.size()];
        const std::string file = site_tail_file_name(name);
        const auto [it, fresh] = seen.emplace(file, name);
        EXPECT_TRUE(fresh || it->second == name) << "seed " << kSeed << ": '" << name << "' and '" << it->second << "' both give " << file;
        EXPECT_THAT(file, MatchesRegex("tail-[A-Za-z0-9_-]*\\.html"));
    }
}

}  // namespace
