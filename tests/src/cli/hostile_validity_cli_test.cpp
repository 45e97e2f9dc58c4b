// Issue 21 items 2 and 3 through the binary: a truncated or invalid run gives NO_TEST (import) or a
// loud warning (estimate), never a verdict; nonsense metadata, impossible samples, network models,
// limits and duplicate JSON keys are refused with the field and value; `discover --db --tail` takes
// the runs of one actuator only and refuses a run of another.
#include "core/run_csv.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/sim/simulator.hpp"
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace emadiag;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using emadiag::test::run_cli;

namespace {

class HostileValidityCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag-validity-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }

    /// A simulated case-B DYN run CSV (complete and valid).
    std::string simulated_csv(const std::string& name) const {
        const auto r = run_cli("simulate --case B --sequence dyn --out " + p(name));
        EXPECT_EQ(r.exit_code, 0) << r.output;
        return p(name);
    }
    /// `text` with the lines starting with `prefix` replaced by `replacement` (or `replacement`
    /// inserted before the first line when no line starts with it).
    static std::string replaced(const std::string& text, const std::string& prefix, const std::string& replacement) {
        std::istringstream in(text);
        std::string out, l;
        bool found = false;
        while (std::getline(in, l)) {
            if (l.rfind(prefix, 0) == 0) {
                out += replacement + "\n";
                found = true;
            } else {
                out += l + "\n";
            }
        }
        return found ? out : replacement + "\n" + out;
    }
    static std::string slurp(const std::string& path) {
        std::ifstream in(path);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    void write(const std::string& path, const std::string& text) const { std::ofstream(path) << text; }
    std::string import(const std::string& run, const std::string& extra = "") const {
        return "import " + run + " --db " + p("m.db") + " --tail N21EM --position LH-ELEV --utc 2026-11-27T12:00:00Z " + extra;
    }
    /// The runs stored in m.db for N21EM, in order.
    std::vector<db::StoredRun> stored_runs() const {
        db::Database database(p("m.db"));
        std::vector<db::StoredRun> out;
        for (const auto& s : db::list_test_sessions(database, "N21EM"))
            for (const auto& r : s.runs) out.push_back(db::load_run(database, r.run_id));
        return out;
    }
    fs::path dir_;
};

/// A session's candump log as the recorder writes it (ident, START_SEQUENCE, status every 20
/// samples, both telemetry frames per sample, final status Done), from a direct noiseless
/// simulation of case B DYN: the same frames the EMA node sends.
std::string session_log() {
    const can::EmaIcd icd;
    sim::SimConfig c;
    c.load_case = sim::LoadCase::B;
    c.sequence = sim::Sequence::Dyn;
    const sim::SimResult sim_result = sim::simulate(c);
    std::string log;
    std::int64_t t_us = 1'700'000'000'000'000;
    const auto put = [&](can::CanFrame f) {
        f.timestamp = std::chrono::microseconds(t_us);
        log += can::format_candump_line(f, "vcan0") + "\n";
    };
    can::EmaIdentification id;
    id.serial_number = 4242;
    id.part_number = 1;
    id.k_t_nm_per_a = c.params.k_t_nm_per_a;
    id.j_kgm2 = c.params.j_kgm2;
    id.tau = c.params.tau;
    id.sample_period_s = sim::kSamplePeriodS;
    for (const auto& f : icd.encode_ident(id)) put(f);
    put(icd.encode_command({can::icd::Command::StartSequence, can::icd::TestSequence::Dyn, 21}));
    can::EmaStatus st;
    st.mode = can::icd::Mode::GroundTest;
    st.sequence = can::icd::TestSequence::Dyn;
    st.load_case = can::icd::LoadCase::B;
    st.session_id = 21;
    st.state = can::icd::SequenceState::Running;
    for (std::size_t k = 0; k < sim_result.samples.size(); ++k) {
        const sim::Sample& s = sim_result.samples[k];
        t_us += 500;
        const auto counter = static_cast<std::uint8_t>(k % 16);
        put(icd.encode_telemetry_a(static_cast<std::uint16_t>(k), counter, s.current_a, s.speed_rad_s));
        put(icd.encode_telemetry_b(static_cast<std::uint16_t>(k), counter, s.theta_m_rad, s.hinge_moment_nm));
        if ((k + 1) % 20 == 0) {
            st.samples_sent = static_cast<std::uint16_t>(k + 1);
            put(icd.encode_status(st));
        }
    }
    st.state = can::icd::SequenceState::Done;
    st.samples_sent = static_cast<std::uint16_t>(sim_result.samples.size());
    put(icd.encode_status(st));
    return log;
}

