// Multiplexing that cannot be evaluated is refused at parse time, in both modes (issue 25 part 3): a
// signal multiplexed by itself, two signals multiplexing each other, a multiplexor not in the
// message. Before, such a file parsed and the first decode overflowed the stack in Message::is_active.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using namespace emadiag::can;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {
const std::string kMessage = "BU_: ECU\nBO_ 256 M: 8 ECU\n SG_ S1 : 0|8@1+ (1,0) [0|255] \"\" ECU\n SG_ S2 : 8|8@1+ (1,0) [0|255] \"\" ECU\n";
}

TEST(HostileDbcMultiplexing, ASignalMultiplexedByItselfIsRefused) {
    // The minimal file; also kept as tests/data/fuzz_regressions/dbc/self_multiplexed_signal.dbc.
    for (const auto mode : {DbcMode::Lenient, DbcMode::Strict})
        EXPECT_THAT([&] { (void)parse_dbc(kMessage + "SG_MUL_VAL_ 256 S1 S1 1-1;\n", "self.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("self.dbc:5:20: signal 'S1' of message 'M' is multiplexed by itself (multiplexing that cannot be evaluated)")));
}

TEST(HostileDbcMultiplexing, ACycleOfMultiplexorsIsRefused) {
    for (const auto mode : {DbcMode::Lenient, DbcMode::Strict})
        EXPECT_THAT([&] { (void)parse_dbc(kMessage + "SG_MUL_VAL_ 256 S1 S2 1-1;\nSG_MUL_VAL_ 256 S2 S1 0-3;\n", "cycle.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("its multiplexors form a cycle (S1 -> S2 -> S1), multiplexing that cannot be evaluated")));
    // Three in a cycle, mNM signals (extended multiplexing) as written by CANdb++.
    const std::string three = "BU_: ECU\nBO_ 256 M: 8 ECU\n SG_ A m1M : 0|8@1+ (1,0) [0|255] \"\" ECU\n SG_ B m1M : 8|8@1+ (1,0) [0|255] \"\" ECU\n"
                              " SG_ C m1M : 16|8@1+ (1,0) [0|255] \"\" ECU\nSG_MUL_VAL_ 256 A B 1-1;\nSG_MUL_VAL_ 256 B C 1-1;\nSG_MUL_VAL_ 256 C A 1-1;\n";
    EXPECT_THAT([&] { (void)parse_dbc(three, "three.dbc"); }, ThrowsMessage<CanError>(HasSubstr("(A -> B -> C -> A)")));
}

TEST(HostileDbcMultiplexing, AMultiplexorNotInTheMessageIsRefused) {
    for (const auto mode : {DbcMode::Lenient, DbcMode::Strict})
        EXPECT_THAT([&] { (void)parse_dbc(kMessage + "SG_MUL_VAL_ 256 S1 Elsewhere 1-1;\n", "missing.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("missing.dbc:5:20: message 'M' has no multiplexor switch 'Elsewhere'")));
}

TEST(HostileDbcMultiplexing, ALongChainStillDecodes) {
    // 1000 signals, each multiplexed by the one before: accepted (no cycle), and decoding walks the
    // chain without trouble.
    std::ostringstream t;
    t << "BU_: ECU\nBO_ 2147483649 Chain: 64 ECU\n SG_ S0 M : 0|1@1+ (1,0) [0|1] \"\" ECU\n";
    for (int i = 1; i < 500; ++i) t << " SG_ S" << i << " m1M : " << i << "|1@1+ (1,0) [0|1] \"\" ECU\n";
    for (int i = 1; i < 500; ++i) t << "SG_MUL_VAL_ 2147483649 S" << i << " S" << i - 1 << " 1-1;\n";
    const Database db = parse_dbc(t.str(), "chain.dbc");
    std::vector<std::uint8_t> data(64, 0xFF);
    std::vector<DecodedSignal> out;
    ASSERT_TRUE(db.messages.at(0).decode(data.data(), data.size(), out));
    EXPECT_EQ(out.size(), 500U);
}

TEST(HostileDbcMultiplexing, TheFuzzSeedIsRefused) {
    const std::string path = std::string(EMADIAG_SOURCE_DIR) + "/tests/data/fuzz_regressions/dbc/self_multiplexed_signal.dbc";
    EXPECT_THAT([&] { (void)parse_dbc_file(path); }, ThrowsMessage<CanError>(HasSubstr("is multiplexed by itself")));
}
