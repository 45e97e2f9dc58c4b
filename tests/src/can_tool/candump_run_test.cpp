// A session's log keeps its good frames (issue 25 part 4): a torn last line (a killed recording, a
// power cut) or a malformed line is skipped with a warning naming the line, and the run is the same
// as from the untorn log; the run's validity follows the telemetry itself.
#include "can_tool/candump_run.hpp"
#include "core/run.hpp"
#include "emadiag/can/can_error.hpp"

#include "support/text_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace emadiag;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

namespace {

std::string write(const std::string& name, const std::string& text) { return emadiag::test::write_test_file("candump_run_test_", name, text); }

/// A recorded session (12 samples; fuzz/corpus/candump/session_12.log, written by the recorder).
const std::string kSession = std::string(EMADIAG_SOURCE_DIR) + "/fuzz/corpus/candump/session_12.log";

void expect_same_samples(const Run& a, const Run& b) {
    ASSERT_EQ(a.samples.size(), b.samples.size());
    for (std::size_t i = 0; i < a.samples.size(); ++i) {
        EXPECT_EQ(a.samples[i].t_s, b.samples[i].t_s) << i;
        EXPECT_EQ(a.samples[i].current_a, b.samples[i].current_a) << i;
        EXPECT_EQ(a.samples[i].speed_rad_s, b.samples[i].speed_rad_s) << i;
    }
}

}  // namespace

TEST(CandumpRun, ATornLastLineIsSkippedWithAWarningAndTheRunKept) {
    const std::string text = emadiag::test::file_bytes(kSession);
    ASSERT_FALSE(text.empty()) << kSession;
    std::vector<std::string> warnings;
    const emadiag::Run whole = read_run_candump(write("whole.log", text), [&](const std::string& w) { warnings.push_back(w); });
    EXPECT_TRUE(warnings.empty()) << ::testing::PrintToString(warnings);
    EXPECT_EQ(whole.meta_value("log_lines_skipped"), "0");
    // The recording was killed while writing one more line: a telemetry frame cut mid-byte.
    const std::string torn_path = write("torn.log", text + "(1700000000.050000) vcan0 100#0C002");
    warnings.clear();
    const emadiag::Run torn = read_run_candump(torn_path, [&](const std::string& w) { warnings.push_back(w); });
    EXPECT_THAT(warnings, ElementsAre(torn_path + ":51:35: expected data as pairs of hex digits; line skipped",
                                      torn_path + ":51: the last line is incomplete and has no final newline: the recording was cut short",
                                      torn_path + ": read 50 frames; skipped 1 torn or malformed line"));
    expect_same_samples(whole, torn);
    EXPECT_EQ(torn.meta_value("log_lines_skipped"), "1");
    EXPECT_EQ(torn.meta_value("valid"), whole.meta_value("valid"));
    EXPECT_EQ(torn.meta_value("status"), whole.meta_value("status"));
}

TEST(CandumpRun, AMalformedTelemetryLineCostsItsSampleNotTheSession) {
    std::string text = emadiag::test::file_bytes(kSession);
    // Break the first TelemetryA line (id 100): its sample is lost, the rest of the run kept, and the
    // loss shows in the telemetry counts, which decide the run's validity.
    const auto at = text.find(" vcan0 100#");
    ASSERT_NE(at, std::string::npos);
    text.replace(at + 7, 3, "1G0");
    std::vector<std::string> warnings;
    const emadiag::Run whole = read_run_candump(write("whole2.log", emadiag::test::file_bytes(kSession)));
    const emadiag::Run r = read_run_candump(write("broken.log", text), [&](const std::string& w) { warnings.push_back(w); });
    ASSERT_EQ(warnings.size(), 2U);
    EXPECT_THAT(warnings[0], HasSubstr("expected hex id digits and '#'; line skipped"));
    EXPECT_EQ(r.samples.size() + 1, whole.samples.size());
    EXPECT_EQ(r.meta_value("frames_lost"), "1");
    EXPECT_EQ(r.meta_value("valid"), "false") << "1 of 24 telemetry frames lost is above kMaxLossFraction";
}

TEST(CandumpRun, ConsoleOutputIsRefusedWithTheHint) {
    const std::string path = write("console.log", "  can0  680   [8]  03 22 01 00 00 00 00 00\n");
    EXPECT_THAT([&] { (void)read_run_candump(path); }, ::testing::ThrowsMessage<can::CanError>(HasSubstr("record the bus with `candump -l`")));
}