std::string first_lines(const std::string& text, std::size_t n) {
    std::size_t pos = 0;
    for (std::size_t i = 0; i < n && pos != std::string::npos; ++i) pos = text.find('\n', pos + (i == 0 ? 0 : 1));
    return pos == std::string::npos ? text : text.substr(0, pos + 1);
}

}  // namespace

// Item 2: the first 1,000 lines of a session's candump log.
TEST_F(HostileValidityCli, ATruncatedCandumpLogGivesNoVerdict) {
    const std::string full = session_log();
    write(p("full.log"), full);
    write(p("head.log"), first_lines(full, 1000));

    auto r = run_cli("estimate " + p("full.log"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, Not(HasSubstr("NOT VALID")));

    r = run_cli("estimate " + p("head.log"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("WARNING: RUN NOT VALID"), HasSubstr("sequence incomplete"), HasSubstr("of 1000 samples"),
                                HasSubstr("no verdict is possible")));
    r = run_cli("estimate --json " + p("head.log"), false);
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_FALSE(j.at("run").at("valid").get<bool>());
    EXPECT_THAT(j.at("run").at("invalid_reason").get<std::string>(), HasSubstr("sequence incomplete"));

    r = run_cli(import(p("head.log")));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("verdict NO_TEST"), HasSubstr("RUN NOT VALID"), HasSubstr("sequence incomplete")));
    EXPECT_THAT(r.output, Not(HasSubstr("SERVICEABLE")));
    r = run_cli(import(p("full.log")));
    EXPECT_THAT(r.output, HasSubstr("verdict SERVICEABLE"));
    const auto runs = stored_runs();
    ASSERT_EQ(runs.size(), 2u);
    EXPECT_FALSE(runs[0].valid);
    EXPECT_THAT(runs[0].status_note, HasSubstr("sequence incomplete"));
    EXPECT_GT(runs[0].samples.size(), 400u);  // the data is kept
    EXPECT_LT(runs[0].samples.size(), 1000u);
    EXPECT_EQ(runs[0].raw_log, first_lines(full, 1000));
    EXPECT_TRUE(runs[1].valid);
}

// Item 2: a run CSV whose metadata says it is invalid or incomplete, and one cut short.
TEST_F(HostileValidityCli, AnInvalidIncompleteOrTruncatedCsvGivesNoTest) {
    const std::string text = slurp(simulated_csv("run.csv"));
    write(p("invalid.csv"), replaced(text, "# valid=", "# valid=false"));
    write(p("incomplete.csv"), replaced(text, "# status=", "# status=incomplete"));
    write(p("head.csv"), first_lines(text, 500));
    for (const char* name : {"invalid.csv", "incomplete.csv", "head.csv"}) {
        const auto r = run_cli(import(p(name)));
        EXPECT_EQ(r.exit_code, 0) << r.output;
        EXPECT_THAT(r.output, AllOf(HasSubstr("verdict NO_TEST"), HasSubstr("RUN NOT VALID"))) << name;
        const auto e = run_cli("estimate " + p(name));
        EXPECT_THAT(e.output, HasSubstr("WARNING: RUN NOT VALID")) << name;
    }
    const auto runs = stored_runs();
    ASSERT_EQ(runs.size(), 3u);
    for (const auto& run : runs) EXPECT_FALSE(run.valid) << run.status_note;
    EXPECT_THAT(runs[0].status_note, HasSubstr("valid=false"));
    EXPECT_THAT(runs[1].status_note, HasSubstr("status=incomplete"));
    EXPECT_THAT(runs[2].status_note, HasSubstr("truncated"));
}

