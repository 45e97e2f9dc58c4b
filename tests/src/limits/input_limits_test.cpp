// The explicit limits of every reader (issue 12 part 2, docs/limits.md): past each, a clear error
// that names the limit, before memory or time grows with the input. The sizes that need gigabytes
// to show (10 million CSV rows, a 1 GB candump log, 10^6 DBC signals) are measured by
// bench/input_limits_bench.cpp; here each limit is crossed with the smallest input that does.
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "diagnosis/health_limits.hpp"
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/dbc.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "estimation/dataset.hpp"
#include "estimation/network_model.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace emadiag;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {

const std::string kCsvHead =
    "# k_t_Nm_per_A=0.2\n# J_kgm2=1.65e-4\n# tau=800\n# sample_period_s=0.0005\n# case=B\n# sequence=dyn\n"
    "t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg\n";

Run read_csv(const std::string& text) {
    std::istringstream in(text);
    return read_run_csv(in, "t.csv");
}

TEST(CsvLimits, LongLineIsRefusedWithoutStoringIt) {
    const std::string text = kCsvHead + "0.0005,1,2,3,4,5\n" + std::string(10 * kCsvMaxLineBytes, '9') + "\n";
    EXPECT_THAT([&] { (void)read_csv(text); },
                ThrowsMessage<EmadiagError>(HasSubstr("t.csv:9: line longer than the limit kCsvMaxLineBytes = 4096 bytes")));
}

TEST(CsvLimits, TooManyColumnsMetadataLinesAndBadRows) {
    std::string wide = "t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg";
    for (std::size_t c = 6; c <= kCsvMaxColumns; ++c) wide += ",x" + std::to_string(c);
    EXPECT_THAT([&] { (void)read_csv("# a=1\n" + wide + "\n"); },
                ThrowsMessage<EmadiagError>(HasSubstr("65 columns exceed the limit kCsvMaxColumns = 64")));
    std::string meta;
    for (std::size_t i = 0; i <= kCsvMaxMetaLines; ++i) meta += "# k" + std::to_string(i) + "=1\n";
    EXPECT_THAT([&] { (void)read_csv(meta); }, ThrowsMessage<EmadiagError>(HasSubstr("the limit kCsvMaxMetaLines = 1000")));
    // After kCsvMaxBadRows bad rows the reader stops (and reports at most 50 of them).
    std::string bad = kCsvHead;
    for (int i = 0; i < 5000; ++i) bad += "x,1,2,3,4,5\n";
    try {
        (void)read_csv(bad);
        FAIL();
    } catch (const EmadiagError& e) {
        EXPECT_LT(std::strlen(e.what()), 6000u);
    }
}

TEST(CsvLimits, NonFiniteCellsAndConstantsAreRefused) {
    for (const char* v : {"nan", "inf", "-inf", "1e999", "-nan", "infinity"}) {
        EXPECT_THAT([&] { (void)read_csv(kCsvHead + "0.0005,1," + v + ",3,4,5\n"); },
                    ThrowsMessage<EmadiagError>(HasSubstr("is not a finite number")))
            << v;
    }
    std::string head = kCsvHead;
    head.replace(head.find("0.0005"), 6, "inf");
    EXPECT_THAT([&] { (void)read_csv(head + "0.0005,1,2,3,4,5\n"); },
                ThrowsMessage<EmadiagError>(HasSubstr("sample_period_s=inf is not a positive number")));
    // Enormous but finite values are no measurement of this actuator (issue 21): refused with the
    // line, the column and the value (core/run_validity.hpp, kImpossibleMargin x the datasheet).
    EXPECT_THAT([&] { (void)read_csv(kCsvHead + "0.0005,1e308,-1e308,3,4,5\n"); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("column 'current_A': current_A = 1e+308 is physically impossible"),
                                                  HasSubstr("column 'speed_rad_s': speed_rad_s = -1e+308 is physically impossible"))));
}

TEST(CandumpLimits, LongLinesAndManyBadLines) {
    std::istringstream long_line("(1.000000) vcan0 100#" + std::string(1 << 20, '0') + "\n");
    EXPECT_THAT([&] { (void)can::read_candump(long_line, "l.log"); },
                ThrowsMessage<can::CanError>(HasSubstr("l.log:1:1: line longer than the limit kCandumpMaxLineBytes = 1024 bytes")));
    std::string many;
    for (int i = 0; i < 10000; ++i) many += "garbage\n";
    std::istringstream in(many);
    try {
        (void)can::read_candump(in, "m.log");
        FAIL();
    } catch (const can::CanError& e) {
        EXPECT_THAT(e.what(), HasSubstr("10000 bad lines in candump log m.log (the first 20 listed)"));
        EXPECT_LT(std::strlen(e.what()), 4000u);
    }
}

