// Bus logs keep what is good (issue 25 part 4) and the reader's fuzz findings (issue 21 item 17): a
// torn or malformed line is reported with its line number and reason and skipped, every good frame
// is kept; plain `candump can0` output is refused with the hint to record with -l; CAN XL lines and
// DROPCOUNT notices are skipped with a message, "_E" raw DLCs ignored; strict reading still refuses.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_log.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using namespace emadiag::can;
using ::testing::AllOf;
using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;
using ::testing::ThrowsMessage;

namespace {

struct Read {
    std::vector<CandumpRecord> records;
    CandumpReport report;
};

Read lenient(const std::string& text, const std::string& name = "s.log") {
    std::istringstream in(text);
    Read r;
    r.records = read_candump(in, name, CandumpMode::Lenient, &r.report);
    return r;
}

const std::string kGood = "(1700000000.000100) can0 100#0011223344556677\n(1700000000.000200) can0 101#8899AABBCCDDEEFF\n";

}  // namespace

TEST(HostileCandumpLines, TheFuzzFindingIsRefusedAsAnErrorFrameIdWithFlagBits) {
    // fuzz_candump (issue 21 item 17): E0022600 has CAN_ERR_FLAG and bits 30-31 (CAN_RTR_FLAG,
    // CAN_EFF_FLAG) set; it was read as an error frame of class C0022600 and written back as
    // 20022600, a different frame. The 12-digit fraction, '(' and '.' in the interface name and
    // '.'-separated data were never the problem and still read.
    const std::string finding = "(17000.002000018000) vca(17000.0a(17000.00200001n0 E0022600#70.02000000";
    std::string err;
    EXPECT_FALSE(parse_candump_line(finding, err));
    EXPECT_EQ(err, "52: error frame id E0022600 has bits above CAN_ERR_FLAG 20000000 and the 29-bit error class");
    const auto ok = parse_candump_line("(17000.002000018000) vca(17000.0a(17000.00200001n0 20022600#70.02000000", err);
    ASSERT_TRUE(ok) << err;
    EXPECT_TRUE(ok->frame.error);
    EXPECT_EQ(ok->frame.id, 0x22600U);
    EXPECT_EQ(ok->iface, "vca(17000.0a(17000.00200001n0");
    EXPECT_EQ(ok->frame.timestamp.count(), 17000002000018LL);
    EXPECT_EQ(ok->frame.len, 5);
    const auto back = parse_candump_line(format_candump_line(ok->frame, ok->iface), err);
    ASSERT_TRUE(back) << err;
    EXPECT_EQ(back->frame.id, ok->frame.id);
    EXPECT_EQ(back->iface, ok->iface);
    std::ifstream kept(std::string(EMADIAG_SOURCE_DIR) + "/tests/data/fuzz_regressions/candump/error_id_above_error_class.log");
    std::string line;
    ASSERT_TRUE(std::getline(kept, line));
    EXPECT_EQ(line, finding);
}

TEST(HostileCandumpLines, ATornLastLineIsSkippedAndReportedAndTheRestKept) {
    const Read r = lenient(kGood + "(1700000000.000300) can0 3C0#DEADB", "torn.log");
    EXPECT_EQ(r.records.size(), 2U);
    EXPECT_EQ(r.report.skipped_lines, 1U);
    EXPECT_TRUE(r.report.last_line_torn);
    EXPECT_THAT(r.report.messages, ElementsAre("torn.log:3:34: expected data as pairs of hex digits; line skipped",
                                               "torn.log:3: the last line is incomplete and has no final newline: the recording was cut short"));
    EXPECT_EQ(r.report.summary(), "2 frames; skipped 1 torn or malformed line");
    // Strict reading refuses the log, as before.
    std::istringstream in(kGood + "(1700000000.000300) can0 3C0#DEADB");
    EXPECT_THAT([&] { (void)read_candump(in, "torn.log"); }, ThrowsMessage<CanError>(HasSubstr("1 bad line in candump log torn.log:\ntorn.log:3:34: expected data")));
}

