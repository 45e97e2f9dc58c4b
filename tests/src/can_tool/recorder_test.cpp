// The recorder against the simulated EMA on an in-process bus (the vcan suite repeats this over
// SocketCAN with separate processes): decoded samples equal a direct simulation to within the
// signal resolution, faults are counted, the log decodes to the same run.
#include "can_tool/candump_run.hpp"
#include "can_tool/recorder.hpp"
#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "emadiag/can/memory_bus.hpp"
#include "emadiag/node/ema_node.hpp"
#include "support/node_runner.hpp"
#include "support/samples_within_resolution.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <thread>

using namespace emadiag;
using ::testing::HasSubstr;

namespace {

using test::NodeRunner;
using test::samples_within_resolution;

node::EmaNodeConfig config(sim::Sequence seq, std::uint64_t seed) {
    node::EmaNodeConfig c;
    c.sim.load_case = sim::LoadCase::B;
    c.sim.noise = sim::NoiseProfile::Typical;
    c.sim.seed = seed;
    c.sim.sequence = seq;
    return c;
}

std::string out_path(const std::string& name) { return std::string(EMADIAG_BINARY_DIR) + "/recorder_test_" + name + ".log"; }


}  // namespace

TEST(Recorder, DynRunMatchesDirectSimulationAndTheLogDecodesToTheSameRun) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    NodeRunner ema(hub, config(sim::Sequence::Dyn, 42));
    can_tool::RecorderOptions ro;
    ro.sequence = can::icd::TestSequence::Dyn;
    ro.session_id = 11;
    ro.log_path = out_path("dyn");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    const auto out = rec.record(interrupt);
    EXPECT_EQ(out.status, "complete");
    EXPECT_TRUE(out.valid) << out.invalid_reason;
    EXPECT_EQ(out.stats.samples_expected, 1000u);
    EXPECT_EQ(out.stats.frames_lost, 0u);
    EXPECT_EQ(out.stats.crc_failures, 0u);
    EXPECT_EQ(out.stats.counter_gaps, 0u);
    EXPECT_EQ(out.run.sequence, sim::Sequence::Dyn);
    EXPECT_EQ(out.run.load_case, sim::LoadCase::B);
    EXPECT_EQ(out.run.constants.tau, 800.0);

    sim::SimConfig direct = config(sim::Sequence::Dyn, 42).sim;
    EXPECT_TRUE(samples_within_resolution(out.run, sim::simulate(direct)));

    const emadiag::Run from_log = read_run_candump(ro.log_path);
    ASSERT_EQ(from_log.samples.size(), out.run.samples.size());
    for (std::size_t k = 0; k < from_log.samples.size(); ++k) {
        EXPECT_EQ(from_log.samples[k].current_a, out.run.samples[k].current_a);
        EXPECT_EQ(from_log.samples[k].hinge_moment_nm, out.run.samples[k].hinge_moment_nm);
    }
    EXPECT_EQ(from_log.meta_value("valid"), std::optional<std::string>("true"));
    std::remove(ro.log_path.c_str());
}

TEST(Recorder, FrameLossAndCrcErrorsAreCountedExactlyAndInvalidateTheRun) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = config(sim::Sequence::Dyn, 5);
    cfg.faults.drop_fraction = 0.01;
    cfg.faults.corrupt_crc_fraction = 0.005;
    cfg.faults.seed = 77;
    NodeRunner ema(hub, cfg);
    can_tool::RecorderOptions ro;
    ro.log_path = out_path("faults");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    const auto out = rec.record(interrupt);
    ema.stop();
    EXPECT_EQ(out.stats.frames_lost, ema.stats().telemetry_frames_dropped);
    EXPECT_EQ(out.stats.crc_failures, ema.stats().telemetry_crc_corrupted);
    EXPECT_GT(out.stats.frames_lost, 0u);
    EXPECT_GT(out.stats.crc_failures, 0u);
    EXPECT_FALSE(out.valid);
    EXPECT_THAT(out.invalid_reason, HasSubstr("telemetry loss"));
    EXPECT_LT(out.run.samples.size(), 1000u);  // incomplete samples are left out, not interpolated
    for (std::size_t k = 1; k < out.run.samples.size(); ++k) EXPECT_GT(out.run.samples[k].t_s, out.run.samples[k - 1].t_s);
    std::remove(ro.log_path.c_str());
}

TEST(Recorder, NoEmaIsAClearErrorNamingTheBusAndTheMessage) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    can_tool::RecorderOptions ro;
    ro.log_path = out_path("none");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    EXPECT_THAT([&] { (void)rec.record(interrupt); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr(
                    "no EMA answered on memory:tool within 500 ms: waited for EMA_Ident (0x022, 5 pages) after TOOL_Command REQUEST_IDENT")));
    std::remove(ro.log_path.c_str());
}

TEST(Recorder, InterlockRefusalGivesTheReason) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = config(sim::Sequence::Dyn, 1);
    cfg.faults.refuse_ground_test = node::Interlock::WeightOffWheels;
    NodeRunner ema(hub, cfg);
    can_tool::RecorderOptions ro;
    ro.log_path = out_path("refused");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    EXPECT_THAT([&] { (void)rec.record(interrupt); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("refused ENTER_GROUND_TEST: REFUSED_WEIGHT_ON_WHEELS")));
    std::remove(ro.log_path.c_str());
}

TEST(Recorder, SilentEmaMidSequenceIsReportedIncomplete) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = config(sim::Sequence::Dyn, 1);
    cfg.faults.silent_after_fraction = 0.5;
    NodeRunner ema(hub, cfg);
    can_tool::RecorderOptions ro;
    ro.log_path = out_path("silent");
    ro.silence_timeout = std::chrono::milliseconds(200);
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    const auto out = rec.record(interrupt);
    EXPECT_EQ(out.status, "incomplete");
    EXPECT_FALSE(out.valid);
    EXPECT_THAT(out.invalid_reason, HasSubstr("went silent"));
    EXPECT_EQ(out.run.samples.size(), 500u);
    std::remove(ro.log_path.c_str());
}

TEST(Recorder, InterruptSendsAbortAndMarksTheRunAborted) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    NodeRunner ema(hub, config(sim::Sequence::Brk, 1));
    can_tool::RecorderOptions ro;
    ro.sequence = can::icd::TestSequence::Brk;
    ro.log_path = out_path("interrupt");
    can_tool::Recorder rec(tool, ro);
    std::atomic<bool> interrupt{false};
    std::thread ctrl_c([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(400));
        interrupt = true;
    });
    const auto out = rec.record(interrupt);
    ctrl_c.join();
    EXPECT_EQ(out.status, "aborted");
    EXPECT_FALSE(out.valid);
    EXPECT_LT(out.run.samples.size(), 1600u);
    const emadiag::Run from_log = read_run_candump(ro.log_path);  // the partial log is kept and says aborted
    EXPECT_EQ(from_log.meta_value("status"), std::optional<std::string>("aborted"));
    std::remove(ro.log_path.c_str());
}
