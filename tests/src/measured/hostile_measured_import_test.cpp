// Every refusal of the measured-run import (issue 23 part 2) with its exact message: the file, the
// line, the column and the value. A file with a problem gives no run.
#include "measured/column_map.hpp"
#include "measured/measured_error.hpp"
#include "measured/measured_import.hpp"
#include "src/measured/measured_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

namespace emadiag::measured {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

/// A 4 Hz layout whose times are exact in binary: t (s), x (mm), i (A), state (a label).
std::string small_map(const std::string& time_extra = "", const std::string& current_column = "i", const std::string& unit = "A") {
    return R"({"schema": "emadiag-column-map/1", "name": "small",
      "columns": [{"column": "x", "signal": "position", "unit": "mm"},
                  {"column": ")" + current_column + R"(", "signal": "current", "unit": ")" + unit + R"("},
                  {"column": "state", "label": "state"}],
      "time": {"source": "column", "column": "t", "unit": "s", "rate_hz": 4)" + time_extra + R"(}})";
}

/// The message of the MeasuredError thrown by importing `csv` (named `name`) through `map_text`.
std::string refusal(const std::string& name, const std::string& csv, const std::string& map_text = small_map()) {
    const ColumnMap map = parse_column_map(map_text, "small.map.json");
    const std::string path = test::measured_file(name, csv);
    try {
        (void)import_measured_csv(path, map);
    } catch (const MeasuredError& e) {
        return e.what();
    }
    return "(no error)";
}

std::string path_of(const std::string& name) { return std::string(EMADIAG_BINARY_DIR) + "/measured_test_" + name; }

TEST(HostileMeasuredImport, MissingColumnIsNamedWithTheHeader) {
    const std::string e = refusal("missing.csv", "t,x,i,state\n0,1,0.5,ok\n", small_map("", "current"));
    EXPECT_THAT(e, StartsWith("[measured] " + path_of("missing.csv") + ": 2 problems"));
    EXPECT_THAT(e, HasSubstr(path_of("missing.csv") + ":1: column 'current' (signal 'current') is not in the header (the header has: t, x, i, state)"));
    EXPECT_THAT(e, HasSubstr(path_of("missing.csv") +
                             ":1: column 'i' (index 2) is not in the map (map it, list it with \"ignore\": true, or set \"unmapped_columns\": \"ignore\")"));
}

TEST(HostileMeasuredImport, ColumnIndexBeyondTheFile) {
    const std::string map = R"({"schema": "emadiag-column-map/1", "name": "n", "format": {"header": false},
      "columns": [{"index": 1, "signal": "position", "unit": "mm"}, {"index": 7, "signal": "current", "unit": "A"}],
      "unmapped_columns": "ignore", "time": {"source": "rate", "rate_hz": 4}})";
    EXPECT_THAT(refusal("index.csv", "0,1\n0.25,2\n", map),
                HasSubstr(path_of("index.csv") + ":1: column index 7 (signal 'current') is beyond the 2 columns of the file"));
}

TEST(HostileMeasuredImport, NonMonotonicTime) {
    const std::string e = refusal("back.csv", "t,x,i,state\n0,1,0.5,ok\n0.25,1,0.5,ok\n0.125,1,0.5,ok\n");
    EXPECT_THAT(e, HasSubstr(path_of("back.csv") +
                             ":4: column 't' (index 0): '0.125' (0.125 s) is not after the previous time 0.25 s at line 3 (time must increase)"));
    EXPECT_THAT(refusal("same.csv", "t,x,i,state\n0,1,0.5,ok\n0,1,0.5,ok\n"),
                HasSubstr(":3: column 't' (index 0): '0' (0 s) is not after the previous time 0 s at line 2 (time must increase)"));
}

