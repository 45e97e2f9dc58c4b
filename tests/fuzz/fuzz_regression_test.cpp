// Every input the fuzzers found a problem with (tests/data/fuzz_regressions/<target>/), and every
// seed of the corpora (fuzz/corpus/<target>/), fed to the same entry point as the libFuzzer target
// (fuzz/fuzz_entries.hpp) in the normal build: each must be accepted or rejected with the project's
// error, never crash, abort or throw anything else (issue 12 part 1).
#include "fuzz/fuzz_entries.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

namespace fs = std::filesystem;

namespace {

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Feeds every file of `dir` to `target`; returns how many there were.
int feed_all(const emadiag::fuzz::Target& target, const fs::path& dir) {
    int n = 0;
    if (!fs::is_directory(dir)) return 0;
    for (const auto& e : fs::directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        const auto bytes = read_bytes(e.path());
        SCOPED_TRACE(e.path().string());
        EXPECT_NO_THROW(target.run(bytes.data(), bytes.size())) << target.name << " on " << e.path();
        ++n;
    }
    return n;
}

class FuzzRegression : public ::testing::TestWithParam<emadiag::fuzz::Target> {};

TEST_P(FuzzRegression, KeptFindingsAndSeedsAreHandledCleanly) {
    const auto& t = GetParam();
    const fs::path src = EMADIAG_SOURCE_DIR;
    const int seeds = feed_all(t, src / "fuzz" / "corpus" / t.name);
    const int findings = feed_all(t, src / "tests" / "data" / "fuzz_regressions" / t.name);
    EXPECT_GT(seeds, 0) << "no seed corpus for " << t.name << " in fuzz/corpus/";
    std::cout << t.name << ": " << seeds << " seeds, " << findings << " kept findings\n";
}

INSTANTIATE_TEST_SUITE_P(AllTargets, FuzzRegression, ::testing::ValuesIn(emadiag::fuzz::targets()),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(FuzzFrameStream, DecodesTheDocumentedLayout) {
    // selector 5 (telemetry A) with the CRC bit, length 8, 8 payload bytes; selector 7, id, length 0.
    const std::uint8_t bytes[] = {0x0D, 8, 1, 0, 0x10, 0, 0, 0, 0, 0xEE, 0x07, 0x01, 0x23, 0x00};
    const auto frames = emadiag::fuzz::frame_stream_frames(bytes, sizeof bytes);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[0].id, 0x100u);
    EXPECT_EQ(frames[0].len, 8);
    EXPECT_NE(frames[0].data[7], 0xEE);  // the CRC byte was replaced by CRC-8 of bytes 0..6
    EXPECT_EQ(frames[1].id, 0x123u);     // selector 7: the 16-bit id that follows (masked to 11 bits)
}

}  // namespace