// Item 3: case=Z, sequence=zz, current_A=1e308.
TEST_F(HostileValidityCli, NonsenseMetadataAndImpossibleSamplesAreRefusedWithFileAndLine) {
    const std::string text = slurp(simulated_csv("run.csv"));
    write(p("case.csv"), replaced(text, "# case=", "# case=Z"));
    write(p("seq.csv"), replaced(text, "# sequence=", "# sequence=zz"));
    const emadiag::Run good = read_run_csv_file(p("run.csv"));
    const std::size_t header_line = good.meta.size() + 1;
    std::string spiked;
    {
        std::istringstream in(text);
        std::string l;
        for (std::size_t n = 1; std::getline(in, l); ++n) {
            if (n == header_line + 100) l = l.substr(0, l.find(',')) + ",1e308" + l.substr(l.find(',', l.find(',') + 1));
            spiked += l + "\n";
        }
    }
    write(p("spike.csv"), spiked);
    auto r = run_cli(import(p("case.csv")));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, AllOf(HasSubstr("case.csv:"), HasSubstr("case=Z is not one of A, A-ext, B")));
    r = run_cli("estimate " + p("seq.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, AllOf(HasSubstr("seq.csv:"), HasSubstr("sequence=zz is not one of dyn, brk, sweep")));
    r = run_cli(import(p("spike.csv")));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, AllOf(HasSubstr("spike.csv:" + std::to_string(header_line + 100) + ": column 'current_A'"),
                                HasSubstr("1e+308 is physically impossible")));
    r = run_cli("estimate " + p("spike.csv"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_FALSE(fs::exists(p("m.db")) && !stored_runs().empty());
}

// Item 3: network models that say nothing true.
TEST_F(HostileValidityCli, NonsenseNetworkModelsAreRefusedNamingTheField) {
    const std::string run = simulated_csv("run.csv");
    const auto model = nlohmann::json::parse(slurp(std::string(EMADIAG_SOURCE_DIR) + "/models/case_b.json"));
    auto r = run_cli("estimate " + run + " --model " + std::string(EMADIAG_SOURCE_DIR) + "/models/case_b.json");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const struct {
        const char* name;
        void (*edit)(nlohmann::json&);
        const char* message;
    } cases[] = {
        {"negative_se", [](nlohmann::json& m) { m["std_error_normalised"][0] = -0.5; }, "std_error_normalised[0] (FDJ_Nm) = -0.5 is not in (0, 1]"},
        {"huge_se", [](nlohmann::json& m) { m["std_error_normalised"][1] = 1e308; }, "std_error_normalised[1] (eta_O) = 1e+308 is not in (0, 1]"},
        {"bogus_transfer", [](nlohmann::json& m) { m["network"]["hidden_transfer"] = "bogus"; },
         "network.hidden_transfer is \"bogus\", expected \"tansig\""},
        {"flat_norm", [](nlohmann::json& m) { m["input_normalisation"]["max"][3] = m["input_normalisation"]["min"][3]; },
         "input_normalisation: input 3 has min"},
        {"dup_outputs", [](nlohmann::json& m) { m["spec"]["outputs"][1] = "FDJ_Nm"; }, "spec.outputs[1] \"FDJ_Nm\" repeats spec.outputs[0]"},
    };
    for (const auto& c : cases) {
        nlohmann::json m = model;
        c.edit(m);
        const std::string path = p(std::string(c.name) + ".json");
        write(path, m.dump());
        r = run_cli("estimate " + run + " --model " + path);
        EXPECT_EQ(r.exit_code, 1) << c.name << ": " << r.output;
        EXPECT_THAT(r.output, AllOf(HasSubstr(path), HasSubstr(c.message))) << c.name;
        EXPECT_THAT(r.output, Not(HasSubstr("agree"))) << c.name;
    }
    // A key twice: the last would silently win.
    std::string text = model.dump();
    text.insert(1, "\"version\": 1, ");
    write(p("dup_key.json"), text);
    r = run_cli("estimate " + run + " --model " + p("dup_key.json"));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr("duplicate key \"version\" in the object at /"));
}

// Item 3: limits that are no limits, and a key twice.
TEST_F(HostileValidityCli, NonsenseLimitsAreRefusedNamingTheKeyAndValue) {
    const std::string run = simulated_csv("run.csv");
    const struct { const char* json; const char* message; } cases[] = {
        {R"({"eta_O": {"min": 5}})", "eta_O.min: 5 exceeds the largest possible efficiency"},
        {R"({"eta_A": {"min": 1.5}})", "eta_A.min: 1.5 exceeds the largest possible efficiency"},
        {R"({"FDJ_Nm": {"max": 100}})", "FDJ_Nm.max: 100 N m exceeds the motor torque saturation T_max"},
        {R"({"eta_O": {"min": 0.8}, "eta_O": {"min": 0.1}})", "duplicate key \"eta_O\" in the object at /"},
        {R"({"FDJ_Nm": {"max": 0.09, "max": 9}})", "duplicate key \"max\" in the object at /FDJ_Nm"},
    };
    int i = 0;
    for (const auto& c : cases) {
        const std::string path = p("limits" + std::to_string(i++) + ".json");
        write(path, c.json);
        const auto r = run_cli(import(run, "--limits " + path));
        EXPECT_EQ(r.exit_code, 1) << c.json << ": " << r.output;
        EXPECT_THAT(r.output, AllOf(HasSubstr(path), HasSubstr(c.message))) << c.json;
    }
    write(p("ok.json"), R"({"eta_O": {"min": 0.7}, "FDJ_Nm": {"max": 0.09}})");
    const auto r = run_cli(import(run, "--limits " + p("ok.json")));
    EXPECT_EQ(r.exit_code, 0) << r.output;
}

// Item 3: `discover RUN --db X --tail T` mixed a run of another actuator into T's and stored the finding under T.
TEST_F(HostileValidityCli, DiscoverTakesOneActuatorsRunsAndRefusesAForeignRun) {
    const std::string own = simulated_csv("own.csv");
    auto r = run_cli(import(own, "--serial SN-1"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string foreign = simulated_csv("foreign.csv");  // no serial: nothing ties it to SN-1
    write(p("other.csv"), replaced(slurp(foreign), "# ema_serial_number=", "# ema_serial_number=SN-9"));

    r = run_cli("discover " + foreign + " --db " + p("m.db") + " --tail N21EM");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("needs --position POS"));
    r = run_cli("discover " + foreign + " --db " + p("m.db") + " --tail N21EM --position LH-ELEV");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("foreign.csv: the run names no serial"), HasSubstr("not the actuator SN-1 at N21EM LH-ELEV")));
    r = run_cli("discover " + p("other.csv") + " --db " + p("m.db") + " --tail N21EM --position LH-ELEV");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("the run names serial SN-9, not the actuator SN-1"));
    r = run_cli("discover " + foreign + " --position LH-ELEV");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("--position and --serial go with --db FILE --tail T"));
    r = run_cli("discover --db " + p("m.db") + " --tail N21EM --position RH-ELEV");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("no valid stored run at position RH-ELEV"));

    db::Database database(p("m.db"));
    EXPECT_TRUE(db::list_discovery_findings(database, "N21EM").empty());
}

