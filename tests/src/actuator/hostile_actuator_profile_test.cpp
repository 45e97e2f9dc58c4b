// Hostile actuator profiles (issue 23 part 1): each bad file is refused with the exact message,
// naming the JSON path, the value and the allowed range; several problems are listed at once; the
// file itself (missing, a folder, too large) is refused before parsing. Each case edits the shipped
// EMA-REF-1 profile (or the rig's) in one place, so every other field stays valid.
#include "actuator/actuator_error.hpp"
#include "actuator/actuator_profile.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "support/text_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>

namespace emadiag::actuator {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;

json shipped(const char* name) {
    return json::parse(test::file_bytes(std::string(EMADIAG_SOURCE_DIR) + "/actuators/" + name));
}

/// The message of loading `doc` as "bad.json"; "" when it loads.
std::string refusal(const json& doc) {
    try {
        (void)parse_actuator_profile(doc.dump(), "bad.json");
    } catch (const ActuatorError& e) {
        return e.what();
    }
    return "";
}

std::string edited(const char* file, const std::function<void(json&)>& edit) {
    json doc = shipped(file);
    edit(doc);
    return refusal(doc);
}

std::string one_problem(const std::string& line) { return "[actuator] actuator profile bad.json: 1 problem\n  bad.json: " + line; }

TEST(HostileActuatorProfile, TheShippedProfilesLoad) {
    EXPECT_EQ(refusal(shipped("ema-ref-1.json")), "");
    EXPECT_EQ(refusal(shipped("cranfield-linear-actuator.json")), "");
}

TEST(HostileActuatorProfile, ANumberOutOfRangeNamesThePathTheValueAndTheRange) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["drive"]["k_t_nm_per_a"] = -0.2; }),
              one_problem("/drive/k_t_nm_per_a: must be > 0, not -0.2"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["efficiency_opposing"] = 1.2; }),
              one_problem("/transmission/efficiency_opposing: must be in (0, 1], not 1.2"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["friction"]["viscous_nm_s_per_rad"] = -1; }),
              one_problem("/transmission/friction/viscous_nm_s_per_rad: must be >= 0, not -1"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["sensors"]["sample_rate_hz"] = "2000"; }),
              one_problem("/sensors/sample_rate_hz: must be a finite number, not \"2000\""));
}

TEST(HostileActuatorProfile, UnknownIsNullAndOnlyWhereTheSchemaAllowsIt) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["drive"]["k_t_nm_per_a"] = nullptr; }),
              one_problem("/drive/k_t_nm_per_a: must be known (> 0), not null"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["drive"]["supply_v"] = nullptr; }), "");
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["drive"].erase("supply_v"); }),
              one_problem("/drive/supply_v: missing (every key is required: write null for a value that is unknown)"));
}

TEST(HostileActuatorProfile, UnknownKeysAreRefusedWithTheKnownOnes) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["warp"] = 1; }),
              one_problem("/warp: unknown key (known here: schema, identity, drive, transmission, sensors, load, operations)"));
    // A stepper has no torque constant: its current is not torque.
    EXPECT_EQ(edited("cranfield-linear-actuator.json", [](json& d) { d["drive"]["k_t_nm_per_a"] = 0.5; }),
              one_problem("/drive/k_t_nm_per_a: unknown key (known here: kind, supply_v, resistance_ohm, inductance_h, current_limit_a, "
                          "holding_torque_nm, speed_limit_rad_s, current_model)"));
}

TEST(HostileActuatorProfile, ChoicesListTheAllowedValues) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["drive"]["kind"] = "warp"; }),
              one_problem("/drive/kind: must be one of \"current_controlled\", \"stepper\", \"current_not_torque\", not \"warp\""));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["load"]["positive"] = "up"; }),
              one_problem("/load/positive: must be one of \"resists_positive_motion\", \"aids_positive_motion\", null (unknown), not \"up\""));
}

TEST(HostileActuatorProfile, SeveralProblemsAreListedAtOnce) {
    const std::string m = edited("ema-ref-1.json", [](json& d) {
        d["schema"] = "emadiag-actuator-profile/9";
        d["drive"]["current_limit_a"] = 0;
        d["sensors"]["signals"][0]["unit"] = "amps";
    });
    EXPECT_THAT(m, HasSubstr("[actuator] actuator profile bad.json: 3 problems\n"));
    EXPECT_THAT(m, HasSubstr("\n  bad.json: /schema: 'emadiag-actuator-profile/9' is not 'emadiag-actuator-profile/1'"));
    EXPECT_THAT(m, HasSubstr("\n  bad.json: /drive/current_limit_a: must be > 0, not 0"));
    EXPECT_THAT(m, HasSubstr("\n  bad.json: /sensors/signals/0/unit: unknown unit 'amps' (known units: time: s, ms"));
}

