// emadiag actuator with hostile profiles and arguments (issue 23 part 1), run as the real binary:
// check prints each problem of each file and exits 1; names with control characters are printed
// escaped; list marks an invalid profile of the folder; misuse of the arguments is refused.
#include "src/cli/actuator_cli_dir.hpp"
#include "support/cli_runner.hpp"

#include <nlohmann/json.hpp>

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
using nlohmann::json;

const std::string kSource = EMADIAG_SOURCE_DIR;

class HostileActuatorCli : public emadiag::test::ActuatorCliDir {
protected:
    /// The shipped EMA-REF-1 with `edit` applied, written to dir_/name.
    std::string write_edited(const std::string& name, void (*edit)(json&)) {
        std::ifstream in(kSource + "/actuators/ema-ref-1.json");
        json doc = json::parse(in);
        edit(doc);
        const std::string path = (dir_ / name).string();
        std::ofstream(path) << doc.dump(2);
        return path;
    }
};

TEST_F(HostileActuatorCli, CheckPrintsEveryProblemOfEachFileAndExitsOne) {
    const std::string bad = write_edited("bad.json", [](json& d) {
        d["drive"]["k_t_nm_per_a"] = -0.2;
        d["transmission"]["efficiency_opposing"] = 1.2;
        d["drive"]["warp_factor"] = 9;
    });
    const auto r = run_shell(std::string(EMADIAG_CLI) + " actuator check " + kSource + "/actuators/cranfield-linear-actuator.json '" + bad +
                             "' 2>/dev/null");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("/actuators/cranfield-linear-actuator.json: ok: CRANFIELD-RM1605-NEMA34"));
    // In reading order: the transmission first (the drive's and the load's units follow its output).
    EXPECT_THAT(r.output, HasSubstr("[actuator] actuator profile " + bad + ": 3 problems\n"
                                    "  " + bad + ": /transmission/efficiency_opposing: must be in (0, 1], not 1.2\n"
                                    "  " + bad + ": /drive/warp_factor: unknown key (known here: kind, supply_v, resistance_ohm, inductance_h, "
                                    "k_t_nm_per_a, current_limit_a, torque_limit_nm, speed_limit_rad_s, controller)\n"
                                    "  " + bad + ": /drive/k_t_nm_per_a: must be > 0, not -0.2\n"));
    const auto err = run_cli("actuator check '" + bad + "'");
    EXPECT_THAT(err.output, HasSubstr("emadiag: 1 of 1 profiles refused\n"));
}

TEST_F(HostileActuatorCli, ControlCharactersInANameArePrintedEscaped) {
    const std::string bad = write_edited("esc\x1b[31m.json", [](json& d) { d["identity"]["part_number"] = nullptr; });
    const auto r = run_cli("actuator check '" + bad + "'");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, Not(HasSubstr("\x1b")));
    EXPECT_THAT(r.output, HasSubstr("esc\\x1b[31m.json: /identity/part_number: must be a string, not null"));
}

TEST_F(HostileActuatorCli, ListMarksAnInvalidProfileAndShowRefusesIt) {
    fs::copy_file(kSource + "/actuators/ema-ref-1.json", dir_ / "ref.json");
    std::ofstream(dir_ / "broken.json") << "{\"schema\": ";
    const std::string env = "EMADIAG_ACTUATORS_DIR='" + dir_.string() + "' ";
    const auto list = run_shell(env + EMADIAG_CLI + " actuator list 2>&1");
    ASSERT_EQ(list.exit_code, 0) << list.output;
    EXPECT_THAT(list.output, AllOf(HasSubstr("\n  INVALID  broken.json  (emadiag actuator check " + (dir_ / "broken.json").string() + " says why)\n"),
                                   HasSubstr("\n  EMA-REF-1  "), HasSubstr("\n1 profile, 1 invalid; default EMA-REF-1\n")));
    const auto show = run_shell(env + EMADIAG_CLI + " actuator show NOPE 2>&1");
    EXPECT_EQ(show.exit_code, 1);
    EXPECT_EQ(show.output, "emadiag: error: [actuator] no actuator profile with part number 'NOPE' in " + dir_.string() +
                               " (EMADIAG_ACTUATORS_DIR); it holds: EMA-REF-1 (ref.json); not valid profiles: broken.json "
                               "(emadiag actuator check FILE says why)\n");
}

TEST_F(HostileActuatorCli, MisusedArgumentsAreRefused) {
    const auto two = run_cli("actuator show EMA-REF-1 EMA-REF-1");
    EXPECT_EQ(two.exit_code, 1);
    EXPECT_EQ(two.output, "emadiag: error: [actuator] actuator show takes one FILE or PART_NUMBER, not 2\n");
    const auto none = run_cli("actuator check");
    EXPECT_EQ(none.exit_code, 1);
    EXPECT_EQ(none.output, "emadiag: error: [actuator] actuator check needs at least one FILE or PART_NUMBER\n");
    const auto list = run_cli("actuator list EMA-REF-1");
    EXPECT_EQ(list.exit_code, 1);
    EXPECT_EQ(list.output, "emadiag: error: [actuator] actuator list takes no FILE or PART_NUMBER (use show or check)\n");
    const auto action = run_cli("actuator remove");
    EXPECT_NE(action.exit_code, 0);
    EXPECT_THAT(action.output, HasSubstr("remove not in {list,show,check}"));
    const auto dir = run_cli("actuator check " + dir_.string() + "/");
    EXPECT_EQ(dir.exit_code, 1);
    EXPECT_THAT(dir.output, HasSubstr("[actuator] actuator profile " + dir_.string() + "/: not a regular file\n"));
}

}  // namespace
