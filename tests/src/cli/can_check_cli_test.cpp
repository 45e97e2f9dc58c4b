// emadiag can-check (what a DBC or a log holds and what was skipped) and --dbc FILE (the actuator's
// own ICD at run time, refused when it lacks what the tool needs), issue 25 parts 1, 2 and 4.
#include "support/cli_runner.hpp"

#include "support/text_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using emadiag::test::run_cli;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

namespace {

const std::string kEmaDbc = std::string(EMADIAG_SOURCE_DIR) + "/can_dbc/ema.dbc";
const std::string kSession = std::string(EMADIAG_SOURCE_DIR) + "/fuzz/corpus/candump/session_12.log";

std::string write(const std::string& name, const std::string& text) { return emadiag::test::write_test_file("can_check_cli_", name, text); }

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (auto at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
    return s;
}

}  // namespace

TEST(CanCheckCli, SaysWhatTheIcdHolds) {
    const auto r = run_cli("can-check " + kEmaDbc);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr(kEmaDbc + ": DBC, read leniently: 7 messages"), HasSubstr("0 warnings"),
                                HasSubstr("EMA ICD: complete (usable as --dbc"), HasSubstr("can-check: 1 read, 0 refused")));
}

TEST(CanCheckCli, WarningsOfLenientReadingAndStrictRefusal) {
    const std::string dbc = write("dangling.dbc", "VERSION \"\"\nBU_: ECU\nBO_ 100 Msg: 8 ECU\n SG_ Sig : 0|8@1+ (1,0) [0|255] \"\" ECU\n"
                                                  "CM_ BO_ 999 \"gone\";\nBA_DEF_ BO_ \"VFrameFormat\" ENUM \"StandardCAN\";\nBA_DEF_DEF_ \"VFrameFormat\" \"\";\n");
    auto r = run_cli("can-check " + dbc);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("1 messages"), HasSubstr("2 warnings"), HasSubstr("warning: " + dbc + ":5:9: unknown message id 999; statement skipped"),
                                HasSubstr("warning: " + dbc + ":7:28: attribute 'VFrameFormat': \"\" is not one of its ENUM values; value skipped"),
                                HasSubstr("EMA ICD: lacks 7 of the messages and signals the tool needs")));
    r = run_cli("can-check --strict " + dbc);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr(dbc + ": refused"), HasSubstr("2 problems in " + dbc), HasSubstr("can-check: 0 read, 1 refused")));
}

TEST(CanCheckCli, ALogWithATornLineAndConsoleOutput) {
    const std::string torn = write("torn.log", emadiag::test::file_bytes(kSession) + "(1700000000.050000) vcan0 100#0C002");
    const std::string console = write("console.log", "  can0  680   [8]  03 22 01 00 00 00 00 00\n");
    const auto r = run_cli("can-check " + torn + " " + console);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr(torn + ": candump log, 51 lines: 50 frames; skipped 1 torn or malformed line"),
                                HasSubstr("on vcan0; time 1700000000.000000 to 1700000000.049000; 50 frames of the EMA ICD"),
                                HasSubstr(torn + ":51:35: expected data as pairs of hex digits; line skipped"),
                                HasSubstr(console + ": refused"), HasSubstr("record the bus with `candump -l`"),
                                HasSubstr("can-check: 1 read, 1 refused")));
}

TEST(CanCheckCli, RunTimeDbcIsUsedAndOneLackingWhatTheToolNeedsIsRefused) {
    const std::string ema = emadiag::test::file_bytes(kEmaDbc);
    ASSERT_NE(ema.find("MotorCurrent"), std::string::npos);
    // The actuator's own DBC: the ICD plus a message of its own.
    const std::string own = write("own.dbc", ema + "\nBO_ 1536 SUPPLIER_Extra: 8 EMA\n SG_ Extra : 0|8@1+ (1,0) [0|255] \"\" TOOL\n");
    auto r = run_cli("--dbc " + own + " can-check " + kSession);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("50 frames of the EMA ICD"));
    r = run_cli("can-check " + kSession + " --dbc " + own);  // after the command name too
    EXPECT_EQ(r.exit_code, 0) << r.output;
    // A DBC without MotorCurrent and EMA_Ident: refused, naming both.
    std::string lacking = replace_all(ema, "MotorCurrent", "MotorCurrentX");
    lacking = replace_all(lacking, "EMA_Ident", "EMA_Identity");
    const std::string bad = write("lacking.dbc", lacking);
    r = run_cli("--dbc " + bad + " can-check " + kSession);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("emadiag: error: "), HasSubstr(bad + ": this DBC lacks 2 items of the EMA ICD the tool needs"),
                                HasSubstr("message EMA_Ident (standard id 0x"), HasSubstr("that id is message 'EMA_Identity'"),
                                HasSubstr("signal EMA_TelemetryA.MotorCurrent"), Not(HasSubstr("can-check:"))));
}
