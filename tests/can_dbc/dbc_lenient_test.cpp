// Lenient by default, strict on request, as cantools (issue 25 part 2): what cantools' strict=False
// lets pass is a warning naming the file, line, column and what was skipped; DbcMode::Strict keeps
// today's refusals; a malformed file is refused in both modes with file:line:column.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

using namespace emadiag::can;
using ::testing::AllOf;
using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {

const std::string kHead =
    "VERSION \"\"\nBU_: ECU\nBO_ 100 Msg: 8 ECU\n SG_ Sig : 0|8@1+ (1,0) [0|255] \"\" ECU\n";

std::string strict_error(const std::string& text, const std::string& name = "t.dbc") {
    try {
        (void)parse_dbc(text, name, DbcMode::Strict);
    } catch (const CanError& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST(DbcLenient, DanglingReferencesAreSkippedWithAWarning) {
    // Line 5: a comment on a message that does not exist (opendbc volvo_v40_2017_pt.dbc:353 has one);
    // line 6: a value table of a signal that does not exist; line 8: an attribute of a missing message.
    const std::string text = kHead + "CM_ BO_ 999 \"gone\";\nVAL_ 100 Nope 0 \"off\" 1 \"on\";\n"
                                     "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 1000;\nBA_ \"GenMsgCycleTime\" BO_ 998 10;\n";
    const Database db = parse_dbc(text, "t.dbc");
    ASSERT_EQ(db.messages.size(), 1U);
    EXPECT_THAT(db.warnings, ElementsAre("t.dbc:5:9: unknown message id 999; statement skipped",
                                         "t.dbc:6:10: message 'Msg' has no signal 'Nope'; statement skipped",
                                         "t.dbc:8:27: unknown message id 998; statement skipped"));
    const std::string strict = strict_error(text);
    EXPECT_THAT(strict, AllOf(HasSubstr("3 problems"), HasSubstr("t.dbc:5:9: unknown message id 999"), HasSubstr("t.dbc:6:10: message 'Msg' has no signal 'Nope'")));
}

TEST(DbcLenient, CandbPlaceholderEmptyEnumDefaultAndOutOfRangeAttribute) {
    const std::string text = kHead +
                             "BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n"
                             " SG_ Loose : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n"
                             "CM_ SG_ 3221225472 Loose \"a signal in no message\";\n"
                             "BA_DEF_ BO_ \"VFrameFormat\" ENUM \"StandardCAN\",\"ExtendedCAN\",\"StandardCAN_FD\";\n"
                             "BA_DEF_DEF_ \"VFrameFormat\" \"\";\n"
                             "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 1000;\n"
                             "BA_ \"GenMsgCycleTime\" BO_ 100 5000;\n";
    const Database db = parse_dbc(text, "abs.dbc");
    ASSERT_EQ(db.messages.size(), 1U);
    EXPECT_THAT(db.warnings,
                ElementsAre("abs.dbc:7:9: message id 3221225472 is CANdb++'s placeholder VECTOR__INDEPENDENT_SIG_MSG (signals in no message); statement skipped",
                            "abs.dbc:9:28: attribute 'VFrameFormat': \"\" is not one of its ENUM values; value skipped",
                            "abs.dbc:11:31: attribute 'GenMsgCycleTime': value 5000 outside [0.000000, 1000.000000]; kept as written"));
    EXPECT_EQ(db.messages[0].cycle_time_ms(), 5000.0);
    EXPECT_FALSE(db.messages[0].is_fd);
    EXPECT_THAT(strict_error(text, "abs.dbc"), AllOf(HasSubstr("3 problems in abs.dbc"), HasSubstr("abs.dbc:7:9: message id 3221225472 is CANdb++'s placeholder"),
                                          HasSubstr("abs.dbc:9:28: attribute 'VFrameFormat': \"\" is not one of its ENUM values")));
}

TEST(DbcLenient, SignalBeyondItsMessageAndRepeatsAreSkippedNotDecodedOutOfBounds) {
    const std::string text = kHead + " SG_ Far : 60|8@1+ (1,0) [0|255] \"\" ECU\n SG_ Sig : 8|8@1+ (1,0) [0|255] \"\" ECU\nBO_ 100 Again: 8 ECU\n SG_ X : 0|8@1+ (1,0) [0|255] \"\" ECU\n";
    const Database db = parse_dbc(text, "t.dbc");
    ASSERT_EQ(db.messages.size(), 1U);
    EXPECT_EQ(db.messages[0].signals.size(), 1U);
    EXPECT_THAT(db.warnings, Contains(HasSubstr("t.dbc:5:12: signal 'Far' (start bit 60, length 8, little-endian) needs 9 bytes but the message has 8 ('Msg'); signal 'Far' skipped")));
    EXPECT_THAT(db.warnings, Contains("t.dbc:6:6: signal 'Sig' is defined twice in message 'Msg'; the second one skipped"));
    EXPECT_THAT(db.warnings, Contains("t.dbc:7:5: message 'Again': id 0x064 is already used by message 'Msg'; message 'Again' and its signals skipped"));
    EXPECT_EQ(db.find_message("Again"), nullptr);
}

TEST(DbcLenient, MalformedFilesAreRefusedInBothModesWithFileLineColumn) {
    // cantools' lenient mode refuses these too (corpus: toyota_radar_dsu_tssp, mazda_2017, chrysler_cusw).
    for (const auto mode : {DbcMode::Lenient, DbcMode::Strict}) {
        EXPECT_THAT([&] { (void)parse_dbc(kHead + "CM_ \"Front target\"\nBO_ 1 B: 8 ECU\n", "t.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("t.dbc:6:1: expected ';', found 'BO_'")));
        EXPECT_THAT([&] { (void)parse_dbc(kHead + "BO_ 1275 2017_5: 8 XXX\n", "t.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("t.dbc:5:10: expected message name")));
        EXPECT_THAT([&] { (void)parse_dbc(kHead + "BO_ 103596083 BSM_LEFT: 8 XXX\n", "t.dbc", mode); },
                    ThrowsMessage<CanError>(HasSubstr("t.dbc:5:5: message 'BSM_LEFT': id 103596083 is out of range")));
    }
}

TEST(DbcLenient, LongNamesReplaceTheNamesCutTo32Characters) {
    const std::string text =
        "BU_: ECU\nBO_ 2147483648 TSC1: 8 ECU\n"
        " SG_ Mode M : 0|2@1+ (1,0) [0|3] \"\" ECU\n"
        " SG_ Engine_Requested_Speed_Control_C m1 : 2|2@1+ (1,0) [0|3] \"\" ECU\n"
        " SG_ Engine_Requested_Torque_Torque_L : 8|8@1+ (1,0) [0|255] \"\" ECU\n"
        "BA_DEF_ SG_ \"SystemSignalLongSymbol\" STRING;\nBA_DEF_ SG_ \"SystemSignalLongName\" STRING;\nBA_DEF_ BO_ \"SystemMessageLongSymbol\" STRING;\n"
        "BA_ \"SystemSignalLongSymbol\" SG_ 2147483648 Engine_Requested_Speed_Control_C \"Engine Requested Speed Control Conditions\";\n"
        "BA_ \"SystemSignalLongName\" SG_ 2147483648 Engine_Requested_Torque_Torque_L \"Engine Requested Torque/Torque Limit\";\n"
        "BA_ \"SystemSignalLongSymbol\" SG_ 2147483648 Mode \"Override Control Mode\";\n"
        "BA_ \"SystemMessageLongSymbol\" BO_ 2147483648 \"Torque_Speed_Control_1\";\n"
        "VAL_ 2147483648 Engine_Requested_Speed_Control_C 0 \"off\";\n";
    const Database db = parse_dbc(text, "j1939.dbc");
    EXPECT_TRUE(db.warnings.empty()) << ::testing::PrintToString(db.warnings);
    const Message& m = db.message("Torque_Speed_Control_1");
    ASSERT_NE(m.find_signal("Engine Requested Speed Control Conditions"), nullptr);
    EXPECT_EQ(m.find_signal("Engine Requested Speed Control Conditions")->multiplexor, "Override Control Mode");
    EXPECT_EQ(m.find_signal("Engine Requested Speed Control Conditions")->value_table.size(), 1U);
    EXPECT_NE(m.find_signal("Engine Requested Torque/Torque Limit"), nullptr);
    const std::uint8_t data[8] = {0x01 | (2 << 2), 7, 0, 0, 0, 0, 0, 0};
    std::vector<DecodedSignal> out;
    ASSERT_TRUE(m.decode(data, 8, out));
    ASSERT_EQ(out.size(), 3U);
    EXPECT_EQ(out[1].signal->name, "Engine Requested Speed Control Conditions");
    EXPECT_EQ(out[1].value, 2.0);
}
