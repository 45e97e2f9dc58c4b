// The measured-run import (issue 23 part 2) on synthetic files: a 2 kHz run in the rig's layout, a
// layout other than the rig's (semicolons, decimal commas, other names and units, title lines) read
// through a map with no code change, the time from a rate, cycles by motion, and the derivative's
// accuracy and noise against its documented formulas.
#include "emadiag/db/sha256.hpp"
#include "measured/column_map.hpp"
#include "measured/differentiator.hpp"
#include "measured/measured_import.hpp"
#include "src/measured/measured_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace emadiag::measured {
namespace {

constexpr double kPi = std::numbers::pi;

std::string fmt(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

/// The rig's layout at 2 kHz: a sine position (amplitude mm, frequency Hz), two groups (cycles) of
/// `rows_per_group`, the time restarting per group.
std::string rig_layout_csv(std::size_t rows_per_group, double rate_hz, double amplitude_mm, double freq_hz) {
    std::string csv = "set_point,position_error,current,profile,load,run,fault_type,group,time\n";
    for (int g = 1; g <= 2; ++g) {
        for (std::size_t k = 0; k < rows_per_group; ++k) {
            const double t_abs = static_cast<double>((g - 1) * rows_per_group + k) / rate_hz;
            const double x_mm = amplitude_mm * std::sin(2 * kPi * freq_hz * t_abs);
            const double err_mm = 0.01 * std::cos(2 * kPi * freq_hz * t_abs);
            csv += fmt(x_mm + err_mm) + "," + fmt(err_mm) + "," + fmt(1.5 + 0.1 * g) + ",trap,40,3,0," + std::to_string(g) + "," +
                   fmt(static_cast<double>(k) / rate_hz) + "\n";
        }
    }
    return csv;
}

std::string rig_map_text(double rate_hz) {
    return R"({"schema": "emadiag-column-map/1", "name": "rig at )" + fmt(rate_hz) + R"( Hz",
      "columns": [{"column": "set_point", "signal": "position_set_point", "unit": "mm", "noise": 0},
                  {"column": "position_error", "signal": "position_error", "unit": "mm", "noise": 0.01},
                  {"column": "current", "signal": "current", "unit": "A"},
                  {"column": "profile", "label": "profile"},
                  {"column": "load", "signal": "load_set_point", "unit": "kgf"},
                  {"column": "run", "label": "run"},
                  {"column": "fault_type", "label": "fault_type"},
                  {"column": "group", "label": "group"}],
      "time": {"source": "column", "column": "time", "unit": "s", "restarts_per_cycle": true, "rate_hz": )" + fmt(rate_hz) + R"(},
      "cycles": {"source": "column", "column": "group"},
      "derived": [{"signal": "position", "op": "difference", "of": ["position_set_point", "position_error"]},
                  {"signal": "speed", "op": "derivative", "of": "position", "method": "central_difference"}]})";
}