TEST_F(HostileValidityCli, DiscoverStoresTheFindingUnderThePositionAndSerialOfItsRuns) {
    const std::string run = simulated_csv("run.csv");
    ASSERT_EQ(run_cli(import(run, "--serial SN-1")).exit_code, 0);
    // Another actuator of the same tail, and a replacement at the same position later.
    ASSERT_EQ(run_cli("import " + run + " --db " + p("m.db") + " --tail N21EM --position RH-ELEV --utc 2026-11-27T13:00:00Z --serial SN-2")
                  .exit_code,
              0);
    auto r = run_cli("discover --db " + p("m.db") + " --tail N21EM --position LH-ELEV");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("finding stored as discovery finding 1 of N21EM LH-ELEV serial SN-1"), HasSubstr("run run 1 ")));
    EXPECT_THAT(r.output, Not(HasSubstr("run run 2 ")));
    ASSERT_EQ(run_cli("import " + run + " --db " + p("m.db") + " --tail N21EM --position LH-ELEV --utc 2026-11-28T12:00:00Z --serial SN-3")
                  .exit_code,
              0);
    r = run_cli("discover --db " + p("m.db") + " --tail N21EM --position LH-ELEV");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_THAT(r.output, HasSubstr("position LH-ELEV of N21EM held 2 actuators (serials SN-1, SN-3); give --serial SN"));
    db::Database database(p("m.db"));
    const auto findings = db::list_discovery_findings(database, "N21EM");
    ASSERT_EQ(findings.size(), 1u);
    EXPECT_EQ(findings[0].position.value_or(""), "LH-ELEV");
    EXPECT_EQ(findings[0].actuator_serial, "SN-1");
}