TEST(HostileActuatorProfile, Eq4IsChecked) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["efficiency_aiding"] = 0.9; }),
              one_problem("/transmission/efficiency_aiding: 0.9 is not eq. (4) of efficiency_opposing 0.85 and gear_ratio 800 "
                          "(0.823788319441542, tolerance kEq4Tolerance = 5e-7)"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["efficiency_opposing"] = nullptr; }),
              one_problem("/transmission/efficiency_aiding_from: \"eq4\" needs efficiency_opposing, efficiency_aiding and gear_ratio known"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) {
                  d["transmission"]["efficiency_opposing"] = nullptr;
                  d["transmission"]["efficiency_aiding_from"] = "given";
              }),
              "");
}

TEST(HostileActuatorProfile, CrossFieldRules) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["friction"]["static_nm"] = 0.05; }),
              one_problem("/transmission/friction/static_nm: static friction 0.05 N m must be >= the dynamic 0.08 N m"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["load"]["signal"] = "torque_cell"; }),
              one_problem("/load/signal: 'torque_cell' is not a signal of /sensors/signals"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["load"]["signal"] = "current"; }),
              one_problem("/load/signal: the sensor 'current' is in 'A', not a unit of torque"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["load"]["quantity"] = "force"; }),
              "[actuator] actuator profile bad.json: 2 problems\n  bad.json: /load/quantity: the load on a rotary output is a torque, not \"force\""
              "\n  bad.json: /load/signal: the sensor 'hinge_moment' is in 'N.m', not a unit of force");
    EXPECT_EQ(edited("cranfield-linear-actuator.json", [](json& d) { d["transmission"]["end_stops_m"] = {0.0, 0.1}; }),
              one_problem("/transmission/end_stops_m: the end stops [0.0,0.1] are closer than the stroke 0.12 m"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["transmission"]["end_stops_deg"] = {25, -25}; }),
              one_problem("/transmission/end_stops_deg: must be [low, high] with low < high, not [25,-25]"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["sensors"]["signals"][1]["signal"] = "current"; }),
              one_problem("/sensors/signals/1/signal: 'current' is listed twice"));
}

TEST(HostileActuatorProfile, OperationsAreChecked) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["health_priors"][0]["nominal"] = 0.2; }),
              one_problem("/operations/health_priors/0: the nominal 0.2 must be in [min, max] = [0.064, 0.096]"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["health_priors"][3]["min"] = 0.7; }),
              one_problem("/operations/health_priors/3/min: must be null: eq. (4) gives it from the eta_A prior, not 0.7"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["sequences"][1]["name"] = "DYN"; }),
              one_problem("/operations/sequences/1/name: 'DYN' is named twice"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["load_cases"][2]["input_matrix"] = {0, 0, 1}; }),
              one_problem("/operations/load_cases/2/input_matrix: must have one entry per state (4), not 3"));
    EXPECT_EQ(edited("cranfield-linear-actuator.json", [](json& d) { d["operations"]["sequences"][0]["stroke_deg"] = 10; }),
              one_problem("/operations/sequences/0/stroke_deg: unknown key (known here: name, kind, description, stroke_m, speed_m_s, dwell_s, cycles)"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["can_icd"]["dbc"] = "../../etc/passwd"; }),
              one_problem("/operations/can_icd/dbc: '../../etc/passwd' must be a path inside the data folder (relative, without '..')"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["operations"]["can_icd"]["messages"][1] = "EMA Status"; }),
              one_problem("/operations/can_icd/messages/1: must be a DBC message name (letters, digits, '_'), not \"EMA Status\""));
}

