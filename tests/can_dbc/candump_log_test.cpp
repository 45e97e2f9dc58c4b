#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_bus.hpp"
#include "emadiag/can/candump_log.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

using namespace emadiag::can;
using ::testing::HasSubstr;

namespace {
CandumpRecord parse_ok(const std::string& line) {
    std::string err;
    auto r = parse_candump_line(line, err);
    EXPECT_TRUE(r.has_value()) << line << ": " << err;
    return r.value_or(CandumpRecord{});
}
std::string parse_err(const std::string& line) {
    std::string err;
    auto r = parse_candump_line(line, err);
    EXPECT_FALSE(r.has_value()) << line;
    return err;
}
std::string temp_path(const std::string& name) { return std::string(EMADIAG_BINARY_DIR) + "/" + name; }
}  // namespace

TEST(CandumpLog, ParsesTheFormsCandumpWrites) {
    auto r = parse_ok("(1700000000.123456) vcan0 123#DEADBEEF");
    EXPECT_EQ(r.iface, "vcan0");
    EXPECT_EQ(r.frame.id, 0x123u);
    EXPECT_FALSE(r.frame.extended);
    EXPECT_EQ(r.frame.len, 4);
    EXPECT_EQ(r.frame.data[0], 0xDE);
    EXPECT_EQ(r.frame.timestamp.count(), 1700000000123456000LL);
    r = parse_ok("(0000000001.000001) can1 1ABCDEF0#00112233445566");
    EXPECT_TRUE(r.frame.extended);
    EXPECT_EQ(r.frame.id, 0x1ABCDEF0u);
    EXPECT_EQ(r.frame.len, 7);
    r = parse_ok("(1.5) vcan0 7FF##3" + std::string(128, 'A'));
    EXPECT_TRUE(r.frame.fd);
    EXPECT_TRUE(r.frame.brs);
    EXPECT_TRUE(r.frame.esi);
    EXPECT_EQ(r.frame.len, 64);
    r = parse_ok("(1.5) vcan0 010#");
    EXPECT_EQ(r.frame.len, 0);
    r = parse_ok("(1.5) vcan0 010#R");
    EXPECT_TRUE(r.frame.rtr);
    r = parse_ok("(1.5) vcan0 20000040#0000000000000000");
    EXPECT_TRUE(r.frame.error);
    EXPECT_EQ(r.frame.id, 0x40u);
    r = parse_ok("(1.5) vcan0 010#04 T");  // trailing direction flag of newer candump
    EXPECT_EQ(r.frame.len, 1);
}

TEST(CandumpLog, FormatParseRoundTrip) {
    CanFrame f;
    f.id = 0x101;
    f.len = 8;
    for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i * 17);
    f.timestamp = std::chrono::nanoseconds(1234567890123456000LL);
    EXPECT_EQ(format_candump_line(f, "vcan0"), "(1234567890.123456) vcan0 101#0011223344556677");
    CanFrame e = f;
    e.extended = true;
    e.id = 0x1234567;
    EXPECT_EQ(format_candump_line(e, "vcan0"), "(1234567890.123456) vcan0 01234567#0011223344556677");
    CanFrame d = f;
    d.fd = true;
    d.brs = true;
    d.len = 12;
    const std::string line = format_candump_line(d, "vcan0");
    EXPECT_EQ(line, "(1234567890.123456) vcan0 101##1001122334455667700000000");
    const auto back = parse_ok(line).frame;
    EXPECT_TRUE(back.fd);
    EXPECT_EQ(back.len, 12);
    EXPECT_EQ(back.data, d.data);
}

TEST(CandumpLog, BadLinesAreAllReportedWithLineAndColumn) {
    EXPECT_THAT(parse_err("1700000000.1 vcan0 123#00"), HasSubstr("1: expected '('"));
    EXPECT_THAT(parse_err("(17x) vcan0 123#00"), HasSubstr("4: expected the timestamp as sec.usec"));
    EXPECT_THAT(parse_err("(1.0) vcan0 12#00"), HasSubstr("13: id must have 3 (standard) or 8 (extended) hex digits, found 2"));
    EXPECT_THAT(parse_err("(1.0) vcan0 123#0"), HasSubstr("17: expected data as pairs of hex digits"));
    EXPECT_THAT(parse_err("(1.0) vcan0 123#001122334455667788"), HasSubstr("more than 8 data bytes"));
    EXPECT_THAT(parse_err("(1.0) vcan0 123##0" + std::string(18, '0')), HasSubstr("9 bytes is not a CAN FD length"));
    EXPECT_THAT(parse_err("(1.0) vcan0 800#00"), HasSubstr("11-bit id 800 above 7FF"));
    const std::string path = temp_path("bad_candump.log");
    {
        std::ofstream out(path);
        out << "(1.0) vcan0 123#00\n\n(1.1) vcan0 123#0\n(1.2) vcan0 XYZ\n";
    }
    EXPECT_THAT([&] { (void)read_candump_file(path); },
                ::testing::ThrowsMessage<CanError>(::testing::AllOf(HasSubstr("2 bad lines"), HasSubstr(path + ":3:17: expected data"),
                                                                    HasSubstr(path + ":4:13: expected hex id digits and '#'"))));
    std::remove(path.c_str());
}

TEST(CandumpBus, ReplaysInOrderThenEndOfLogAndCannotSend) {
    const std::string path = temp_path("replay_candump.log");
    {
        CandumpWriter w(path);
        for (std::uint32_t i = 0; i < 3; ++i) {
            CanFrame f;
            f.id = 0x100 + i;
            f.len = 1;
            f.data[0] = static_cast<std::uint8_t>(i);
            f.timestamp = std::chrono::seconds(10 + i);
            w.write(f, "vcan0");
        }
        w.flush();
    }
    auto bus = open_bus("candump:" + path);
    EXPECT_EQ(bus->spec(), "candump:" + path);
    EXPECT_EQ(bus->interface_name(), "vcan0");
    bus->set_filters({CanFilter{0x100, 0x7FE, false}});  // 0x100 and 0x101
    auto r = bus->receive(std::chrono::milliseconds(1));
    ASSERT_TRUE(r.has_frame());
    EXPECT_EQ(r.frame.id, 0x100u);
    EXPECT_EQ(r.frame.timestamp, std::chrono::seconds(10));
    r = bus->receive(std::chrono::milliseconds(1));
    EXPECT_EQ(r.frame.id, 0x101u);
    r = bus->receive(std::chrono::milliseconds(1));
    EXPECT_EQ(r.status, ReceiveStatus::EndOfLog);
    EXPECT_EQ(bus->send(CanFrame{}), SendStatus::ReadOnly);
    EXPECT_THAT([] { (void)open_bus("serial:/dev/ttyS0"); }, ::testing::ThrowsMessage<CanError>(HasSubstr("unknown kind 'serial'")));
    EXPECT_THAT([] { (void)open_bus("vcan0"); }, ::testing::ThrowsMessage<CanError>(HasSubstr("expected socketcan:IFACE or candump:FILE.log")));
    std::remove(path.c_str());
}
