// Golden and malformed-file tests of the DBC parser (can_dbc/src/dbc_parser.cpp).
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"
#include "emadiag/can/ema_icd.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>

using namespace emadiag::can;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

namespace {

const std::string kData = std::string(EMADIAG_SOURCE_DIR) + "/tests/data/can/";

double value_of(const std::vector<DecodedSignal>& v, const std::string& name) {
    for (const auto& d : v)
        if (d.signal->name == name) return d.value;
    ADD_FAILURE() << "signal " << name << " not decoded";
    return NAN;
}
bool decoded(const std::vector<DecodedSignal>& v, const std::string& name) {
    for (const auto& d : v)
        if (d.signal->name == name) return true;
    return false;
}

/// The refusal of `text` in strict mode (today's refusals; lenient mode is tested in dbc_lenient_test.cpp).
std::string parse_error(const std::string& text) {
    try {
        (void)parse_dbc(text, "t.dbc", DbcMode::Strict);
    } catch (const CanError& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST(DbcParser, MotohawkGoldenVector) {
    const Database db = parse_dbc_file(kData + "motohawk.dbc");
    const Message* m = db.find_message(496, false);
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->name, "ExampleMessage");
    EXPECT_EQ(m->length, 8u);
    EXPECT_EQ(m->comment, "Example message used as template in MotoHawk models.");
    const std::array<std::uint8_t, 8> frame{0x80, 0x4A, 0x0F, 0x00, 0x00, 0x00, 0x00, 0x00};
    std::vector<DecodedSignal> v;
    ASSERT_TRUE(m->decode(frame.data(), frame.size(), v));
    EXPECT_EQ(value_of(v, "Enable"), 1.0);
    EXPECT_EQ(value_of(v, "AverageRadius"), 0.0);
    EXPECT_NEAR(value_of(v, "Temperature"), 255.92, 1e-9);
    const Signal* t = m->find_signal("Temperature");
    EXPECT_EQ(t->byte_order, ByteOrder::BigEndian);
    EXPECT_TRUE(t->is_signed);
    EXPECT_EQ(t->unit, "degK");
    EXPECT_EQ(t->receivers, (std::vector<std::string>{"PCM1", "FOO"}));
    EXPECT_DOUBLE_EQ(t->minimum, 229.53);
    EXPECT_DOUBLE_EQ(t->maximum, 270.47);
    EXPECT_EQ(m->find_signal("Enable")->value_table.at(1), "Enabled");
    // And back: encoding the decoded values gives the same bytes (the low 5 bits of byte 2 belong
    // to no signal, so they encode as 0).
    const auto bytes = m->encode({{"Enable", 1}, {"AverageRadius", 0}, {"Temperature", 255.92}});
    EXPECT_EQ((std::vector<std::uint8_t>{0x80, 0x4A, 0x00, 0, 0, 0, 0, 0}), bytes);
}

TEST(DbcParser, FeaturesMultiplexExtendedFdAttributesComments) {
    const Database db = parse_dbc_file(kData + "features.dbc");
    const Message* ext = db.find_message(0x400, true);
    ASSERT_NE(ext, nullptr);
    EXPECT_TRUE(ext->extended);
    EXPECT_EQ(ext->comment, "A comment\nspanning three lines\nwith a \"quote\".");
    EXPECT_EQ(ext->cycle_time_ms(), std::optional<double>(100));  // BA_DEF_DEF_
    EXPECT_EQ(db.find_message(0x400, false)->name, "FdMsg");  // same number, standard id: another message
    EXPECT_EQ(db.message("Plain").cycle_time_ms(), std::optional<double>(10));
    EXPECT_EQ(db.message("Plain").find_signal("Flag")->attributes.at("GenSigStartValue").number, 1.0);
    EXPECT_EQ(db.network_attributes.at("DBName").text, "features");
    EXPECT_EQ(db.value_tables.at("OnOff").at(1), "On");
    EXPECT_EQ(db.node_comments.at("ECU1"), "node comment");

    // Simple multiplexing: Mux = 0 selects SigA, Mux = 1 selects SigB.
    std::vector<DecodedSignal> v;
    auto bytes = ext->encode({{"Mux", 0}, {"SigA", -20.5}, {"Always", 7}});
    ASSERT_TRUE(ext->decode(bytes.data(), bytes.size(), v));
    EXPECT_DOUBLE_EQ(value_of(v, "SigA"), -20.5);
    EXPECT_FALSE(decoded(v, "SigB"));
    EXPECT_FALSE(decoded(v, "SubMux"));
    EXPECT_EQ(value_of(v, "Always"), 7);
    bytes = ext->encode({{"Mux", 1}, {"SigB", 0xABC}});
    ASSERT_TRUE(ext->decode(bytes.data(), bytes.size(), v));
    EXPECT_EQ(value_of(v, "SigB"), 0xABC);
    EXPECT_FALSE(decoded(v, "SigA"));
    // Extended multiplexing (SG_MUL_VAL_): Deep is present when Mux = 2 and SubMux in 3-5 or 7.
    for (int sub = 0; sub < 16; ++sub) {
        bytes = ext->encode({{"Mux", 2}, {"SubMux", sub}});
        ASSERT_TRUE(ext->decode(bytes.data(), bytes.size(), v));
        EXPECT_EQ(decoded(v, "Deep"), (sub >= 3 && sub <= 5) || sub == 7) << "SubMux " << sub;
    }
    bytes = ext->encode({{"Mux", 0}});
    bytes[1] = 4;  // would be SubMux = 4, but Mux = 0 deselects SubMux itself
    ASSERT_TRUE(ext->decode(bytes.data(), bytes.size(), v));
    EXPECT_FALSE(decoded(v, "Deep"));
    EXPECT_THAT([&] { (void)ext->encode({{"Mux", 0}, {"SigB", 1}}); },
                ::testing::ThrowsMessage<CanError>(HasSubstr("multiplexed by 'Mux'")));

    // CAN FD: 64 bytes, floats (SIG_VALTYPE_ 1 and 2), a 64-bit integer, a BE signal in the last bytes.
    const Message& fd = db.message("FdMsg");
    EXPECT_EQ(fd.length, 64u);
    EXPECT_TRUE(fd.is_fd);
    EXPECT_EQ(fd.find_signal("Real")->value_type, ValueType::Float32);
    EXPECT_EQ(fd.find_signal("RealBE")->value_type, ValueType::Float64);
    bytes = fd.encode({{"First", 1}, {"Last", -2}, {"Wide", 18446744073709549568.0}, {"Real", -1.5f}, {"RealBE", 3.141592653589793}});
    ASSERT_TRUE(fd.decode(bytes.data(), bytes.size(), v));
    EXPECT_EQ(value_of(v, "Last"), -2);
    EXPECT_EQ(bytes[62], 0xFF);
    EXPECT_EQ(bytes[63], 0xFE);
    EXPECT_EQ(value_of(v, "Real"), -1.5);
    EXPECT_EQ(value_of(v, "RealBE"), 3.141592653589793);
    EXPECT_EQ(value_of(v, "Wide"), 18446744073709549568.0);
    EXPECT_EQ(bytes[20], 0x40);  // big-endian double: sign/exponent byte first
    std::string err;
    EXPECT_FALSE(fd.decode(bytes.data(), 8, v, &err));
    EXPECT_THAT(err, HasSubstr("needs 64 bytes, frame has 8"));
}

TEST(DbcParser, ReportsEveryProblemWithFileLineColumn) {
    const std::string path = kData + "malformed_many.dbc";
    std::string what;
    try {
        (void)parse_dbc_file(path, DbcMode::Strict);
    } catch (const CanError& e) {
        what = e.what();
    }
    const std::string f = path + ":";
    EXPECT_THAT(what, HasSubstr("[can_dbc] "));
    EXPECT_THAT(what, HasSubstr(f + "6:15: signal 'TooFar' (start bit 10, length 8, little-endian) needs 3 bytes but the message has 2"));
    EXPECT_THAT(what, HasSubstr(f + "7:15: signal 'Zero': length 0 bits"));
    EXPECT_THAT(what, HasSubstr(f + "9:5: message 'BadId': id 3000 is out of range"));
    EXPECT_THAT(what, HasSubstr(f + "10:14: expected byte order 0 (big-endian) or 1 (little-endian), found '2'"));
    EXPECT_THAT(what, HasSubstr(f + "12:17: message 'BadLen': length 9 bytes is not a CAN or CAN FD length"));
    EXPECT_THAT(what, HasSubstr(f + "16:6: signal 'S' is defined twice in message 'Dup'"));
    EXPECT_THAT(what, HasSubstr(f + "17:6: signal 'M1' is multiplexed but message 'Dup' has no multiplexor (M) signal"));
    EXPECT_THAT(what, HasSubstr(f + "19:5: message 'DupId': id 0x066 is already used by message 'Dup'"));
    EXPECT_THAT(what, HasSubstr(f + "21:9: unknown message id 999"));
    EXPECT_THAT(what, HasSubstr(f + "22:13: message 'Short' has no signal 'Nope'"));
    EXPECT_THAT(what, HasSubstr(f + "23:5: BA_ for undefined attribute 'Undefined'"));
    EXPECT_THAT(what, HasSubstr(f + "24:22: signal 'S' is 8 bits but SIG_VALTYPE_ 1 needs 32"));
    EXPECT_THAT(what, HasSubstr(f + "25:1: unknown keyword 'BOGUS_'"));
    EXPECT_THAT(what, HasSubstr(f + "26:5: unterminated string"));
    EXPECT_THAT(what, HasSubstr("27:1: expected BU_, BO_, SG_, EV_ or a comment string, found end of file"));
    EXPECT_THAT(what, HasSubstr("15 problems"));
    // Problems are listed in file order.
    EXPECT_LT(what.find(f + "6:15"), what.find(f + "17:6"));
    EXPECT_LT(what.find(f + "17:6"), what.find(f + "26:5"));
}

TEST(DbcParser, SingleMalformedStatements) {
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (0,0) [0|0] \"\" B\n"), HasSubstr("t.dbc:2:6: signal 'S': factor must not be zero"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] B\n"), HasSubstr("t.dbc:2:29: expected unit string, found 'B'"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S x : 0|8@1+ (1,0) [0|0] \"\" B\n"), HasSubstr("t.dbc:2:8: invalid multiplexer indicator 'x'"));
    EXPECT_THAT(parse_error(" SG_ S : 0|8@1+ (1,0) [0|0] \"\" B\n"), HasSubstr("t.dbc:1:2: SG_ 'S' outside a BO_ message"));
    EXPECT_THAT(parse_error("BA_DEF_ BO_ \"A\" WORD;\n"), HasSubstr("t.dbc:1:17: attribute 'A': unknown type 'WORD'"));
    EXPECT_THAT(parse_error("BA_DEF_ BO_ \"C\" INT 0 10;\nBO_ 1 M: 8 A\nBA_ \"C\" BO_ 1 11;\n"), HasSubstr("t.dbc:3:15: attribute 'C': value 11 outside [0"));
    EXPECT_THAT(parse_error("BA_DEF_ BO_ \"E\" ENUM \"a\",\"b\";\nBO_ 1 M: 8 A\nBA_ \"E\" BO_ 1 2;\n"), HasSubstr("t.dbc:3:15: attribute 'E': ENUM index 2 outside 0..1"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" B\nSIG_VALTYPE_ 1 S : 3;\n"), HasSubstr("t.dbc:3:20: SIG_VALTYPE_ 3 is not 0"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" B\nSG_MUL_VAL_ 1 S Nope 1-2;\n"), HasSubstr("t.dbc:3:17: message 'M' has no multiplexor switch 'Nope'"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" B\nVAL_ 1 S 0 \"a\" 0 \"b\";\n"), HasSubstr("t.dbc:3:16: signal 'S': value 0 described twice"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 60|8@0+ (1,0) [0|0] \"\" B\n"), HasSubstr("needs 9 bytes but the message has 8"));
    EXPECT_THAT(parse_error("BO_ 1 M: 8 A\n SG_ S : 0|65@1+ (1,0) [0|0] \"\" B\n"), HasSubstr("t.dbc:2:12: signal 'S': length 65 bits"));
    EXPECT_THAT(parse_error("VERSION \"\"\n$\n"), HasSubstr("t.dbc:2:1: unexpected character '$'"));
    EXPECT_EQ(parse_error("BO_ 2684354560 X: 8 A\n"), parse_error("BO_ 2684354560 X: 8 A\n"));
    EXPECT_THAT(parse_error("BO_ 2684354560 X: 8 A\n"), HasSubstr("id 2684354560 is out of range"));  // 0xA0000000
}

