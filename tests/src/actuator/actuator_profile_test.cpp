// Actuator profiles (issue 23 part 1): the shipped profiles load with their values, hash and unknowns;
// every numeric field of them has a unit from its name; the finder resolves a file or a part number in
// a profile folder, and says what the folder holds when it does not.
#include "actuator/actuator_error.hpp"
#include "actuator/actuator_profile.hpp"
#include "actuator/profile_finder.hpp"
#include "emadiag/db/sha256.hpp"
#include "support/text_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

namespace emadiag::actuator {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ::testing::HasSubstr;

std::string shipped_path(const char* name) { return std::string(EMADIAG_SOURCE_DIR) + "/actuators/" + name; }

TEST(ActuatorProfile, TheRigIsAStepperOnALinearOutputWithItsUnknownsNull) {
    const ActuatorProfile p = load_actuator_profile(shipped_path("cranfield-linear-actuator.json"));
    EXPECT_EQ(p.part_number, "CRANFIELD-RM1605-NEMA34");
    EXPECT_EQ(p.sha256, db::sha256_hex(test::file_bytes(p.path)));
    EXPECT_EQ(p.drive.kind, DriveKind::stepper);
    EXPECT_FALSE(p.drive.k_t_nm_per_a.has_value());
    ASSERT_TRUE(p.drive.current_model.has_value());
    EXPECT_EQ(p.drive.current_model->form, "linear_load_speed/1");
    EXPECT_FALSE(p.drive.current_model->calibration.has_value());
    EXPECT_EQ(p.drive.holding_torque_nm, 4.6);
    EXPECT_EQ(p.transmission.output, OutputKind::linear);
    EXPECT_EQ(p.transmission.screw_lead_m, 0.005);
    EXPECT_EQ(p.transmission.stroke_m, 0.12);
    EXPECT_FALSE(p.transmission.gear_ratio.has_value());
    EXPECT_FALSE(p.transmission.efficiency_opposing.has_value());
    EXPECT_EQ(p.sensors.sample_rate_hz, 25.0);
    ASSERT_NE(p.sensors.find("position"), nullptr);
    ASSERT_NE(p.sensors.find("current"), nullptr);
    EXPECT_FALSE(p.sensors.find("current")->noise_sd.has_value());
    EXPECT_EQ(p.load.measured_by, LoadMeasuredBy::set_point);
    EXPECT_FALSE(p.load.positive.has_value());
    EXPECT_FALSE(p.operations.can_icd.has_value());
    ASSERT_EQ(p.operations.load_cases.size(), 3u);
    EXPECT_NEAR(p.operations.load_cases[2].parameters.at("load_n").get<double>(), -40 * 9.80665, 1e-9);  // -40 kgf
    const std::vector<std::string> unknown = unknown_fields(p);
    EXPECT_EQ(unknown.size(), 24u);
    EXPECT_THAT(unknown, ::testing::Contains("/transmission/friction/dynamic_nm"));
    EXPECT_THAT(unknown, ::testing::Contains("/drive/current_model/calibration"));
}

TEST(ActuatorProfile, ACalibratedCurrentModelLoadsWithItsCoefficientsPerDirection) {
    json doc = json::parse(test::file_bytes(shipped_path("cranfield-linear-actuator.json")));
    doc["drive"]["kind"] = "current_not_torque";
    doc["drive"]["current_model"]["calibration"] = {
        {"positive", {{"i0_a", 1.1}, {"load_opposing_a_per_n", 0.001}, {"load_aiding_a_per_n", -0.0005}, {"speed_a_s_per_m", 2.0}}},
        {"negative", {{"i0_a", 1.0}, {"load_opposing_a_per_n", 0.002}, {"load_aiding_a_per_n", -0.0004}, {"speed_a_s_per_m", 3.0}}},
        {"hold_current_a", 0.8},
        {"residual_sd_a", 0.02},
        {"samples", 3240},
        {"runs_sha256", {std::string(64, 'a')}},
        {"calibrated_utc", "2026-11-28T02:00:00Z"}};
    const ActuatorProfile p = parse_actuator_profile(doc.dump(), "calibrated.json");
    EXPECT_EQ(p.drive.kind, DriveKind::current_not_torque);
    ASSERT_TRUE(p.drive.current_model && p.drive.current_model->calibration);
    const CurrentCalibration& c = *p.drive.current_model->calibration;
    EXPECT_EQ(c.positive.i0_a, 1.1);
    EXPECT_EQ(c.negative.load_opposing_a_per_si, 0.002);
    EXPECT_EQ(c.negative.load_aiding_a_per_si, -0.0004);
    EXPECT_EQ(c.negative.speed_a_per_si, 3.0);
    EXPECT_EQ(c.hold_current_a, 0.8);
    EXPECT_EQ(c.samples, 3240u);
    EXPECT_EQ(c.runs_sha256, std::vector<std::string>{std::string(64, 'a')});
    doc["drive"]["current_model"]["calibration"]["runs_sha256"] = json::array();
    EXPECT_THAT([&] { (void)parse_actuator_profile(doc.dump(), "calibrated.json"); },
                ::testing::ThrowsMessage<ActuatorError>(HasSubstr("calibrated.json: /drive/current_model/calibration/runs_sha256: must name at least one healthy run")));
}

/// Every numeric leaf of `node` has a unit from its field name (or is dimensionless by name).
void expect_units(const json& node, const std::string& path, const std::string& key) {
    if (node.is_object()) {
        for (auto it = node.begin(); it != node.end(); ++it) expect_units(*it, path + "/" + it.key(), it.key());
    } else if (node.is_array()) {
        for (std::size_t i = 0; i < node.size(); ++i) expect_units(node[i], path + "/" + std::to_string(i), key);
    } else if (node.is_number()) {
        EXPECT_TRUE(unit_of_field(key).has_value()) << path << ": the field name '" << key << "' carries no unit the table knows";
    }
}

TEST(ActuatorProfile, EveryNumberOfTheShippedProfilesHasAUnitInItsName) {
    for (const char* f : {"ema-ref-1.json", "cranfield-linear-actuator.json"}) {
        const ActuatorProfile p = load_actuator_profile(shipped_path(f));
        expect_units(p.document, "", "");
    }
    EXPECT_EQ(unit_of_field("k_t_nm_per_a"), "N m/A");
    EXPECT_EQ(unit_of_field("rate_nm_per_s"), "N m/s");
    EXPECT_EQ(unit_of_field("position_gain_per_s"), "1/s");
    EXPECT_EQ(unit_of_field("speed_limit_rad_s"), "rad/s");
    EXPECT_EQ(unit_of_field("dwell_s"), "s");
    EXPECT_EQ(unit_of_field("gear_ratio"), "");
    EXPECT_EQ(unit_of_field("warp"), std::nullopt);
}

TEST(ActuatorProfile, ShowPrintsEveryValueWithItsUnitAndUnknownForNull) {
    const ActuatorProfile p = load_actuator_profile(shipped_path("ema-ref-1.json"));
    const std::vector<std::string> lines = describe_profile(p);
    EXPECT_THAT(lines, ::testing::Contains("/drive/k_t_nm_per_a = 0.2 N m/A"));
    EXPECT_THAT(lines, ::testing::Contains("/transmission/end_stops_deg = [-25,25] deg"));
    EXPECT_THAT(lines, ::testing::Contains("/transmission/screw_lead_m = unknown"));
    EXPECT_THAT(lines, ::testing::Contains("/sensors/signals/0/resolution = 0.002 A"));
    EXPECT_THAT(lines, ::testing::Contains("/operations/health_priors/1/max = 0.144 N m"));
    EXPECT_THAT(lines, ::testing::Contains("sha256 = " + p.sha256));
}

class ProfileFolder : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::path(EMADIAG_BINARY_DIR) / ("actuator_folder_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        fs::copy_file(shipped_path("ema-ref-1.json"), dir_ / "ref.json");
        fs::copy_file(shipped_path("cranfield-linear-actuator.json"), dir_ / "rig.json");
        fs::copy_file(shipped_path("cranfield-linear-actuator.map.json"), dir_ / "rig.map.json");  // a map, not a profile
    }
    std::vector<ProfileLocation> locations() const { return {{dir_ / "absent", "first"}, {dir_, "test"}}; }
    fs::path dir_;
};