TEST(MeasuredImport, TwoKilohertzRunInTheRigsLayout) {
    constexpr double kRateHz = 2000.0, kAmplitudeMm = 30.0, kFreqHz = 2.0;
    constexpr std::size_t kRows = 2000;
    const std::string csv = rig_layout_csv(kRows, kRateHz, kAmplitudeMm, kFreqHz);
    const std::string path = test::measured_file("rig2k.csv", csv);
    const std::string map_text = rig_map_text(kRateHz);
    const ColumnMap map = parse_column_map(map_text, "rig2k.map.json");
    const MeasuredRun run = import_measured_csv(path, map);

    EXPECT_TRUE(run.measured);
    EXPECT_EQ(run.source_path, path);
    EXPECT_EQ(run.source_sha256, db::sha256_hex(csv));
    EXPECT_EQ(run.map_sha256, db::sha256_hex(map_text));
    EXPECT_EQ(run.map_name, "rig at 2000 Hz");
    ASSERT_EQ(run.rows(), 2 * kRows);
    EXPECT_DOUBLE_EQ(run.nominal_period_s, 1.0 / kRateHz);
    // The time restarts in group 2: it is placed one period after group 1's last row.
    EXPECT_DOUBLE_EQ(run.time_s[kRows - 1], (kRows - 1) / kRateHz);
    EXPECT_NEAR(run.time_s[kRows], kRows / kRateHz, 1e-12);
    for (std::size_t i = 1; i < run.rows(); ++i) ASSERT_GT(run.time_s[i], run.time_s[i - 1]) << i;
    ASSERT_EQ(run.cycles.size(), 2U);
    EXPECT_EQ(run.cycles[0].key, "1");
    EXPECT_EQ(run.cycles[1].begin, kRows);
    EXPECT_EQ(run.cycles[1].end, 2 * kRows);
    EXPECT_EQ(run.cycles[1].first_line, kRows + 2);
    EXPECT_EQ(run.rows_outside_cycles, 0U);

    const MeasuredSignal* load = run.signal("load_set_point");
    ASSERT_NE(load, nullptr);
    EXPECT_EQ(load->quantity, Quantity::force);
    EXPECT_DOUBLE_EQ(load->values[0], 40 * 9.80665);
    const MeasuredSignal* current = run.signal("current");
    EXPECT_DOUBLE_EQ(current->values[kRows], 1.7);
    // position = set_point - position_error, in metres.
    const MeasuredSignal* position = run.signal("position");
    ASSERT_NE(position, nullptr);
    EXPECT_EQ(position->quantity, Quantity::length);
    EXPECT_NEAR(position->noise_si, 1e-5, 1e-18);  // hypot(0, 0.01 mm)
    for (std::size_t i = 0; i < run.rows(); i += 97) {
        EXPECT_NEAR(position->values[i], 1e-3 * kAmplitudeMm * std::sin(2 * kPi * kFreqHz * run.time_s[i]), 1e-12) << i;
    }
    // Central difference: error A w^3 h^2 / 6 inside, A w^2 h / 2 at a cycle's ends (one-sided).
    const MeasuredSignal* speed = run.signal("speed");
    ASSERT_NE(speed, nullptr);
    EXPECT_EQ(speed->quantity, Quantity::linear_speed);
    const double w = 2 * kPi * kFreqHz, h = 1.0 / kRateHz, a_m = 1e-3 * kAmplitudeMm;
    const double inside_tol = a_m * w * w * w * h * h / 6 * 1.01, end_tol = a_m * w * w * h / 2 * 1.01;
    for (std::size_t i = 0; i < run.rows(); ++i) {
        const bool edge = i == 0 || i == kRows - 1 || i == kRows || i == 2 * kRows - 1;
        ASSERT_NEAR(speed->values[i], a_m * w * std::cos(w * run.time_s[i]), edge ? end_tol : inside_tol) << i;
    }
    EXPECT_NEAR(speed->noise_gain_per_s, 1.0 / (std::sqrt(2.0) * h), 1e-9);
    EXPECT_NEAR(speed->noise_si, 1e-5 / (std::sqrt(2.0) * h), 1e-12);
    // Labels are text, never signals.
    EXPECT_EQ(run.signal("fault_type"), nullptr);
    const LabelColumn* group = run.label("group");
    ASSERT_NE(group, nullptr);
    EXPECT_EQ(group->values, (std::vector<std::string>{"1", "2"}));
    EXPECT_EQ(group->at(kRows), "2");
    EXPECT_EQ(run.label("profile")->values, std::vector<std::string>{"trap"});
}

TEST(MeasuredImport, AnotherLayoutReadsThroughItsMapAlone) {
    // Semicolons, decimal commas, two title lines, a comment, other names, units and signs.
    const std::string csv =
        "Prüfstand B, Lauf 7\n"
        "exported 2026-01-02\n"
        "Zeit [ms];Strom;Weg;Kraft;Zustand;Bemerkung\n"
        "# kalibriert\n"
        "0;1500;-10000;1,5;gut;a\n"
        "10;1600;-10500;1,5;gut;b\n"
        "\n"
        "20;1700;-11000;-2,25;\"verschlissen\";c\n";
    const std::string map_text = R"({"schema": "emadiag-column-map/1", "name": "bench B",
      "format": {"delimiter": ";", "decimal": ",", "skip_lines": 2, "header": true, "comment_prefix": "#"},
      "columns": [{"column": "Strom", "signal": "current", "unit": "mA"},
                  {"column": "Weg", "signal": "position", "unit": "um", "sign": -1, "scale": 2, "offset": 100},
                  {"column": "Kraft", "signal": "load", "unit": "kN"},
                  {"column": "Zustand", "label": "state"},
                  {"column": "Bemerkung", "ignore": true}],
      "time": {"source": "column", "column": "Zeit [ms]", "unit": "ms"}})";
    const MeasuredRun run = import_measured_csv(test::measured_file("bench_b.csv", csv), parse_column_map(map_text, "b.map.json"));
    ASSERT_EQ(run.rows(), 3U);
    EXPECT_EQ(run.comment_lines, 1U);
    EXPECT_EQ(run.blank_lines, 1U);
    EXPECT_DOUBLE_EQ(run.time_s[2], 0.02);
    EXPECT_DOUBLE_EQ(run.nominal_period_s, 0.01);  // no rate_hz: the first step
    EXPECT_DOUBLE_EQ(run.signal("current")->values[1], 1.6);
    // sign * (scale * raw + offset) in um: -(2 * -10500 + 100) um = 20.9 mm.
    EXPECT_DOUBLE_EQ(run.signal("position")->values[1], 1e-6 * 20900);
    EXPECT_DOUBLE_EQ(run.signal("load")->values[2], -2250.0);
    EXPECT_EQ(run.label("state")->values, (std::vector<std::string>{"gut", "verschlissen"}));
    EXPECT_TRUE(run.cycles.empty());
    EXPECT_EQ(run.rows_outside_cycles, 3U);
}

