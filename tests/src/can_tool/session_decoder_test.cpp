// SessionDecoder on hand-made frame sequences: what is counted, what is left out, what is an error.
#include "can_tool/session_decoder.hpp"
#include "core/emadiag_error.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

using namespace emadiag;
using namespace emadiag::can;
using ::testing::HasSubstr;

namespace {

void feed_preamble(can_tool::SessionDecoder& d, std::uint16_t session) {
    EmaIdentification id;
    id.k_t_nm_per_a = 0.2;
    id.j_kgm2 = 1.65e-4;
    id.tau = 800;
    id.sample_period_s = 5e-4;
    for (const auto& f : d.icd.encode_ident(id)) d.feed(f);
    d.feed(d.icd.encode_command({icd::Command::StartSequence, icd::TestSequence::Dyn, session}));
}

void feed_status(can_tool::SessionDecoder& d, std::uint16_t session, std::uint16_t sent, icd::SequenceState st) {
    EmaStatus s;
    s.mode = icd::Mode::GroundTest;
    s.state = st;
    s.session_id = session;
    s.samples_sent = sent;
    s.load_case = icd::LoadCase::AExt;
    d.feed(d.icd.encode_status(s));
}

}  // namespace

TEST(SessionDecoder, MissingIdentificationOrStartIsAnError) {
    can_tool::SessionDecoder d;
    EXPECT_THAT([&] { (void)d.build_run("x.log"); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("x.log: no complete EMA_Ident (0x022, all 5 pages)")));
    EmaIdentification id;
    for (const auto& f : d.icd.encode_ident(id)) d.feed(f);
    EXPECT_THAT([&] { (void)d.build_run("x.log"); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("x.log: no TOOL_Command START_SEQUENCE (0x010)")));
}

TEST(SessionDecoder, CountsLossCrcCounterGapsAndDuplicatesAndNeverInterpolates) {
    can_tool::SessionDecoder d;
    feed_preamble(d, 7);
    constexpr std::uint16_t kSamples = 40;  // counters wrap twice
    for (std::uint16_t k = 0; k < kSamples; ++k) {
        const auto c = static_cast<std::uint8_t>(k % 16);
        CanFrame a = d.icd.encode_telemetry_a(k, c, 0.01 * k, 1.0);
        CanFrame b = d.icd.encode_telemetry_b(k, c, 0.001 * k, 2.0);
        if (k == 5) continue;                      // both halves lost
        if (k == 9) a.data[7] ^= 0xFF;             // A corrupt
        d.feed(a);
        if (k != 20) d.feed(b);                    // B lost
        if (k == 30) d.feed(b);                    // B duplicated
    }
    feed_status(d, 7, kSamples, icd::SequenceState::Done);
    const auto st = d.stats();
    EXPECT_EQ(st.samples_expected, 40u);
    EXPECT_EQ(st.frames_expected, 80u);
    EXPECT_EQ(st.crc_failures, 1u);
    EXPECT_EQ(st.frames_lost, 3u);  // A5, B5, B20
    EXPECT_EQ(st.duplicates, 1u);
    EXPECT_EQ(st.samples_complete, 37u);  // all but 5, 9, 20
    // Counter gaps: A misses 5 and 9 (corrupt frames are not trusted), B misses 5 and 20. The
    // duplicate B30 is recognised by its index before the counter is read (a retransmission repeats
    // both), so it does not read as 15 missing frames.
    EXPECT_EQ(st.counter_gaps, 2u + 2u);
    EXPECT_DOUBLE_EQ(st.loss_fraction(), 4.0 / 80.0);
    const emadiag::Run run = d.build_run("test");
    EXPECT_EQ(run.samples.size(), 37u);
    for (const auto& s : run.samples) {
        const long k = std::lround(s.t_s / 5e-4) - 1;
        EXPECT_NE(k, 5);
        EXPECT_NE(k, 9);
        EXPECT_NE(k, 20);
        EXPECT_NEAR(s.current_a, 0.01 * static_cast<double>(k), 1e-3);
    }
    EXPECT_EQ(run.load_case, emadiag::sim::LoadCase::AExt);
    EXPECT_EQ(run.meta_value("valid"), std::optional<std::string>("false"));
    EXPECT_THAT(run.meta_value("invalid_reason").value_or(""), HasSubstr("telemetry loss 5 % above 0.1 %"));
    EXPECT_EQ(run.meta_value("status"), std::optional<std::string>("complete"));
}

TEST(SessionDecoder, LossAtTheLimitIsStillValid) {
    can_tool::SessionDecoder d;
    feed_preamble(d, 1);
    constexpr std::uint16_t kSamples = 1000;  // 2000 frames: 2 lost = 0.1 % exactly
    for (std::uint16_t k = 0; k < kSamples; ++k) {
        const auto c = static_cast<std::uint8_t>(k % 16);
        if (k != 100) d.feed(d.icd.encode_telemetry_a(k, c, 0, 0));
        if (k != 700) d.feed(d.icd.encode_telemetry_b(k, c, 0, 0));
    }
    feed_status(d, 1, kSamples, icd::SequenceState::Done);
    EXPECT_DOUBLE_EQ(d.stats().loss_fraction(), 0.001);
    const emadiag::Run run = d.build_run("test");
    EXPECT_EQ(run.meta_value("valid"), std::optional<std::string>("true"));
    EXPECT_EQ(run.samples.size(), 998u);
}