TEST_F(ProfileFolder, APartNumberIsFoundByTheFilesContentInTheFirstFolderThatExists) {
    EXPECT_EQ(find_profile("EMA-REF-1", locations()).path, (dir_ / "ref.json").string());
    EXPECT_EQ(find_profile("CRANFIELD-RM1605-NEMA34", locations()).path, (dir_ / "rig.json").string());
    EXPECT_EQ(find_profile(shipped_path("ema-ref-1.json"), {}).part_number, "EMA-REF-1");  // a path, no folder needed
    EXPECT_TRUE(names_a_file("x.json"));
    EXPECT_TRUE(names_a_file("./EMA-REF-1"));
    EXPECT_FALSE(names_a_file("EMA-REF-1"));
    const auto listed = list_profiles(dir_);
    ASSERT_EQ(listed.size(), 2u);  // the map is not listed
    EXPECT_EQ(listed[0].file.filename(), "ref.json");
}

TEST_F(ProfileFolder, AnUnknownPartNumberNamesTheFolderAndWhatItHolds) {
    test::write_test_file("", "actuator_folder_AnUnknownPartNumberNamesTheFolderAndWhatItHolds/broken.json", "{\"schema\": 1}");
    EXPECT_THAT([&] { (void)find_profile("EMA-REF-2", locations()); },
                ::testing::ThrowsMessage<ActuatorError>("[actuator] no actuator profile with part number 'EMA-REF-2' in " + dir_.string() +
                                                        " (test); it holds: EMA-REF-1 (ref.json), CRANFIELD-RM1605-NEMA34 (rig.json); "
                                                        "not valid profiles: broken.json (emadiag actuator check FILE says why)"));
    const auto listed = list_profiles(dir_);
    ASSERT_EQ(listed.size(), 3u);
    EXPECT_FALSE(listed[0].profile.has_value());
    EXPECT_THAT(listed[0].error, HasSubstr("/schema: must be a string, not 1"));
}

TEST_F(ProfileFolder, APartNumberInTwoFilesIsAnError) {
    fs::copy_file(dir_ / "ref.json", dir_ / "ref-copy.json");
    EXPECT_THAT([&] { (void)find_profile("EMA-REF-1", locations()); },
                ::testing::ThrowsMessage<ActuatorError>("[actuator] part number 'EMA-REF-1' is in two profiles of " + dir_.string() +
                                                        ": ref-copy.json and ref.json"));
}

TEST_F(ProfileFolder, NoFolderIsAnErrorNamingWhereItLooked) {
    EXPECT_THAT([&] { (void)find_profile("EMA-REF-1", {{dir_ / "absent", "installed"}}); },
                ::testing::ThrowsMessage<ActuatorError>("[actuator] no actuator profile folder to look up part number 'EMA-REF-1' in (looked in: " +
                                                        (dir_ / "absent").string() + " (installed)); give the profile's file instead"));
}

}  // namespace
}  // namespace emadiag::actuator
