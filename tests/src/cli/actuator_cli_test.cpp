// emadiag actuator list|show|check (issue 23 part 1), run as the real binary: the profiles of the
// build tree, of an installed layout (<prefix>/bin/emadiag reads <prefix>/share/emadiag/actuators,
// never ./actuators), and of EMADIAG_ACTUATORS_DIR.
#include "src/cli/actuator_cli_dir.hpp"
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using emadiag::test::run_cli;
using emadiag::test::run_shell;

const std::string kSource = EMADIAG_SOURCE_DIR;

class ActuatorCli : public emadiag::test::ActuatorCliDir {};

TEST_F(ActuatorCli, ListNamesTheBuildTreesProfiles) {
    const auto r = run_cli("actuator list");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("actuator profiles in " + kSource + "/actuators (build tree):\n"),
                                HasSubstr("\n  EMA-REF-1  current_controlled  rotary  ema-ref-1.json  Reference elevator"),
                                HasSubstr("\n  CRANFIELD-RM1605-NEMA34  stepper  linear  cranfield-linear-actuator.json  Cranfield"),
                                HasSubstr("\n2 profiles, 0 invalid; default EMA-REF-1\n")));
    EXPECT_THAT(r.output, Not(HasSubstr(".map.json")));
}

TEST_F(ActuatorCli, ShowPrintsEveryValueWithItsUnitEmaRef1ByDefault) {
    const auto r = run_cli("actuator show");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("file = " + kSource + "/actuators/ema-ref-1.json\n"), HasSubstr("\nsha256 = "),
                                HasSubstr("\n/drive/k_t_nm_per_a = 0.2 N m/A\n"), HasSubstr("\n/transmission/gear_ratio = 800\n"),
                                HasSubstr("\n/transmission/inertia_motor_side_kgm2 = 0.000165 kg m^2\n"),
                                HasSubstr("\n/sensors/sample_rate_hz = 2000 Hz\n"), HasSubstr("\n/transmission/screw_lead_m = unknown\n")));
    const auto rig = run_cli("actuator show CRANFIELD-RM1605-NEMA34");
    ASSERT_EQ(rig.exit_code, 0) << rig.output;
    EXPECT_THAT(rig.output, AllOf(HasSubstr("\n/transmission/screw_lead_m = 0.005 m\n"), HasSubstr("\n/transmission/stroke_m = 0.12 m\n"),
                                  HasSubstr("\n/drive/kind = stepper\n"), HasSubstr("\n/load/measured_by = set_point\n"),
                                  HasSubstr("\n/operations/can_icd = unknown\n")));
    const auto by_file = run_cli("actuator show " + kSource + "/actuators/cranfield-linear-actuator.json");
    EXPECT_EQ(by_file.output, rig.output);
}

TEST_F(ActuatorCli, CheckSaysOkAndListsTheUnknownValues) {
    const auto r = run_cli("actuator check " + kSource + "/actuators/ema-ref-1.json EMA-REF-1 CRANFIELD-RM1605-NEMA34");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("/actuators/ema-ref-1.json: ok: EMA-REF-1 (current_controlled drive, rotary output), sha256 "),
                                HasSubstr("; 4 values unknown (null): /operations/health_priors/3/max, /operations/health_priors/3/min, "
                                          "/sensors/signals/4/resolution, /transmission/screw_lead_m\n"),
                                HasSubstr("/actuators/cranfield-linear-actuator.json: ok: CRANFIELD-RM1605-NEMA34 (stepper drive, linear output)"),
                                HasSubstr("; 24 values unknown (null): /drive/current_limit_a, ")));
}

TEST_F(ActuatorCli, AnInstalledBinaryReadsItsPrefixNeverTheCurrentDirectory) {
    // <prefix>/bin/emadiag and <prefix>/share/emadiag/actuators, as cmake --install lays them out.
    const fs::path prefix = dir_ / "prefix";
    fs::create_directories(prefix / "bin");
    fs::create_directories(prefix / "share/emadiag/actuators");
    fs::copy_file(EMADIAG_CLI, prefix / "bin/emadiag");
    fs::copy_file(kSource + "/actuators/ema-ref-1.json", prefix / "share/emadiag/actuators/ema-ref-1.json");
    // A decoy where the technician stands: ./actuators with another profile.
    const fs::path cwd = dir_ / "cwd";
    fs::create_directories(cwd / "actuators");
    fs::copy_file(kSource + "/actuators/cranfield-linear-actuator.json", cwd / "actuators/rig.json");
    const std::string bin = (prefix / "bin/emadiag").string();
    const auto r = run_shell("cd '" + cwd.string() + "' && '" + bin + "' actuator list 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("actuator profiles in " + (prefix / "share/emadiag/actuators").string() + " (installed):\n"),
                                HasSubstr("  EMA-REF-1  "), HasSubstr("\n1 profile, 0 invalid; default EMA-REF-1\n"),
                                Not(HasSubstr("CRANFIELD"))));
    const auto show = run_shell("cd '" + cwd.string() + "' && '" + bin + "' actuator show CRANFIELD-RM1605-NEMA34 2>&1");
    EXPECT_EQ(show.exit_code, 1);
    EXPECT_THAT(show.output, HasSubstr("emadiag: error: [actuator] no actuator profile with part number 'CRANFIELD-RM1605-NEMA34' in " +
                                       (prefix / "share/emadiag/actuators").string() + " (installed); it holds: EMA-REF-1 (ema-ref-1.json) "));
}

TEST_F(ActuatorCli, TheEnvironmentVariableChoosesTheFolderAlone) {
    fs::copy_file(kSource + "/actuators/cranfield-linear-actuator.json", dir_ / "rig.json");
    const auto r = run_cli("actuator list", true);
    const auto env = run_shell("EMADIAG_ACTUATORS_DIR='" + dir_.string() + "' " + EMADIAG_CLI + " actuator list 2>&1");
    ASSERT_EQ(env.exit_code, 0) << env.output;
    EXPECT_THAT(env.output, AllOf(HasSubstr("actuator profiles in " + dir_.string() + " (EMADIAG_ACTUATORS_DIR):\n"),
                                  HasSubstr("  CRANFIELD-RM1605-NEMA34  "), Not(HasSubstr("EMA-REF-1  "))));
    const auto missing = run_shell("EMADIAG_ACTUATORS_DIR='" + (dir_ / "none").string() + "' " + EMADIAG_CLI + " actuator show 2>&1");
    EXPECT_EQ(missing.exit_code, 1);
    EXPECT_EQ(missing.output, "emadiag: error: [actuator] EMADIAG_ACTUATORS_DIR=" + (dir_ / "none").string() +
                                  ": no such folder (the profile folder given explicitly)\n");
}

}  // namespace
