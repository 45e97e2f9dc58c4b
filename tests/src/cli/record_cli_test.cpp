// The fleet record from the command line: history-sim per position with cycles, import of an
// in-flight run, report (text, json, csv, --out), fleet ranking, verify against a change made
// outside the tool, export (json, csv), and the errors: invalid or unknown tail, unknown position.
#include "support/cli_runner.hpp"
#include "support/db_test_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

#include <unistd.h>
#include <fstream>

namespace {

using emadiag::test::run_cli;
using ::testing::HasSubstr;
using ::testing::Not;

class RecordCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        // One folder per process: ctest runs each test in a process of its own, in parallel.
        dir_ = std::filesystem::path(EMADIAG_BINARY_DIR) / ("record_cli_test_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
        db_ = (dir_ / "fleet.db").string();
        // Two aircraft: N1EM's LH-ELEV wears fast (FDJ +0.012 N m per 100 days), N2EM's RH-AIL barely.
        for (const std::string args : {
                 "--tail N1EM --position LH-ELEV --serial SN-A --sessions 5 --days-between 20 --cycles 3000 --cycles-per-day 6 "
                 "--fdj-rate-per-100d 0.012 --technician 'A. Mechanic' --certificate B1-1 --operator EMA-AIR --seed 3",
                 "--tail N2EM --position RH-AIL --serial SN-B --sessions 4 --days-between 30 --cycles 800 --cycles-per-day 4 "
                 "--fdj-rate-per-100d 0.0005 --seed 4"}) {
            const auto r = run_cli("history-sim --db " + db_ + " " + args);
            ASSERT_EQ(r.exit_code, 0) << r.output;
        }
    }
    static std::filesystem::path dir_;
    static std::string db_;
};
std::filesystem::path RecordCli::dir_;
std::string RecordCli::db_;

TEST_F(RecordCli, ImportStoresAnInFlightRunWithEtaFromBothEstimators) {
    const std::string csv = (dir_ / "flight.csv").string();
    ASSERT_EQ(run_cli("simulate --case B --noise typical --seed 5 --out " + csv).exit_code, 0);
    auto r = run_cli("import " + csv + " --db " + db_ + " --tail N2EM --position RH-AIL --utc 2026-06-01T12:00:00Z --cycles 1400 --serial SN-B");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("eta_O physics:dyn 0.8"));
    EXPECT_THAT(r.output, HasSubstr("eta_A network:dyn 0.8"));
    r = run_cli("import " + csv + " --db " + db_ + " --tail N2EM --position CANARD --utc 2026-06-01T12:00:00Z");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("unknown position 'CANARD'"));
    r = run_cli("import " + csv + " --db " + db_ + " --tail N2EM --position RH-AIL");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("the run has no started_utc key; give --utc"));
}

TEST_F(RecordCli, ReportGivesPositionsAndSerialsInCyclesAndDays) {
    auto r = run_cli("report --db " + db_ + " --tail N1EM");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("POSITION LH-ELEV (ATA 27-30, left elevator): serial installed SN-A"));
    EXPECT_THAT(r.output, HasSubstr("SERIAL SN-A"));
    EXPECT_THAT(r.output, HasSubstr("A. Mechanic (B1-1)"));
    const std::string out = (dir_ / "n1.json").string();
    r = run_cli("report --db " + db_ + " --tail N1EM --format json --out " + out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::ifstream in(out);
    const auto j = nlohmann::json::parse(in);
    EXPECT_EQ(j["schema"], "emadiag-report");
    ASSERT_EQ(j["positions"].size(), 1u);
    const auto& fdj = j["positions"][0]["parameters"][0];
    EXPECT_EQ(fdj["parameter"], "FDJ_Nm");
    EXPECT_EQ(fdj["preferred_axis"], "cycles");
    ASSERT_EQ(fdj["axes"].size(), 2u);
    EXPECT_EQ(fdj["axes"][0]["axis"], "cycles");
    EXPECT_EQ(fdj["axes"][0]["points"].size(), 5u);
    EXPECT_GT(fdj["axes"][0]["trend_per_100"]["value"].get<double>(), 0.0) << "friction rises with cycles";
    // 0.012 N m per 100 days at 6 cycles a day is 0.002 N m per 100 cycles.
    EXPECT_NEAR(fdj["axes"][0]["trend_per_100"]["value"].get<double>(), 0.002, 0.001);
    r = run_cli("report --db " + db_ + " --tail N1EM --format csv");
    ASSERT_EQ(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("N1EM,position,LH-ELEV,FDJ_Nm,cycles,1,5,"));
    EXPECT_THAT(r.output, HasSubstr("N1EM,serial,SN-A,FDJ_Nm,days,0,5,"));
}