TEST(HostileMeasuredImport, GapAboveTheMapsFactor) {
    EXPECT_THAT(refusal("gap.csv", "t,x,i,state\n0,1,0.5,ok\n0.25,1,0.5,ok\n0.75,1,0.5,ok\n"),
                HasSubstr(path_of("gap.csv") + ":4: column 't' (index 0): '0.75' (0.75 s) is 0.5 s after the previous time 0.25 s at line 3: "
                                               "a gap (the limit is max_step_factor 1.5 x the nominal period 0.25 s = 0.375 s)"));
    // The factor is the map's: 2.5 admits the same step.
    const ColumnMap loose = parse_column_map(small_map(", \"max_step_factor\": 2.5"), "loose.map.json");
    const MeasuredRun run = import_measured_csv(test::measured_file("gap2.csv", "t,x,i,state\n0,1,0.5,ok\n0.25,1,0.5,ok\n0.75,1,0.5,ok\n"), loose);
    EXPECT_EQ(run.rows(), 3U);
}

TEST(HostileMeasuredImport, NanAndInfinityAreRefused) {
    const std::string e = refusal("nan.csv", "t,x,i,state\n0,nan,0.5,ok\n0.25,1,inf,ok\n0.5,-INF,0.5,ok\n0.75,1,1e999,ok\n");
    EXPECT_THAT(e, HasSubstr(path_of("nan.csv") + ":2: column 'x' (index 1): 'nan' is not finite (NaN and infinity are refused)"));
    EXPECT_THAT(e, HasSubstr(path_of("nan.csv") + ":3: column 'i' (index 2): 'inf' is not finite (NaN and infinity are refused)"));
    EXPECT_THAT(e, HasSubstr(path_of("nan.csv") + ":4: column 'x' (index 1): '-INF' is not finite (NaN and infinity are refused)"));
    EXPECT_THAT(e, HasSubstr(path_of("nan.csv") + ":5: column 'i' (index 2): '1e999' is out of the range of a double"));
    EXPECT_THAT(refusal("tnan.csv", "t,x,i,state\n0,1,0.5,ok\nnan,1,0.5,ok\n"),
                HasSubstr(":3: column 't' (index 0): 'nan' is not finite (NaN and infinity are refused)"));
}

TEST(HostileMeasuredImport, UnknownUnitNamesTheKnownOnes) {
    try {
        (void)parse_column_map(small_map("", "i", "amps"), "small.map.json");
        FAIL() << "no error";
    } catch (const MeasuredError& e) {
        EXPECT_THAT(e.what(), HasSubstr("[measured] column map small.map.json: 1 problem\n  small.map.json: /columns/1/unit: unknown unit 'amps' "
                                        "(known units: time: s, ms, us, min; length: m, mm, cm, um, in; angle: rad, deg, rev; current: A, mA; "
                                        "voltage: V, mV; force: N, kN, kgf, lbf;"));
    }
    try {
        (void)parse_column_map(R"({"schema": "emadiag-column-map/1", "name": "t", "columns": [{"column": "x", "signal": "x", "unit": "mm"}],
                                  "time": {"source": "column", "column": "t", "unit": "fortnight"}})",
                               "t.map.json");
        FAIL() << "no error";
    } catch (const MeasuredError& e) {
        EXPECT_THAT(e.what(), HasSubstr("t.map.json: /time/unit: unknown unit 'fortnight' (known units: time: s, ms"));
    }
}

TEST(HostileMeasuredImport, MalformedNumber) {
    const std::string e = refusal("bad.csv", "t,x,i,state\n0,1.2x,0.5,ok\n0.25,,0.5,ok\n0.5,1,0x10,ok\n");
    EXPECT_THAT(e, HasSubstr(path_of("bad.csv") + ":2: column 'x' (index 1): '1.2x' is not a number"));
    EXPECT_THAT(e, HasSubstr(path_of("bad.csv") + ":3: column 'x' (index 1): '' is not a number"));
    EXPECT_THAT(e, HasSubstr(path_of("bad.csv") + ":4: column 'i' (index 2): '0x10' is not a number"));
}

TEST(HostileMeasuredImport, RaggedRow) {
    const std::string e = refusal("ragged.csv", "t,x,i,state\n0,1,0.5,ok\n0.25,1,0.5\n0.5,1,0.5,ok,extra\n");
    EXPECT_THAT(e, HasSubstr(path_of("ragged.csv") + ":3: 3 fields where the header has 4 (a ragged row)"));
    EXPECT_THAT(e, HasSubstr(path_of("ragged.csv") + ":4: 5 fields where the header has 4 (a ragged row)"));
}

