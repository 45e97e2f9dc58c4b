// The Cranfield rig's real measurements (shared/data/cranfield-linear-actuator, runs 1-7 of each
// state) read through the shipped map actuators/cranfield-linear-actuator.map.json: every file
// imports, its groups are its cycles of 324 samples, position = set_point - position_error, the
// labels stay text, and motion detection on the set point finds the same cycles as the group column.
#include "emadiag/db/sha256.hpp"
#include "measured/column_map.hpp"
#include "measured/measured_import.hpp"
#include "src/measured/measured_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace emadiag::measured {
namespace {

constexpr std::size_t kSamplesPerGroup = 324;
constexpr double kKgf_n = 9.80665;
constexpr double kStrokeSpeed_m_s = 0.024;  // 120 mm in 5 s (the README)

std::string rig_map_path() { return std::string(EMADIAG_SOURCE_DIR) + "/actuators/cranfield-linear-actuator.map.json"; }

struct RigFile {
    const char* name;
    std::size_t groups;
    const char* fault_type;
};

constexpr RigFile kFiles[] = {
    {"normal", 105, "0"},    {"lackLubrication1", 105, "1"}, {"backlash1", 100, "1"}, {"spalling1", 105, "1"},
    {"spalling2", 105, "2"}, {"spalling3", 105, "3"},        {"spalling4", 105, "4"},
};

TEST(RigData, EveryStateImportsThroughTheShippedMap) {
    EMADIAG_REQUIRE_RIG_DATA();
    const ColumnMap map = load_column_map(rig_map_path());
    for (const RigFile& f : kFiles) {
        SCOPED_TRACE(f.name);
        const std::string path = test::rig_data_dir() + "/" + f.name + ".csv";
        const MeasuredRun run = import_measured_csv(path, map);
        EXPECT_TRUE(run.measured);
        EXPECT_EQ(run.source_sha256, db::sha256_file_hex(path));
        EXPECT_EQ(run.map_sha256, map.sha256);
        ASSERT_EQ(run.rows(), f.groups * kSamplesPerGroup);
        EXPECT_DOUBLE_EQ(run.nominal_period_s, 0.04);
        ASSERT_EQ(run.cycles.size(), f.groups);
        for (const Cycle& c : run.cycles) ASSERT_EQ(c.end - c.begin, kSamplesPerGroup) << c.key;
        EXPECT_EQ(run.rows_outside_cycles, 0U);
        // The absolute time: 25 Hz throughout (each group one period after the last).
        EXPECT_NEAR(run.time_s.back(), (run.rows() - 1) * 0.04, 1e-6);
        EXPECT_EQ(run.label("fault_type")->values, std::vector<std::string>{f.fault_type});
        EXPECT_EQ(run.label("profile")->values, std::vector<std::string>{"trap"});
        EXPECT_EQ(run.label("run")->values.size(), 7U);  // runs 1..7 (8..10 are held out)
        const auto& loads = run.signal("load_set_point")->values;
        std::set<double> distinct(loads.begin(), loads.end());
        EXPECT_EQ(distinct, (std::set<double>{-40 * kKgf_n, 20 * kKgf_n, 40 * kKgf_n}));
        const auto& sp = run.signal("position_set_point")->values;
        const auto& err = run.signal("position_error")->values;
        const auto& pos = run.signal("position")->values;
        for (std::size_t i = 0; i < run.rows(); i += 53) ASSERT_DOUBLE_EQ(pos[i], sp[i] - err[i]) << i;
        // The set point's speed in the middle of the first extension: 24 mm/s.
        EXPECT_NEAR(run.signal("set_point_speed")->values[run.cycles[0].begin + 50], kStrokeSpeed_m_s, 1e-9);
        EXPECT_NEAR(run.signal("speed")->noise_gain_per_s, 1.0 / (std::sqrt(2.0) * 0.04), 1e-9);
        // The measured speed follows the set point's: its mean over the extensions (set-point speed
        // 24 mm/s) within 5 % of it.
        double sum_m_s = 0;
        std::size_t n = 0;
        const auto& sp_speed = run.signal("set_point_speed")->values;
        const auto& speed = run.signal("speed")->values;
        for (std::size_t i = 0; i < run.rows(); ++i) {
            if (std::fabs(sp_speed[i] - kStrokeSpeed_m_s) < 1e-9) {
                sum_m_s += speed[i];
                ++n;
            }
        }
        ASSERT_GT(n, run.cycles.size() * 100);
        EXPECT_NEAR(sum_m_s / static_cast<double>(n), kStrokeSpeed_m_s, 0.05 * kStrokeSpeed_m_s);
    }
}

TEST(RigData, MotionFindsTheGroupsCycles) {
    EMADIAG_REQUIRE_RIG_DATA();
    const std::string path = test::rig_data_dir() + "/normal.csv";
    const MeasuredRun by_group = import_measured_csv(path, load_column_map(rig_map_path()));
    // The same file, the time from the rate and the cycles from the set point's motion (each begins
    // with an extension; the file holds no dwell at the retracted end, so a reversal starts it).
    const std::string map_text = R"({"schema": "emadiag-column-map/1", "name": "rig by motion",
      "columns": [{"column": "set_point", "signal": "position_set_point", "unit": "mm"},
                  {"column": "current", "signal": "current", "unit": "A"}],
      "unmapped_columns": "ignore",
      "time": {"source": "rate", "rate_hz": 25},
      "cycles": {"source": "motion", "signal": "position_set_point", "speed_threshold": 0.005, "min_rest_s": 1.0, "direction": "positive"}})";
    const MeasuredRun by_motion = import_measured_csv(path, parse_column_map(map_text, "motion.map.json"));
    ASSERT_EQ(by_motion.cycles.size(), by_group.cycles.size());
    for (std::size_t c = 0; c < by_group.cycles.size(); ++c) {
        ASSERT_EQ(by_motion.cycles[c].begin, by_group.cycles[c].begin) << "cycle " << c << " group " << by_group.cycles[c].key;
    }
    EXPECT_EQ(by_motion.rows_outside_cycles, 0U);
}

}  // namespace
}  // namespace emadiag::measured