TEST(MeasuredImport, TimeFromARateAndCyclesByMotion) {
    // A trapezoid at 50 Hz in a file without a header: up 1 s, dwell 0.5 s, down 1 s, dwell 0.5 s; 4 cycles after 0.3 s at rest.
    constexpr double kRateHz = 50.0;
    std::string csv;
    std::vector<double> x;
    for (int k = 0; k < 15; ++k) x.push_back(0.0);
    for (int c = 0; c < 4; ++c) {
        for (int k = 1; k <= 50; ++k) x.push_back(k * 2.0);
        for (int k = 0; k < 25; ++k) x.push_back(100.0);
        for (int k = 49; k >= 0; --k) x.push_back(k * 2.0);
        for (int k = 0; k < 25; ++k) x.push_back(0.0);
    }
    for (double v : x) csv += fmt(v) + ",0.5\n";
    const std::string map_text = R"({"schema": "emadiag-column-map/1", "name": "trapezoid",
      "format": {"header": false},
      "columns": [{"index": 0, "signal": "position", "unit": "mm"}, {"index": 1, "signal": "current", "unit": "A"}],
      "time": {"source": "rate", "rate_hz": 50},
      "cycles": {"source": "motion", "signal": "position", "speed_threshold": 0.01, "min_rest_s": 0.2, "direction": "positive"},
      "derived": [{"signal": "speed", "op": "derivative", "of": "position", "method": "savitzky_golay", "half_window": 2}]})";
    const MeasuredRun run = import_measured_csv(test::measured_file("trapezoid.csv", csv), parse_column_map(map_text, "t.map.json"));
    ASSERT_EQ(run.rows(), x.size());
    EXPECT_DOUBLE_EQ(run.time_s[50], 50 / kRateHz);
    ASSERT_EQ(run.cycles.size(), 4U);
    for (std::size_t c = 0; c < 4; ++c) {
        EXPECT_EQ(run.cycles[c].key, "motion " + std::to_string(c + 1));
        // The first moving row: the central difference sees the first step one row early.
        EXPECT_EQ(run.cycles[c].begin, 14 + 150 * c) << c;
    }
    EXPECT_EQ(run.cycles[3].end, x.size());
    EXPECT_EQ(run.rows_outside_cycles, 14U);
    // Savitzky-Golay (m = 2) inside the ramp: exactly the slope, 2 mm per 20 ms.
    EXPECT_NEAR(run.signal("speed")->values[14 + 25], 0.1, 1e-12);
    EXPECT_NEAR(run.signal("speed")->noise_gain_per_s, 50.0 / std::sqrt(10.0), 1e-12);
    EXPECT_TRUE(std::isnan(run.signal("speed")->noise_si));  // the position's noise is not in the map
}

