// The ICD codecs: telemetry at signal resolution with CRC, and every message round trip.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/ema_icd.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

using namespace emadiag::can;
namespace icd = emadiag::can::icd;

TEST(EmaIcd, TelemetryRoundTripWithinHalfAResolutionStepAndCrc) {
    const EmaIcd c;
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> cur(-40, 40), spd(-1200, 1200), th(-400, 400), h(-5000, 5000);
    for (int i = 0; i < 10000; ++i) {
        const double ia = cur(rng), w = spd(rng), t = th(rng), hm = h(rng);
        const auto idx = static_cast<std::uint16_t>(rng());
        const auto cnt = static_cast<std::uint8_t>(rng() % 16);
        TelemetryA a;
        TelemetryB b;
        ASSERT_TRUE(c.decode_telemetry_a(c.encode_telemetry_a(idx, cnt, ia, w), a));
        ASSERT_TRUE(c.decode_telemetry_b(c.encode_telemetry_b(idx, cnt, t, hm), b));
        EXPECT_EQ(a.index, idx);
        EXPECT_EQ(b.counter, cnt);
        EXPECT_TRUE(a.crc_ok && b.crc_ok);
        EXPECT_NEAR(a.current_a, ia, 0.001 + 1e-12);
        EXPECT_NEAR(a.speed_rad_s, w, 0.025 + 1e-9);
        EXPECT_NEAR(b.theta_m_rad, t, 0.0005 + 1e-9);
        EXPECT_NEAR(b.hinge_moment_nm, hm, 0.25 + 1e-9);
    }
    CanFrame f = c.encode_telemetry_a(1, 2, 3.0, 4.0);
    TelemetryA a;
    for (int bit = 0; bit < 64; ++bit) {  // every single-bit error is detected
        CanFrame g = f;
        g.data[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
        ASSERT_TRUE(c.decode_telemetry_a(g, a));
        EXPECT_FALSE(a.crc_ok) << "bit " << bit;
    }
    f.len = 7;
    EXPECT_FALSE(c.decode_telemetry_a(f, a));
    EXPECT_THAT([&] { (void)c.encode_telemetry_a(0, 0, 70.0, 0.0); },
                ::testing::ThrowsMessage<CanError>(::testing::HasSubstr("signal 'MotorCurrent': value 70")));
}

TEST(EmaIcd, ControlMessagesRoundTrip) {
    const EmaIcd c;
    EmaStatus s;
    s.mode = icd::Mode::GroundTest;
    s.weight_on_wheels = false;
    s.state = icd::SequenceState::Aborted;
    s.sequence = icd::TestSequence::Brk;
    s.load_case = icd::LoadCase::AExt;
    s.counter = 13;
    s.session_id = 54321;
    s.samples_sent = 1600;
    s.fault = icd::FaultCode::HeartbeatLost;
    const auto back = c.decode_status(c.encode_status(s));
    ASSERT_TRUE(back);
    EXPECT_EQ(back->mode, s.mode);
    EXPECT_FALSE(back->weight_on_wheels);
    EXPECT_TRUE(back->maintenance_enable);
    EXPECT_EQ(back->state, s.state);
    EXPECT_EQ(back->sequence, s.sequence);
    EXPECT_EQ(back->load_case, s.load_case);
    EXPECT_EQ(back->counter, 13);
    EXPECT_EQ(back->session_id, 54321);
    EXPECT_EQ(back->samples_sent, 1600);
    EXPECT_EQ(back->fault, s.fault);

    const CanFrame start = c.encode_command(ToolCommand{icd::Command::StartSequence, icd::TestSequence::Dyn, 777});
    EXPECT_EQ(start.id, icd::kToolCommandId);
    EXPECT_EQ(start.data[0], 3);
    const auto cmd = c.decode_command(start);
    ASSERT_TRUE(cmd);
    EXPECT_EQ(cmd->sequence, icd::TestSequence::Dyn);
    EXPECT_EQ(cmd->session_id, 777);
    // `cansend vcan0 010#04000000` is an ABORT (the message is 4 bytes; shorter frames are rejected).
    CanFrame abort_frame;
    abort_frame.id = icd::kToolCommandId;
    abort_frame.len = 4;
    abort_frame.data[0] = 4;
    EXPECT_EQ(c.decode_command(abort_frame)->command, icd::Command::Abort);

    const auto ack = c.decode_ack(c.encode_ack(CommandAck{icd::Command::EnterGroundTest, icd::AckResult::RefusedWeightOnWheels, 5}));
    ASSERT_TRUE(ack);
    EXPECT_EQ(ack->result, icd::AckResult::RefusedWeightOnWheels);
    EXPECT_EQ(c.value_name(c.ack, "AckResult", 1), "REFUSED_WEIGHT_ON_WHEELS");

    EmaIdentification id;
    id.serial_number = 4000000000u;
    id.part_number = 0x45524631;
    id.firmware_major = 1;
    id.firmware_minor = 2;
    id.firmware_patch = 3;
    id.k_t_nm_per_a = 0.2;
    id.j_kgm2 = 1.65e-4;
    id.tau = 800;
    id.sample_period_s = 5e-4;
    IdentAssembler as;
    for (const auto& f : c.encode_ident(id)) {
        EXPECT_FALSE(as.complete());
        ASSERT_TRUE(c.decode_ident(f, as));
    }
    ASSERT_TRUE(as.complete());
    const auto& g = as.identification();
    EXPECT_EQ(g.serial_number, id.serial_number);
    EXPECT_EQ(g.part_number, id.part_number);
    EXPECT_EQ(g.firmware_minor, 2);
    EXPECT_EQ(g.k_t_nm_per_a, static_cast<double>(0.2f));
    EXPECT_EQ(g.j_kgm2, static_cast<double>(1.65e-4f));
    EXPECT_EQ(g.tau, 800.0);
    EXPECT_NEAR(g.sample_period_s, 5e-4, 1e-15);
}

#include "emadiag/can/bus_load.hpp"

TEST(EmaIcd, WorstCaseBusLoadAtOneMegabitIsAtMost60Percent) {
    static_assert(worst_case_frame_bits(8, false) == 135);
    static_assert(worst_case_frame_bits(1, false) == 65);
    static_assert(worst_case_frame_bits(0, false) == 55);
    static_assert(worst_case_frame_bits(8, true) == 160);
    constexpr double kBitrate = 1e6;
    constexpr double kMaxLoad = 0.60;
    const BusLoad load = cyclic_bus_load(ema_database(), kBitrate);
    std::cout << load.table();
    ASSERT_EQ(load.lines.size(), 4u);  // TOOL_Heartbeat, EMA_Status, EMA_TelemetryA, EMA_TelemetryB
    EXPECT_DOUBLE_EQ(load.bits_per_s, 2 * 2000 * 135 + 50 * 135 + 50 * 65);
    EXPECT_LE(load.fraction(), kMaxLoad);
}