TEST(HostileActuatorProfile, TheCalibrationIsChecked) {
    const std::string m = edited("cranfield-linear-actuator.json", [](json& d) {
        d["drive"]["current_model"]["calibration"] = {
            {"positive", {{"i0_a", 1.1}, {"load_opposing_a_per_n", 0.001}, {"load_aiding_a_per_n", -0.0005}, {"speed_a_s_per_m", 2.0}}},
            {"negative", {{"i0_a", 1.0}, {"load_opposing_a_per_nm", 0.001}, {"load_aiding_a_per_n", -0.0005}, {"speed_a_s_per_m", 2.0}}},
            {"hold_current_a", 0.8},
            {"residual_sd_a", 0.02},
            {"samples", 0},
            {"runs_sha256", {"ABC"}},
            {"calibrated_utc", "2026-11-28T02:00:00Z"}};
    });
    EXPECT_THAT(m, HasSubstr("bad.json: 4 problems"));
    EXPECT_THAT(m, HasSubstr("/drive/current_model/calibration/negative/load_opposing_a_per_nm: unknown key (known here: i0_a, "
                             "load_opposing_a_per_n, load_aiding_a_per_n, speed_a_s_per_m)"));
    EXPECT_THAT(m, HasSubstr("/drive/current_model/calibration/negative/load_opposing_a_per_n: missing"));
    EXPECT_THAT(m, HasSubstr("/drive/current_model/calibration/samples: must be a whole number >= 1, not 0"));
    EXPECT_THAT(m, HasSubstr("/drive/current_model/calibration/runs_sha256/0: must be a SHA-256 in 64 lowercase hexadecimal digits, not \"ABC\""));
}

TEST(HostileActuatorProfile, NamesAndTextsAreBoundedAndPrintable) {
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["identity"]["part_number"] = "../EMA"; }),
              one_problem("/identity/part_number: '../EMA' must be a letter or digit, then letters, digits, '.', '_', '+' or '-'"));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["identity"]["name"] = "EMA\x1b[31m"; }),
              one_problem("/identity/name: must be 1 to 200 printable characters, not \"EMA\\u001b[31m\""));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) { d["identity"]["part_number"] = std::string(65, 'A'); }),
              one_problem("/identity/part_number: must be 1 to 64 printable characters, not \"" + std::string(65, 'A').substr(0, 79) + "\""));
    EXPECT_EQ(edited("ema-ref-1.json", [](json& d) {
                  json many = json::array();
                  for (int i = 0; i < 65; ++i) many.push_back({{"signal", "s" + std::to_string(i)}, {"unit", "A"}, {"resolution", nullptr}, {"noise_sd", nullptr}, {"source", nullptr}});
                  d["sensors"]["signals"] = many;
                  d["load"]["measured_by"] = "set_point";
                  d["load"]["signal"] = nullptr;
              }),
              one_problem("/sensors/signals: 65 entries exceed the limit kMaxProfileEntries = 64"));
}

TEST(HostileActuatorProfile, TextThatIsNotAProfile) {
    EXPECT_EQ(refusal(json::array()), one_problem("/: must be a JSON object"));
    try {
        (void)parse_actuator_profile(R"({"schema": "a", "schema": "b"})", "bad.json");
        FAIL() << "a repeated key was accepted";
    } catch (const ActuatorError& e) {
        EXPECT_THAT(e.what(), HasSubstr("[actuator] actuator profile bad.json: "));
        EXPECT_THAT(e.what(), HasSubstr("schema"));
    }
}

TEST(HostileActuatorProfile, TheFileIsCheckedBeforeItIsRead) {
    const std::string dir = std::string(EMADIAG_BINARY_DIR) + "/actuator_hostile_dir";
    std::filesystem::create_directories(dir);
    EXPECT_THAT([&] { (void)load_actuator_profile(dir); }, ::testing::ThrowsMessage<ActuatorError>(
                                                              "[actuator] actuator profile " + dir + ": not a regular file"));
    EXPECT_THAT([&] { (void)load_actuator_profile(dir + "/none.json"); },
                ::testing::ThrowsMessage<ActuatorError>("[actuator] actuator profile " + dir + "/none.json: no such file"));
    const std::string big = dir + "/big.json";
    { std::ofstream(big) << ' '; }
    std::filesystem::resize_file(big, io::kMaxJsonBytes + 1);  // sparse: cheap
    EXPECT_THAT([&] { (void)load_actuator_profile(big); },
                ::testing::ThrowsMessage<ActuatorError>("[actuator] actuator profile " + big + ": file exceeds the limit kMaxJsonBytes = 16777216 bytes"));
}

}  // namespace
}  // namespace emadiag::actuator
