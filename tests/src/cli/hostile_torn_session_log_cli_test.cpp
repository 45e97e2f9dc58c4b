// A real session's log whose last line is torn (a killed recording, a power cut) gives the same
// estimates as the untorn log, and says which line was skipped (issue 25 part 4). Before, `emadiag
// estimate` refused the whole log ("...: expected data as pairs of hex digits") and the session was lost.
#include "can_tool/recorder.hpp"
#include "emadiag/can/memory_bus.hpp"
#include "emadiag/node/ema_node.hpp"
#include "support/cli_runner.hpp"
#include "support/node_runner.hpp"

#include "support/text_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

using namespace emadiag;
using emadiag::test::run_cli;
using ::testing::AllOf;
using ::testing::HasSubstr;

namespace {

std::string out_path(const std::string& name) { return std::string(EMADIAG_BINARY_DIR) + "/torn_session_cli_" + name; }

std::size_t count_lines(const std::string& text) { return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')); }

}  // namespace

TEST(HostileTornSessionLog, GivesTheSameEstimatesAndSaysWhichLineWasSkipped) {
    // A DYN session recorded from the simulated EMA on an in-process bus.
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    node::EmaNodeConfig cfg;
    cfg.sim.load_case = sim::LoadCase::B;
    cfg.sim.noise = sim::NoiseProfile::Typical;
    cfg.sim.seed = 42;
    test::NodeRunner ema(hub, cfg);
    can_tool::RecorderOptions ro;
    ro.sequence = can::icd::TestSequence::Dyn;
    ro.session_id = 7;
    ro.log_path = out_path("whole.log");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    const auto out = rec.record(interrupt);
    ASSERT_EQ(out.status, "complete");
    ema.stop();
    const std::string whole = emadiag::test::file_bytes(ro.log_path);
    ASSERT_GT(count_lines(whole), 2000U);
    // Then one more line, cut mid-byte with no final newline: a TelemetryA frame the recorder was
    // writing when it was killed.
    const std::string torn_path = out_path("torn.log");
    std::ofstream(torn_path, std::ios::binary) << whole << "(1700000099.000100) vcan0 100#0C002";
    const std::size_t torn_line = count_lines(whole) + 1;

    const auto a = run_cli("estimate " + ro.log_path, false);
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const auto b = run_cli("estimate " + torn_path, false);
    ASSERT_EQ(b.exit_code, 0) << b.output;
    // The same estimates: the output differs only in the file name.
    std::string b_as_a = b.output;
    for (auto at = b_as_a.find(torn_path); at != std::string::npos; at = b_as_a.find(torn_path, at + 1)) b_as_a.replace(at, torn_path.size(), ro.log_path);
    EXPECT_EQ(b_as_a, a.output);
    const auto warned = run_cli("estimate " + torn_path);
    EXPECT_THAT(warned.output, AllOf(HasSubstr("emadiag: warning: " + torn_path + ":" + std::to_string(torn_line) +
                                               ":35: expected data as pairs of hex digits; line skipped"),
                                     HasSubstr("the last line is incomplete and has no final newline: the recording was cut short"),
                                     HasSubstr("skipped 1 torn or malformed line")));
    if (!std::getenv("EMADIAG_KEEP_TEST_LOGS")) std::remove(ro.log_path.c_str());
    if (!std::getenv("EMADIAG_KEEP_TEST_LOGS")) std::remove(torn_path.c_str());
}