TEST(MeasuredImport, DerivativeNoiseMatchesItsFormula) {
    // White noise of sigma through each differentiator: the sample deviation within 3 % of the stated gain.
    constexpr std::uint64_t kSeed = 20260123;
    constexpr std::size_t kN = 200000;
    constexpr double kSigma = 1e-4, kH = 0.04;
    std::mt19937_64 rng(kSeed);
    std::normal_distribution<double> noise(0.0, kSigma);
    std::vector<double> t(kN), x(kN), v(kN);
    for (std::size_t i = 0; i < kN; ++i) {
        t[i] = static_cast<double>(i) * kH;
        x[i] = noise(rng);
    }
    for (const auto& [method, m] : {std::pair{Differentiator::central_difference, 1}, std::pair{Differentiator::savitzky_golay, 3}}) {
        differentiate(t, x, 0, kN, method, m, kH, v);
        double ss = 0;
        for (std::size_t i = 10; i + 10 < kN; ++i) ss += v[i] * v[i];
        const double sd = std::sqrt(ss / static_cast<double>(kN - 20));
        const double stated = kSigma * derivative_noise_gain_per_s(method, m, kH);
        EXPECT_NEAR(sd / stated, 1.0, 0.03) << "seed " << kSeed << " m " << m;
    }
    EXPECT_NEAR(derivative_noise_gain_per_s(Differentiator::central_difference, 1, kH), 1.0 / (std::sqrt(2.0) * kH), 1e-12);
}

TEST(MeasuredImport, NumbersReadBackExactly) {
    // Property: numbers written shortest-exact (%.17g), with blanks and '+' around them, read back to the bit.
    constexpr std::uint64_t kSeed = 424242;
    constexpr std::size_t kRows = 5000;
    std::mt19937_64 rng(kSeed);
    std::uniform_real_distribution<double> mantissa(-10.0, 10.0);
    std::uniform_int_distribution<int> exponent(-30, 30), pad(0, 2);
    std::vector<std::array<double, 3>> want(kRows);
    std::string csv = "a|b|c\n";
    for (std::size_t r = 0; r < kRows; ++r) {
        for (std::size_t c = 0; c < 3; ++c) {
            want[r][c] = mantissa(rng) * std::pow(10.0, exponent(rng));
            std::string cell = fmt(want[r][c]);
            if (want[r][c] > 0 && pad(rng) == 0) cell = "+" + cell;
            csv += std::string(static_cast<std::size_t>(pad(rng)), ' ') + cell + std::string(static_cast<std::size_t>(pad(rng)), '\t');
            csv += c < 2 ? "|" : "\n";
        }
    }
    const std::string map_text = R"({"schema": "emadiag-column-map/1", "name": "pipes", "format": {"delimiter": "|"},
      "columns": [{"column": "a", "signal": "a", "unit": "m"}, {"column": "b", "signal": "b", "unit": "A"}, {"column": "c", "signal": "c", "unit": "1"}],
      "time": {"source": "rate", "rate_hz": 1000}})";
    const MeasuredRun run = import_measured_csv(test::measured_file("pipes.csv", csv), parse_column_map(map_text, "pipes.map.json"));
    ASSERT_EQ(run.rows(), kRows) << "seed " << kSeed;
    for (std::size_t r = 0; r < kRows; ++r) {
        for (std::size_t c = 0; c < 3; ++c) ASSERT_EQ(run.signals[c].values[r], want[r][c]) << "seed " << kSeed << " row " << r << " column " << c;
    }
}

TEST(MeasuredImport, ShippedRigMapLoads) {
    const ColumnMap map = load_column_map(std::string(EMADIAG_SOURCE_DIR) + "/actuators/cranfield-linear-actuator.map.json");
    EXPECT_EQ(map.signals.size(), 4U);
    EXPECT_EQ(map.labels.size(), 4U);
    EXPECT_EQ(map.time.source, TimeSource::column);
    EXPECT_TRUE(map.time.restarts_per_cycle);
    EXPECT_EQ(map.cycles.source, CycleSource::column);
    EXPECT_EQ(map.derived.size(), 3U);
    EXPECT_EQ(map.sha256, db::sha256_hex(test::file_bytes(std::string(EMADIAG_SOURCE_DIR) + "/actuators/cranfield-linear-actuator.map.json")));
}

TEST(MeasuredUnits, KnownUnitsConvertToSi) {
    EXPECT_DOUBLE_EQ(find_unit("kgf")->factor, 9.80665);
    EXPECT_EQ(find_unit("kgf")->quantity, Quantity::force);
    EXPECT_DOUBLE_EQ(find_unit("deg")->factor, kPi / 180);
    EXPECT_DOUBLE_EQ(find_unit("degC")->offset, 273.15);
    EXPECT_EQ(find_unit("rpm")->quantity, Quantity::angular_speed);
    EXPECT_FALSE(find_unit("MA").has_value());
    EXPECT_EQ(si_unit(Quantity::linear_speed), "m/s");
}

}  // namespace
}  // namespace emadiag::measured