TEST(DbcParser, EmaIcdIsComplete) {
    const Database db = parse_dbc_file(std::string(EMADIAG_SOURCE_DIR) + "/can_dbc/ema.dbc");
    EXPECT_EQ(db.messages.size(), ema_database().messages.size());  // the compiled-in copy is the file
    EXPECT_EQ(ema_dbc_text().size() > 1000, true);
    EmaIcd icd(db);
    // Resolutions no coarser than issue 3 part 1 (their equality with the simulator's sensor
    // resolutions is checked in tests/sim_backend/node/icd_resolution_test.cpp).
    EXPECT_LE(icd.current_resolution_a(), 0.002);
    EXPECT_LE(icd.speed_resolution_rad_s(), 0.05);
    EXPECT_LE(icd.theta_resolution_rad(), 1e-3);
    EXPECT_LE(icd.hinge_resolution_nm(), 0.5);
    // Ranges of section 6 fit the raw ranges.
    auto covers = [](const Signal& s, double lo, double hi) {
        return s.raw_min() * s.factor + s.offset <= lo && s.raw_max() * s.factor + s.offset >= hi && s.minimum <= lo && s.maximum >= hi;
    };
    EXPECT_TRUE(covers(*icd.telemetry_a.find_signal("MotorCurrent"), -40, 40));
    EXPECT_TRUE(covers(*icd.telemetry_a.find_signal("MotorSpeed"), -1200, 1200));
    EXPECT_TRUE(covers(*icd.telemetry_b.find_signal("MotorAngle"), -400, 400));
    EXPECT_TRUE(covers(*icd.telemetry_b.find_signal("HingeMoment"), -5000, 5000));
    for (const auto& m : db.messages) {
        EXPECT_FALSE(m.comment.empty()) << m.name;
        EXPECT_TRUE(m.attributes.count("GenMsgCycleTime")) << m.name << " lacks GenMsgCycleTime";
        EXPECT_LE(m.length, 8u) << m.name;
        for (const auto& s : m.signals) {
            const bool is_enum = s.length <= 8 && s.factor == 1 && s.unit.empty() && s.name.find("Counter") == std::string::npos &&
                                 s.name.find("Crc") == std::string::npos && s.name.find("Firmware") == std::string::npos;
            if (is_enum) {
                EXPECT_FALSE(s.value_table.empty()) << m.name << "." << s.name << " is an enum without VAL_";
            }
        }
    }
    EXPECT_EQ(db.message("EMA_Status").cycle_time_ms(), std::optional<double>(20));
    EXPECT_EQ(db.message("TOOL_Heartbeat").cycle_time_ms(), std::optional<double>(20));
    EXPECT_EQ(db.message("EMA_TelemetryA").attributes.at("GenMsgCycleTimeUs").number, 500);
    EXPECT_EQ(db.message("EMA_Ident").find_signal("TorqueConstant")->value_type, ValueType::Float32);
    EXPECT_EQ(db.message("EMA_Ident").find_signal("Inertia")->value_type, ValueType::Float32);
    EXPECT_EQ(db.message("EMA_Ident").find_signal("GearRatio")->value_type, ValueType::Float32);
}