TEST(HostileMeasuredImport, EveryProblemIsCountedAndTheFirstAreListed) {
    std::string csv = "t,x,i,state\n";
    for (int k = 0; k < 30; ++k) csv += std::to_string(k * 0.25) + ",oops,0.5,ok\n";
    const std::string e = refusal("many.csv", csv);
    EXPECT_THAT(e, StartsWith("[measured] " + path_of("many.csv") + ": 30 problems (the first 20 listed)\n"));
}

TEST(HostileMeasuredImport, LongLineIsRefusedByTheLimit) {
    const std::string e = refusal("long.csv", "t,x,i,state\n0,1,0.5," + std::string(kMeasuredMaxLineBytes + 10, 'a') + "\n");
    EXPECT_THAT(e, HasSubstr(path_of("long.csv") + ":2: line longer than the limit kMeasuredMaxLineBytes = 4096 bytes"));
}

TEST(HostileMeasuredImport, CycleThatStartsAgainIsRefused) {
    const std::string map = R"({"schema": "emadiag-column-map/1", "name": "c",
      "columns": [{"column": "x", "signal": "position", "unit": "mm"}, {"column": "g", "label": "g"}],
      "time": {"source": "rate", "rate_hz": 4}, "cycles": {"source": "column", "column": "g"}})";
    EXPECT_THAT(refusal("cycles.csv", "x,g\n1,a\n2,a\n3,b\n4,a\n", map),
                HasSubstr(path_of("cycles.csv") + ":5: column 'g' (index 1): cycle 'a' starts again; it ended at line 3 (a cycle's rows must be contiguous)"));
}

TEST(HostileMeasuredImport, NoDataRows) {
    EXPECT_THAT(refusal("empty.csv", "t,x,i,state\n"), HasSubstr(path_of("empty.csv") + ": no data rows after the header at line 1"));
    EXPECT_THAT(refusal("nothing.csv", ""), HasSubstr(path_of("nothing.csv") + ": no header line after 0 lines"));
}

TEST(HostileMeasuredImport, MapProblemsAreAllListed) {
    try {
        (void)parse_column_map(R"({"schema": "emadiag-column-map/2", "name": "m", "colums": [],
          "columns": [{"column": "a", "signal": "Bad Name", "unit": "mm", "sign": 2},
                      {"column": "b", "signal": "x", "label": "y", "unit": "mm"}],
          "time": {"source": "column", "column": "t", "unit": "mm"},
          "derived": [{"signal": "v", "op": "derivative", "of": "nothing", "method": "magic"}]})",
                               "bad.map.json");
        FAIL() << "no error";
    } catch (const MeasuredError& e) {
        const std::string w = e.what();
        EXPECT_THAT(w, HasSubstr("bad.map.json: /colums: unknown key"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /schema: 'emadiag-column-map/2' is not 'emadiag-column-map/1'"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /columns/0/sign: must be 1 or -1, not 2"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /columns/0/signal: name 'Bad Name' must be a lowercase letter"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /columns/1: give exactly one of \"signal\", \"label\" and \"ignore\""));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /time/unit: 'mm' is not a unit of time"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /derived/0/of: 'nothing' is not a signal defined above it"));
        EXPECT_THAT(w, HasSubstr("bad.map.json: /derived/0/method: must be \"central_difference\" or \"savitzky_golay\", not 'magic'"));
    }
}

TEST(HostileMeasuredImport, RefusesADirectoryAFifoAndADeviceWithoutBlocking) {
    const ColumnMap map = parse_column_map(small_map(), "small.map.json");
    auto refused = [&](const std::string& path) {
        try {
            (void)import_measured_csv(path, map);
        } catch (const MeasuredError& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_EQ(refused(EMADIAG_BINARY_DIR), "[measured] " + std::string(EMADIAG_BINARY_DIR) + ": not a regular file");
    const std::string fifo = path_of("fifo.csv");
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    EXPECT_EQ(refused(fifo), "[measured] " + fifo + ": not a regular file");  // no writer: a blocking open would hang here
    ::unlink(fifo.c_str());
    EXPECT_EQ(refused("/dev/zero"), "[measured] /dev/zero: not a regular file");
    EXPECT_THAT(refused(path_of("absent.csv")), HasSubstr(path_of("absent.csv") + ": cannot open: No such file or directory"));
}

}  // namespace
}  // namespace emadiag::measured