TEST_F(RecordCli, FleetRanksTheFasterWearingPositionFirst) {
    auto r = run_cli("fleet --db " + db_ + " --format json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    ASSERT_EQ(j["rows"].size(), 2u);
    EXPECT_EQ(j["rows"][0]["tail_number"], "N1EM");
    EXPECT_EQ(j["rows"][0]["driving_parameter"], "FDJ_Nm");
    EXPECT_EQ(j["rows"][0]["rank"], 1);
    r = run_cli("fleet --db " + db_);
    EXPECT_THAT(r.output, HasSubstr("1     N1EM      LH-ELEV   27-30   SN-A"));
}

TEST_F(RecordCli, VerifyDetectsAChangeMadeOutsideTheToolAndExportWritesTheWholeRecord) {
    const std::string copy = (dir_ / "tampered.db").string();
    std::filesystem::copy_file(db_, copy, std::filesystem::copy_options::overwrite_existing);
    auto r = run_cli("verify --db " + copy + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("5 sessions, hash chain intact"));
    {
        emadiag::test::RawConnection raw(copy);
        raw.exec("DROP TRIGGER test_sessions_no_update; UPDATE test_sessions SET technician_name = 'Someone Else' WHERE session_id = 2");
    }
    r = run_cli("verify --db " + copy + " --tail N1EM");
    EXPECT_EQ(r.exit_code, 5);
    EXPECT_THAT(r.output, HasSubstr("RECORD CHANGED OUTSIDE THE TOOL"));
    EXPECT_THAT(r.output, HasSubstr("session 2 ("));

    r = run_cli("export --db " + db_ + " --tail N1EM --format json --no-samples");
    ASSERT_EQ(r.exit_code, 0);
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j["schema"], "emadiag-record");
    EXPECT_EQ(j["sessions"].size(), 5u);
    EXPECT_EQ(j["sessions"][0]["technician_certificate"], "B1-1");
    EXPECT_EQ(j["sessions"][1]["prev_sha256"], j["sessions"][0]["content_sha256"]);
    EXPECT_TRUE(j["chain"]["intact"].get<bool>());
    const auto csv_dir = dir_ / "export";
    r = run_cli("export --db " + db_ + " --tail N1EM --format csv --out " + csv_dir.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"sessions.csv", "findings.csv", "runs.csv", "samples.csv", "installations.csv", "positions.csv"})
        EXPECT_TRUE(std::filesystem::exists(csv_dir / f)) << f;
}

TEST_F(RecordCli, InvalidOrUnknownTailIsAClearError) {
    for (const std::string cmd : {"report", "verify", "export"}) {
        auto r = run_cli(cmd + " --db " + db_ + " --tail 'n1 em'");
        EXPECT_EQ(r.exit_code, 1) << cmd;
        EXPECT_THAT(r.output, HasSubstr("tail number 'n1 em' is not valid")) << cmd;
        r = run_cli(cmd + " --db " + db_ + " --tail N9EM");
        EXPECT_EQ(r.exit_code, 1) << cmd;
        EXPECT_THAT(r.output, HasSubstr("\"N9EM\" is not in")) << cmd;
    }
    const auto r = run_cli("history-sim --db " + db_ + " --tail N1EM --position WINGLET --sessions 1");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("unknown position 'WINGLET'"));
}

}  // namespace