std::string dbc_message(int id, int signals) {
    std::string s = "BO_ " + std::to_string(id) + " M" + std::to_string(id) + ": 64 ECU\n";
    for (int k = 0; k < signals; ++k) s += " SG_ S" + std::to_string(k) + " : " + std::to_string(k % 512) + "|1@1+ (1,0) [0|1] \"\" ECU\n";
    return s;
}

TEST(DbcLimits, SignalsPerMessageAndFileSize) {
    const std::string text = "VERSION \"\"\nBU_: ECU\n" + dbc_message(1, static_cast<int>(can::kDbcMaxSignalsPerMessage) + 1);
    EXPECT_THAT([&] { (void)can::parse_dbc(text, "big.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("has more than the limit kDbcMaxSignalsPerMessage = 1024 signals; parsing stopped")));
    const std::string huge(can::kDbcMaxBytes + 1, ' ');
    EXPECT_THAT([&] { (void)can::parse_dbc(huge, "huge.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("exceed the limit kDbcMaxBytes")));
}

TEST(DbcLimits, ProblemsListedAreBoundedAndCounted) {
    std::string text;
    for (int i = 0; i < 5000; ++i) text += "BO_ 99999999999 X" + std::to_string(i) + ": 8 ECU\n";
    try {
        (void)can::parse_dbc(text, "bad.dbc");
        FAIL();
    } catch (const can::CanError& e) {
        EXPECT_THAT(e.what(), HasSubstr("5000 problems in bad.dbc (the first 100 listed)"));
    }
}

TEST(DbcFindings, OutOfRangeMultiplexerNumbersAreCleanErrors) {
    // Found by fuzz_dbc: std::stoull threw std::out_of_range / invalid_argument out of the parser.
    const std::string head = "BU_: ECU\nBO_ 1 M: 8 ECU\n SG_ Sw M : 0|8@1+ (1,0) [0|255] \"\" ECU\n";
    EXPECT_THAT([&] { (void)can::parse_dbc(head + " SG_ A m99999999999999999999 : 8|8@1+ (1,0) [0|1] \"\" ECU\n", "m.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("out of range")));
    EXPECT_THAT([&] { (void)can::parse_dbc(head + " SG_ A m1 : 8|8@1+ (1,0) [0|1] \"\" ECU\nSG_MUL_VAL_ 1 A Sw 1-.5;\n", "r.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("invalid multiplexor range end")));
}

TEST(DbcFindings, ValueDescriptionKeysMustBeWholeSigned64BitNumbers) {
    // Found by fuzz_dbc (session 8): VAL_ 1 A 4.44e25 "x" converted 4.44e25 to int64 (undefined
    // behaviour, UBSan); a key must be a whole number of a signed 64-bit raw value.
    const std::string head = "BU_: ECU\nBO_ 1 M: 8 ECU\n SG_ A : 0|8@1+ (1,0) [0|255] \"\" ECU\n";
    EXPECT_THAT([&] { (void)can::parse_dbc(head + "VAL_ 1 A 44444444444444444444444444 \"x\" ;\n", "v.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("not a whole number of a signed 64-bit raw value")));
    EXPECT_THAT([&] { (void)can::parse_dbc(head + "VAL_ 1 A 1.5 \"x\" ;\n", "v.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("invalid value '1.5'")));
    EXPECT_THAT([&] { (void)can::parse_dbc("VAL_TABLE_ T 1e300 \"x\" ;\n" + head, "t.dbc"); },
                ThrowsMessage<can::CanError>(HasSubstr("not a whole number")));
    const can::Database ok = can::parse_dbc(head + "VAL_ 1 A -9223372036854775808 \"min\" 0 \"off\" 1 \"on\" ;\n", "ok.dbc");
    ASSERT_EQ(ok.messages.size(), 1u);
    EXPECT_EQ(ok.messages.front().signals.front().value_table.size(), 3u);
}

std::string temp_file(const std::string& name, const std::string& text) {
    const fs::path p = fs::temp_directory_path() / ("emadiag-limits-" + std::to_string(::getpid()) + "-" + name);
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
}

TEST(JsonLimits, DepthAndSizeAreRefusedByEveryLoader) {
    const std::string deep = "{\"FDJ_Nm\":" + std::string(100000, '[') + std::string(100000, ']') + "}";
    const std::string path = temp_file("deep.json", deep);
    EXPECT_THAT([&] { (void)HealthLimits::load(path); },
                ThrowsMessage<EmadiagError>(HasSubstr("nests deeper than the limit kMaxJsonDepth = 64")));
    EXPECT_THAT([&] { (void)NetworkModel::load(path); }, ThrowsMessage<EmadiagError>(HasSubstr("kMaxJsonDepth")));
    EXPECT_THAT([&] { (void)sim::EmaParams::from_json_file(path); }, ThrowsMessage<sim::SimError>(HasSubstr("kMaxJsonDepth")));
    fs::remove(path);
    std::string error;
    EXPECT_TRUE(io::parse_bounded_json(std::string(64, '[') + std::string(64, ']'), error)) << error;
    EXPECT_FALSE(io::parse_bounded_json(std::string(65, '[') + std::string(65, ']'), error));
    EXPECT_TRUE(io::parse_bounded_json("[\"[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\\\"\"]", error)) << error;
    EXPECT_FALSE(io::parse_bounded_json(std::string(io::kMaxJsonBytes + 1, ' '), error));
    EXPECT_THAT(error, HasSubstr("kMaxJsonBytes"));
}

TEST(JsonLimits, NonFiniteNegativeAndEnormousLimitsAreRefused) {
    for (const char* v : {"1e999", "-1e999", "-0.05", "0", "1e308", "\"0.09\"", "null", "[]"}) {
        std::string error;
        const auto j = io::parse_bounded_json(std::string("{\"FDJ_Nm\": {\"max\": ") + v + "}}", error);
        if (!j) continue;  // a parse error is a clean refusal too
        // 1e308 is finite and positive, but no friction limit: the motor cannot exceed T_max (issue 21).
        EXPECT_THROW((void)HealthLimits::from_json(*j, "l.json"), EmadiagError) << v;
    }
}

TEST(DatasetLimits, AHeaderThatLiesAboutItsSizeIsRefusedBeforeAllocating) {
    auto file = [](std::uint64_t runs, std::uint64_t samples, std::size_t body_bytes) {
        const std::string header = "{\"version\":1,\"case\":\"B\",\"sequence\":\"dyn\",\"noise\":\"none\",\"seed\":1,\"count\":1,"
                                   "\"runs\":" + std::to_string(runs) + ",\"samples_per_run\":" + std::to_string(samples) +
                                   ",\"constants\":{\"k_t_Nm_per_A\":0.2,\"J_kgm2\":1e-4,\"tau\":800,\"sample_period_s\":0.0005},"
                                   "\"filter\":{\"simulated\":1,\"accepted\":1,\"non_finite\":0,\"limit_cycle\":0,\"non_physical\":0}}";
        std::string s = "EMADSET1";
        const std::uint64_t n = header.size();
        s.append(reinterpret_cast<const char*>(&n), 8);
        s += header;
        s += std::string(body_bytes, '\0');
        return s;
    };
    std::istringstream huge(file(1'000'000'000'000ULL, 1000, 0));
    EXPECT_THAT([&] { (void)read_dataset(huge, "h.dataset"); }, ThrowsMessage<EmadiagError>(HasSubstr("kMaxDatasetBytes")));
    std::istringstream lie(file(1000, 1000, 100));
    EXPECT_THAT([&] { (void)read_dataset(lie, "l.dataset"); },
                ThrowsMessage<EmadiagError>(HasSubstr("header announces 1000 runs of 1000 samples")));
    std::istringstream many_samples(file(1, 10'000'000, 0));
    EXPECT_THAT([&] { (void)read_dataset(many_samples, "s.dataset"); },
                ThrowsMessage<EmadiagError>(HasSubstr("kMaxDatasetSamplesPerRun")));
    // The size the header announces is accepted; the zeros it holds are then refused by the checks
    // of each run (issue 21 item 11: labels inside the datasheet's ranges, increasing time).
    std::istringstream exact(file(2, 3, 2 * (5 + 18) * 8));
    EXPECT_THAT([&] { (void)read_dataset(exact, "e.dataset"); },
                ThrowsMessage<EmadiagError>(HasSubstr("e.dataset: run 0: label FDJ_Nm = 0 is outside the datasheet's range")));
}

}  // namespace

namespace {

TEST(CandumpFindings, TimestampSecondsBeyondInt64NanosecondsAreACleanError) {
    // Found by fuzz_candump: sec * 10 overflowed (UBSan), and sec * 1e9 beyond 9.2e9 s as well.
    std::string error;
    EXPECT_FALSE(can::parse_candump_line("(4446666666666666666666.000000) vcan0 100#00", error));
    EXPECT_THAT(error, HasSubstr("timestamp seconds beyond 9000000000"));
    EXPECT_TRUE(can::parse_candump_line("(8999999999.999999) vcan0 100#00", error)) << error;
}

TEST(JsonFindings, NumberOverflowIsAParseErrorOfEveryLoader) {
    // Found by fuzz_limits_json and fuzz_dataset: nlohmann's out_of_range 406 escaped the loaders.
    std::string error;
    EXPECT_FALSE(io::parse_bounded_json("{\"FDJ_Nm\": {\"max\": 1e999}}", error));
    EXPECT_THAT(error, HasSubstr("number overflow"));
    const std::string path = temp_file("overflow.json", "{\"j_kgm2\": 0.0001651e406}");
    EXPECT_THAT([&] { (void)sim::EmaParams::from_json_file(path); }, ThrowsMessage<sim::SimError>(HasSubstr("number overflow")));
    EXPECT_THAT([&] { (void)HealthLimits::load(path); }, ThrowsMessage<EmadiagError>(HasSubstr("number overflow")));
    fs::remove(path);
}

}  // namespace