namespace emadiag::measured {
namespace {

TEST(HostileMeasuredImportLimits, ValuesHeldAreBounded) {
    // One column and 255 derived sums: 257 values per row, so kMeasuredMaxValues / 257 rows at most.
    std::string map = R"({"schema": "emadiag-column-map/1", "name": "wide", "columns": [{"column": "x", "signal": "x", "unit": "m"}],
      "time": {"source": "rate", "rate_hz": 1000}, "derived": [)";
    for (int k = 0; k < 255; ++k) map += std::string(k ? "," : "") + R"({"signal": "s)" + std::to_string(k) + R"(", "op": "sum", "of": ["x", "x"]})";
    map += "]}";
    const std::size_t max_rows = kMeasuredMaxValues / 257;
    std::string csv = "x\n";
    csv.reserve(2 * max_rows + 8);
    for (std::size_t r = 0; r <= max_rows; ++r) csv += "1\n";
    const std::string e = refusal("values.csv", csv, map);
    EXPECT_THAT(e, HasSubstr(path_of("values.csv") + ":" + std::to_string(max_rows + 2) + ": more than " + std::to_string(max_rows) +
                             " rows: the limit kMeasuredMaxValues = 40000000 values held (257 per row)"));
    // The refusal is at row max_rows + 1 (line max_rows + 2 after the header): row max_rows itself was kept.
}

TEST(HostileMeasuredImportLimits, DistinctLabelTextsAreBounded) {
    const std::string map = R"({"schema": "emadiag-column-map/1", "name": "labels",
      "columns": [{"column": "x", "signal": "x", "unit": "m"}, {"column": "tag", "label": "tag"}],
      "time": {"source": "rate", "rate_hz": 1000}})";
    std::string csv = "x,tag\n";
    for (std::size_t r = 0; r <= kMeasuredMaxLabelValues; ++r) csv += "1,t" + std::to_string(r) + "\n";
    EXPECT_THAT(refusal("labels.csv", csv, map),
                HasSubstr(path_of("labels.csv") + ":65538: column 'tag' (index 1): 't65536' would be distinct text number 65537 of label 'tag': "
                                                  "the limit kMeasuredMaxLabelValues = 65536"));
}

TEST(HostileMeasuredImportLimits, DerivedOperandsOfTwoQuantitiesAreRefused) {
    const std::string map = R"({"schema": "emadiag-column-map/1", "name": "q",
      "columns": [{"column": "x", "signal": "x", "unit": "mm"}, {"column": "i", "signal": "i", "unit": "A"}],
      "time": {"source": "rate", "rate_hz": 4},
      "derived": [{"signal": "bad", "op": "difference", "of": ["x", "i"]}]})";
    EXPECT_THAT(refusal("quantities.csv", "x,i\n1,2\n", map),
                HasSubstr("[measured] column map small.map.json: derived 'bad': 'x' is a length and 'i' a current: a difference needs one quantity"));
    const std::string deriv = R"({"schema": "emadiag-column-map/1", "name": "q", "columns": [{"column": "i", "signal": "i", "unit": "A"}],
      "time": {"source": "rate", "rate_hz": 4}, "derived": [{"signal": "di", "op": "derivative", "of": "i", "method": "central_difference"}]})";
    EXPECT_THAT(refusal("deriv.csv", "i\n1\n2\n", deriv),
                HasSubstr("derived 'di': the derivative of a current ('i') is not supported (length, linear_speed, angle and angular_speed are)"));
}

TEST(HostileMeasuredImportLimits, ByteOrderMarkBeforeTheHeaderIsSkipped) {
    const ColumnMap map = parse_column_map(small_map(), "small.map.json");
    const MeasuredRun run = import_measured_csv(test::measured_file("bom.csv", "\xEF\xBB\xBFt,x,i,state\r\n0,1,0.5,ok\r\n0.25,2,0.5,ok\r\n"), map);
    ASSERT_EQ(run.rows(), 2U);
    EXPECT_DOUBLE_EQ(run.signal("position")->values[1], 0.002);
}

}  // namespace
}  // namespace emadiag::measured