TEST(HostileCandumpLines, MalformedLinesAreCountedAndTheListIsCapped) {
    std::string text = kGood;
    for (int i = 0; i < 50; ++i) text += "(1700000000.000300) can0 1G0#0103\n";
    text += "(1700000000.000400) can0 100#00\n(1700000000.000500) can0 100#01\n";
    const Read r = lenient(text, "m.log");
    EXPECT_EQ(r.records.size(), 4U);
    EXPECT_EQ(r.report.skipped_lines, 50U);
    EXPECT_EQ(r.report.messages.size(), kCandumpMaxReportedErrors);
    EXPECT_EQ(r.report.messages_left_out, 50U - kCandumpMaxReportedErrors);
    EXPECT_EQ(r.report.messages.front(), "m.log:3:27: expected hex id digits and '#'; line skipped");
    EXPECT_FALSE(r.report.last_line_torn);
}

TEST(HostileCandumpLines, ALogWithNoGoodLineIsRefused) {
    EXPECT_THAT([] { (void)lenient("garbage\n(1.0) can0 XYZ\n", "g.log"); },
                ThrowsMessage<CanError>(AllOf(HasSubstr("2 bad lines in candump log g.log and no good frame:"), HasSubstr("g.log:1:1: expected '('"))));
}

TEST(HostileCandumpLines, PlainCandumpConsoleOutputIsRefusedWithTheHintToRecordWithL) {
    for (const std::string text : {"  can0  680   [8]  03 22 01 00 00 00 00 00\n  can0  690   [8]  03 22 01 00 00 00 00 00\n",
                                   " (1700000000.123456)  can0  123   [2]  11 22\n"}) {
        for (const auto mode : {CandumpMode::Lenient, CandumpMode::Strict}) {
            std::istringstream in(text);
            EXPECT_THAT([&] { (void)read_candump(in, "c.log", mode); },
                        ThrowsMessage<CanError>(AllOf(HasSubstr("c.log:1:1: this is the console output of plain `candump can0`"),
                                                      HasSubstr("record the bus with `candump -l`"))));
        }
    }
}

TEST(HostileCandumpLines, CanXlLinesDropcountNoticesAndRawDlcs) {
    const std::string text = kGood +
                             "(1700000000.000300) can0 00242#80:03:00000242#000102030405060708090A0B0C0D0E0F10111213\n"
                             "DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 3)\n"
                             "(1700000000.000400) can0 123#1122334455667788_E\n"
                             "(1700000000.000500) can0 123#R8_F\n";
    const Read r = lenient(text, "x.log");
    ASSERT_EQ(r.records.size(), 4U);
    EXPECT_EQ(r.records[2].raw_dlc, 0xE);
    EXPECT_EQ(r.records[2].frame.len, 8);
    EXPECT_TRUE(r.records[3].frame.rtr);
    EXPECT_EQ(r.records[3].raw_dlc, 0xF);
    EXPECT_EQ(r.report.can_xl_lines, 1U);
    EXPECT_EQ(r.report.dropcount_lines, 1U);
    EXPECT_EQ(r.report.frames_dropped_by_candump, 3U);
    EXPECT_EQ(r.report.skipped_lines, 0U);
    EXPECT_THAT(r.report.messages, Contains("x.log:3:1: CAN XL frame, not supported (CAN and CAN FD only); line skipped"));
    EXPECT_THAT(r.report.messages, Contains(StartsWith("x.log:4:1: candump's own notice \"DROPCOUNT: dropped 3")));
    EXPECT_EQ(r.report.summary(),
              "4 frames (1 remote); skipped 1 CAN XL line, 1 DROPCOUNT notice (candump lost 3 frames); ignored 2 raw DLC suffixes (\"_E\")");
    // A raw DLC only after 8 bytes of a classic frame.
    std::string err;
    EXPECT_FALSE(parse_candump_line("(1.0) can0 123#11223344_E", err));
    EXPECT_THAT(err, HasSubstr("a raw DLC suffix '_' follows exactly 8 data bytes of a classic frame"));
    EXPECT_FALSE(parse_candump_line("(1.0) can0 123#1122334455667788_8", err));
    EXPECT_THAT(err, HasSubstr("expected a raw DLC 9..F after '_'"));
}

TEST(HostileCandumpLines, ControlCharactersInANoteAreNotPrinted) {
    const Read r = lenient(kGood + "DROPCOUNT: dropped 1 CAN frame \x1b[31m\x07\n");
    ASSERT_EQ(r.report.dropcount_lines, 1U);
    for (const auto& m : r.report.messages)
        for (char c : m) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << m;
}
