// The technician's test run against the simulated EMA on an in-process bus (the vcan suite repeats
// it with separate processes over SocketCAN): verdicts for a healthy and a worn transmission,
// everything stored under the tail number, and the refusals that must come before anything moves.
#include "core/emadiag_error.hpp"
#include "diagnosis/ground_test.hpp"
#include "emadiag/can/memory_bus.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"
#include "support/node_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <fstream>
#include <sstream>
#include <thread>

using namespace emadiag;
using ::testing::AllOf;
using ::testing::HasSubstr;

namespace {

node::EmaNodeConfig ema_config(double fdj_nm, double fsj_nm, std::uint64_t seed) {
    node::EmaNodeConfig c;
    c.sim.load_case = sim::LoadCase::A;  // on the ramp
    c.sim.noise = sim::NoiseProfile::Typical;
    c.sim.seed = seed;
    c.sim.params.fdj_nm = fdj_nm;
    c.sim.params.fsj_nm = fsj_nm;
    return c;
}

class TestRun : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = std::filesystem::path(EMADIAG_BINARY_DIR) / ("test_run_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override {
        if (!HasFailure()) std::filesystem::remove_all(dir_);
    }
    TestRunOptions options(const std::string& tail) const {
        TestRunOptions o;
        o.tail_number = tail;
        o.phase = kPhasePostFlight;
        o.out_dir = dir_ / "logs";
        o.db_path = (dir_ / "maintenance.db").string();
        o.tool_version = "test";
        return o;
    }
    static std::string slurp(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        std::ostringstream s;
        s << in.rdbuf();
        return s.str();
    }
    std::filesystem::path dir_;
    std::atomic<bool> interrupt_{false};
};

}  // namespace

TEST_F(TestRun, HealthyEmaIsServiceableAndEverythingIsStoredUnderTheTail) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    test::NodeRunner ema(hub, ema_config(0.08, 0.12, 5));
    const TestRunOptions o = options("N123EM");
    const TestRunResult r = run_test(tool, o, interrupt_);
    EXPECT_EQ(r.assessment.verdict, Verdict::Serviceable) << r.assessment.reason;
    ASSERT_EQ(r.runs.size(), 2u);
    EXPECT_EQ(sim::to_string(r.runs[0].sequence), "dyn");
    EXPECT_EQ(sim::to_string(r.runs[1].sequence), "brk");
    for (const auto& run : r.runs) {
        EXPECT_TRUE(run.outcome.valid) << run.outcome.invalid_reason;
        EXPECT_TRUE(run.estimates.has_value()) << run.estimate_error;
        EXPECT_TRUE(std::filesystem::exists(run.csv_path));
    }
    // eta is not identifiable on the ground (case A): listed, not assessed.
    bool eta_listed = false;
    for (const auto& f : r.assessment.findings)
        if (f.parameter == kParamEtaO && to_string(f.estimator) == "physics:dyn") eta_listed = f.status == FindingStatus::NotIdentifiable;
    EXPECT_TRUE(eta_listed);

    db::Database database(o.db_path);
    const auto sessions = db::list_test_sessions(database, "N123EM");
    ASSERT_EQ(sessions.size(), 1u);
    const db::StoredTestSession s = db::load_test_session(database, sessions[0].session_id);
    EXPECT_EQ(s.verdict, "SERVICEABLE");
    EXPECT_EQ(s.phase, "post-flight");
    EXPECT_EQ(s.tool_version, "test");
    EXPECT_EQ(s.findings.size(), r.assessment.findings.size());
    ASSERT_EQ(s.runs.size(), 2u);
    EXPECT_EQ(s.runs[0].samples.size(), r.runs[0].outcome.run.samples.size());
    EXPECT_EQ(s.runs[1].samples.size(), r.runs[1].outcome.run.samples.size());
    // The raw bus logs are stored byte for byte.
    EXPECT_EQ(s.runs[0].raw_log, slurp(r.runs[0].log_path));
    EXPECT_EQ(s.runs[1].raw_log, slurp(r.runs[1].log_path));
    EXPECT_FALSE(s.runs[1].raw_log.empty());
    EXPECT_FALSE(s.runs[1].estimates.empty());
    EXPECT_EQ(s.runs[0].load_case, "A");
    // Recorded inside the spool directory (recover takes no file from elsewhere), then moved to the
    // output directory, which the stored run's log_file names.
    for (const auto& run : s.runs) {
        const std::string log_file = nlohmann::json::parse(run.meta_json).value("log_file", "");
        EXPECT_EQ(std::filesystem::path(log_file).parent_path(), dir_ / "logs");
        EXPECT_EQ(run.raw_log, slurp(log_file));
    }
    EXPECT_TRUE(std::filesystem::is_empty(spool_dir_for(o.db_path)));
}

TEST_F(TestRun, TheRecordKeepsPositionSerialCyclesAndThePersonAndNotesAnInstallationChange) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    TestRunOptions o = options("N123EM");
    o.sequences = {can::icd::TestSequence::Dyn};  // a network model is shipped for case A DYN
    o.record.position = "RH-ELEV";
    o.record.cycles = 4120;
    o.record.hours_h = 6203.5;
    o.record.operator_id = "EMA-AIR";
    o.record.technician_name = "A. Mechanic";
    o.record.technician_certificate = "B1-12345";
    std::vector<TestRunResult> results;
    for (const std::uint32_t serial : {1001u, 1001u, 2002u}) {
        node::EmaNodeConfig c = ema_config(0.08, 0.12, serial);
        c.ident.serial_number = serial;
        test::NodeRunner ema(hub, c);
        results.push_back(run_test(tool, o, interrupt_));
        o.record.cycles = *o.record.cycles + 10;
    }
    EXPECT_EQ(results[0].actuator_serial, "1001") << "from the EMA's identification";
    ASSERT_TRUE(results[0].installation);
    EXPECT_EQ(results[0].installation->to_serial, "1001");
    EXPECT_FALSE(results[1].installation);
    ASSERT_TRUE(results[2].installation) << "a new serial at RH-ELEV";
    EXPECT_EQ(results[2].installation->from_serial, "1001");
    EXPECT_EQ(results[2].installation->to_serial, "2002");
    EXPECT_EQ(results[2].installation->cycles, std::optional<std::int64_t>(4140));
    db::Database database(o.db_path);
    const db::StoredTestSession s = db::load_test_session(database, results[0].db_session_id);
    EXPECT_EQ(s.position, std::optional<std::string>("RH-ELEV"));
    EXPECT_EQ(s.position_ata, "27-30");
    EXPECT_EQ(s.cycles, std::optional<std::int64_t>(4120));
    EXPECT_EQ(s.hours_h, std::optional<double>(6203.5));
    EXPECT_EQ(s.technician_name, "A. Mechanic");
    EXPECT_EQ(s.technician_certificate, "B1-12345");
    EXPECT_EQ(s.operator_id, "EMA-AIR");
    EXPECT_EQ(s.source, "test-run");
    EXPECT_THAT(s.work_performed, HasSubstr("ground test run over CAN (post-flight): dyn"));
    EXPECT_EQ(s.limits_sha256.size(), 64u);
    bool model_hashed = false;
    for (const auto& a : s.artifacts) model_hashed = model_hashed || (a.role == "model" && a.sha256 == db::sha256_file_hex(a.name));
    EXPECT_TRUE(model_hashed) << "the network model file used, with its SHA-256";
    EXPECT_TRUE(db::verify_tail(database, "N123EM").ok());
}

TEST_F(TestRun, WornTransmissionIsUnserviceableNamingTheParameter) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    test::NodeRunner ema(hub, ema_config(0.08, 0.17, 6));  // static friction 42 % above nominal
    TestRunOptions o = options("N123EM");
    o.phase = kPhasePreFlight;
    o.sequences = {can::icd::TestSequence::Brk};
    const TestRunResult r = run_test(tool, o, interrupt_);
    EXPECT_EQ(r.assessment.verdict, Verdict::Unserviceable) << r.assessment.reason;
    EXPECT_THAT(r.assessment.reason, HasSubstr("FSJ_Nm"));
    db::Database database(o.db_path);
    ASSERT_EQ(db::list_test_sessions(database, "N123EM").size(), 1u);
    EXPECT_EQ(db::list_test_sessions(database, "N123EM")[0].verdict, "UNSERVICEABLE");
}

TEST_F(TestRun, BadTailNumberIsRefusedBeforeTheSurfaceMoves) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    test::NodeRunner ema(hub, ema_config(0.08, 0.12, 1));
    EXPECT_THROW((void)run_test(tool, options("n123 em"), interrupt_), db::DbError);
    TestRunOptions o = options("N123EM");
    o.sequences = {can::icd::TestSequence::Dyn, can::icd::TestSequence::Dyn};
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr("dyn is listed twice")));
    o = options("N123EM");
    o.phase = "mid-flight";
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr("phase \"mid-flight\"")));
    o = options("N123EM");
    o.record.position = "LH-WING";
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("unknown position 'LH-WING' (known positions, built-in: LH-AIL, RH-AIL")));
    o.record.position = "LH-ELEV";
    o.record.cycles = -3;
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr("--cycles -3 is negative")));
    EXPECT_EQ(ema.stats().sequences_started, 0u);
    EXPECT_FALSE(std::filesystem::exists(o.db_path)) << "nothing stored, not even an empty database";
}

TEST_F(TestRun, EmaThatDoesNotReportGroundTestIsNeverStarted) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = ema_config(0.08, 0.12, 1);
    cfg.faults.ack_without_ground_test = true;
    test::NodeRunner ema(hub, cfg);
    EXPECT_THAT([&] { (void)run_test(tool, options("N123EM"), interrupt_); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("acknowledged ENTER_GROUND_TEST but its EMA_Status (0x020) reports Mode=NORMAL")));
    EXPECT_EQ(ema.stats().sequences_started, 0u);
    db::Database database(options("N123EM").db_path);
    EXPECT_TRUE(db::list_test_sessions(database, "N123EM").empty());  // nothing ran, nothing stored
}

TEST_F(TestRun, InvalidRunEndsTheSessionAsNoTestAndIsStillStored) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = ema_config(0.08, 0.12, 1);
    cfg.faults.drop_fraction = 0.05;  // telemetry loss above the recorder's limit
    cfg.faults.seed = 4;
    test::NodeRunner ema(hub, cfg);
    TestRunOptions o = options("G-EMAD");
    o.retry_transient = false;  // the retry has its own test
    const TestRunResult r = run_test(tool, o, interrupt_);
    EXPECT_EQ(r.assessment.verdict, Verdict::NoTest);
    EXPECT_THAT(r.assessment.reason, HasSubstr("the dyn run is not valid"));
    ASSERT_EQ(r.runs.size(), 1u);  // nothing more is commanded after an invalid run
    EXPECT_EQ(ema.stats().sequences_started, 1u);
    db::Database database(o.db_path);
    const auto sessions = db::list_test_sessions(database, "G-EMAD");
    ASSERT_EQ(sessions.size(), 1u);
    EXPECT_EQ(sessions[0].verdict, "NO_TEST");
    const auto s = db::load_test_session(database, sessions[0].session_id);
    ASSERT_EQ(s.runs.size(), 1u);
    EXPECT_FALSE(s.runs[0].valid);
    EXPECT_EQ(s.runs[0].raw_log, slurp(r.runs[0].log_path));
}

TEST_F(TestRun, NoEmaIsAClearErrorAndNothingIsStored) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    const TestRunOptions o = options("N123EM");
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr("no EMA answered")));
    db::Database database(o.db_path);
    EXPECT_TRUE(db::list_test_sessions(database, "N123EM").empty());
}

TEST_F(TestRun, CtrlCAbortsTheSequenceAndStoresTheSessionAsNoTest) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    test::NodeRunner ema(hub, ema_config(0.08, 0.12, 2));
    const TestRunOptions o = options("N123EM");
    std::thread technician([this] {
        std::this_thread::sleep_for(std::chrono::milliseconds(400));  // mid-DYN: simulation plus 0.5 s of streaming
        interrupt_ = true;
    });
    const TestRunResult r = run_test(tool, o, interrupt_);
    technician.join();
    EXPECT_TRUE(r.interrupted);
    EXPECT_EQ(r.assessment.verdict, Verdict::NoTest);
    EXPECT_THAT(r.assessment.reason, HasSubstr("Ctrl-C"));
    ASSERT_EQ(r.runs.size(), 1u);  // BRK is never commanded
    EXPECT_EQ(r.runs[0].outcome.status, "aborted");
    EXPECT_EQ(ema.stats().sequences_aborted, 1u);
    EXPECT_EQ(ema.stats().sequences_started, 1u);
    db::Database database(o.db_path);
    const auto sessions = db::list_test_sessions(database, "N123EM");
    ASSERT_EQ(sessions.size(), 1u);
    EXPECT_EQ(sessions[0].verdict, "NO_TEST");
    EXPECT_EQ(db::load_test_session(database, sessions[0].session_id).runs.at(0).raw_log, slurp(r.runs[0].log_path));
}

TEST_F(TestRun, TransientLossIsRunOnceMoreAndBothAttemptsAreStored) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    auto cfg = ema_config(0.08, 0.12, 5);
    cfg.faults.drop_burst_frames = 50;  // 1.25 % of DYN's frames, in the first sequence only
    cfg.faults.fault_sequences = 1;
    test::NodeRunner ema(hub, cfg);
    std::vector<std::string> said;
    TestRunOptions o = options("N123EM");
    o.on_progress = [&](const std::string& line) { said.push_back(line); };
    const TestRunResult r = run_test(tool, o, interrupt_);
    EXPECT_EQ(r.assessment.verdict, Verdict::Serviceable) << r.assessment.reason;
    ASSERT_EQ(r.runs.size(), 3u);
    EXPECT_FALSE(r.runs[0].outcome.valid);
    EXPECT_TRUE(r.runs[0].outcome.transient_loss);
    EXPECT_EQ(r.runs[0].outcome.stats.frames_lost, 50u);
    EXPECT_EQ(sim::to_string(r.runs[1].sequence), "dyn");
    EXPECT_EQ(r.runs[1].attempt, 2);
    EXPECT_TRUE(r.runs[1].outcome.valid);
    EXPECT_EQ(sim::to_string(r.runs[2].sequence), "brk");
    EXPECT_EQ(ema.stats().sequences_started, 3u);
    bool told = false;
    for (const auto& l : said) told = told || l.find("running dyn once more") != std::string::npos;
    EXPECT_TRUE(told) << "the technician is told about the retry";
    db::Database database(o.db_path);
    const auto sessions = db::list_test_sessions(database, "N123EM");
    ASSERT_EQ(sessions.size(), 1u);
    const auto s = db::load_test_session(database, sessions[0].session_id);
    ASSERT_EQ(s.runs.size(), 3u);
    EXPECT_THAT(s.runs[1].status_note, HasSubstr("attempt 2"));
    EXPECT_EQ(s.runs[0].raw_log, slurp(r.runs[0].log_path));
    EXPECT_TRUE(std::filesystem::is_empty(spool_dir_for(o.db_path)));
}

TEST_F(TestRun, SpooledSessionOfAKilledToolIsRecoveredOnceNeverTwice) {
    // What a kill -9 leaves: a raw log in the spool directory and a manifest still "recording".
    const TestRunOptions o = options("N123EM");
    std::filesystem::create_directories(spool_dir_for(o.db_path));
    const std::string log_name = "killed_dyn.log";
    const std::string log_path = (spool_dir_for(o.db_path) / log_name).string();
    {
        can::MemoryBusHub hub;
        can::MemoryBus tool(hub, "tool");
        test::NodeRunner ema(hub, ema_config(0.08, 0.12, 3));
        can_tool::RecorderOptions ro;
        ro.log_path = log_path;
        can_tool::Recorder rec(tool, ro);
        (void)rec.record(interrupt_);
    }
    SessionManifest m;
    m.tail_number = "N123EM";
    m.phase = kPhasePostFlight;
    m.started_utc = "2026-11-24T10:00:00Z";
    m.tool_version = "test";
    m.limits_json = HealthLimits::datasheet_envelope().to_json().dump();
    m.sequences = {"dyn", "brk"};
    std::filesystem::path manifest;
    {
        SessionSpool spool(spool_dir_for(o.db_path), m);
        spool.add_log(SpooledLog{"dyn", 1, log_name});
        manifest = spool.path();
        // While the tool lives, its lock keeps every other recovery away from the session.
        EXPECT_TRUE(recover_spooled_sessions(o.db_path, nullptr).empty());
    }  // the tool dies: the kernel releases its lock; the manifest stays
    // A manifest that cannot be read is reported and left in place, never deleted.
    const auto bad = spool_dir_for(o.db_path) / "N999EM_bad.json";
    std::ofstream(bad) << "{ not json";

    std::vector<std::string> said;
    const auto first = recover_spooled_sessions(o.db_path, [&](const std::string& l) { said.push_back(l); });
    ASSERT_EQ(first.size(), 2u) << "the good manifest stored, the bad one refused";
    EXPECT_TRUE(first[1].refused);
    EXPECT_EQ(first[1].manifest.filename(), "N999EM_bad.json");
    EXPECT_GT(first[0].db_session_id, 0);
    EXPECT_EQ(first[0].verdict, "NO_TEST");
    EXPECT_THAT(first[0].note, HasSubstr("the tool stopped mid-session (while recording dyn)"));
    EXPECT_FALSE(std::filesystem::exists(manifest));
    EXPECT_TRUE(std::filesystem::exists(bad));
    bool reported = false;
    for (const auto& l : said) reported = reported || l.find("N999EM_bad.json") != std::string::npos;
    EXPECT_TRUE(reported);
    {
        db::Database database(o.db_path);
        const auto sessions = db::list_test_sessions(database, "N123EM");
        ASSERT_EQ(sessions.size(), 1u);
        const auto s = db::load_test_session(database, sessions[0].session_id);
        ASSERT_EQ(s.runs.size(), 1u);
        EXPECT_EQ(s.runs[0].raw_log, slurp(log_path));
        EXPECT_EQ(s.started_utc, "2026-11-24T10:00:00Z");
    }
    // The tool died after storing but before removing the manifest: not stored twice.
    {
        SessionSpool again(spool_dir_for(o.db_path), m);
        again.add_log(SpooledLog{"dyn", 1, log_name});
    }
    std::filesystem::remove(bad);
    const auto second = recover_spooled_sessions(o.db_path, nullptr);
    ASSERT_EQ(second.size(), 1u);
    EXPECT_EQ(second[0].db_session_id, 0);
    EXPECT_THAT(second[0].note, HasSubstr("already stored"));
    db::Database database(o.db_path);
    EXPECT_EQ(db::list_test_sessions(database, "N123EM").size(), 1u);
}

// Killed before the EMA identified itself: the frames the log holds are kept (an invalid run with
// no samples, its raw log byte for byte); killed before any frame: nothing to keep, manifest removed.
TEST_F(TestRun, SpooledSessionKilledBeforeTheEmaAnsweredKeepsItsFramesOrIsDroppedWhenEmpty) {
    const TestRunOptions o = options("N123EM");
    SessionManifest m;
    m.tail_number = "N123EM";
    m.phase = kPhasePreFlight;
    m.started_utc = "2026-11-24T11:00:00Z";
    m.tool_version = "test";
    m.limits_json = HealthLimits::datasheet_envelope().to_json().dump();
    m.sequences = {"dyn"};
    std::filesystem::create_directories(spool_dir_for(o.db_path));
    const std::string cut_log = (spool_dir_for(o.db_path) / "cut_dyn.log").string();
    std::ofstream(cut_log) << "(1795525640.771675) can0 011#0100000000000000\n"
                              "(1795525640.791645) can0 010#0100000000000000\n";
    {
        SessionSpool spool(spool_dir_for(o.db_path), m);
        spool.add_log(SpooledLog{"dyn", 1, "cut_dyn.log"});
    }
    const auto kept = recover_spooled_sessions(o.db_path, nullptr);
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_GT(kept[0].db_session_id, 0);
    EXPECT_FALSE(kept[0].nothing_recorded);
    EXPECT_EQ(kept[0].verdict, "NO_TEST");
    {
        db::Database database(o.db_path);
        const auto s = db::load_test_session(database, kept[0].db_session_id);
        ASSERT_EQ(s.runs.size(), 1u);
        EXPECT_FALSE(s.runs[0].valid);
        EXPECT_THAT(s.runs[0].status_note, HasSubstr("no run could be decoded from the raw log"));
        EXPECT_EQ(s.runs[0].raw_log, slurp(cut_log));
    }
    const std::string empty_log = (spool_dir_for(o.db_path) / "empty_dyn.log").string();
    std::ofstream(empty_log).flush();
    m.started_utc = "2026-11-24T12:00:00Z";
    std::filesystem::path manifest;
    {
        SessionSpool spool(spool_dir_for(o.db_path), m);
        spool.add_log(SpooledLog{"dyn", 1, "empty_dyn.log"});
        manifest = spool.path();
    }
    std::vector<std::string> said;
    const auto dropped = recover_spooled_sessions(o.db_path, [&](const std::string& l) { said.push_back(l); });
    ASSERT_EQ(dropped.size(), 1u);
    EXPECT_TRUE(dropped[0].nothing_recorded);
    EXPECT_EQ(dropped[0].db_session_id, 0);
    EXPECT_FALSE(std::filesystem::exists(manifest));
    ASSERT_FALSE(said.empty());
    EXPECT_THAT(said.back(), HasSubstr("nothing was recorded on the bus before the tool stopped"));
    db::Database database(o.db_path);
    EXPECT_EQ(db::list_test_sessions(database, "N123EM").size(), 1u);
}

TEST_F(TestRun, ASecondToolOnTheBusIsHeardAndNothingIsCommanded) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    can::MemoryBus other(hub, "other");
    test::NodeRunner ema(hub, ema_config(0.08, 0.12, 5));
    std::atomic<bool> stop{false};
    std::thread other_tool([&] {  // another tool's heartbeat, 50 Hz
        const can::EmaIcd icd;
        std::uint8_t c = 0;
        while (!stop) {
            (void)other.send(icd.encode_heartbeat(c++));
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    });
    const TestRunOptions o = options("N123EM");
    EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("another tool is active on memory:tool: heard TOOL_Heartbeat (0x011)")));
    stop = true;
    other_tool.join();
    EXPECT_EQ(ema.stats().sequences_started, 0u);
    db::Database database(o.db_path);
    EXPECT_TRUE(db::list_test_sessions(database, "N123EM").empty());
}

namespace {

/// An augmented model as `emadiag discover` writes it (the fields apply_model reads), with `terms`.
std::string write_model(const std::filesystem::path& path, const nlohmann::json& terms) {
    const nlohmann::json model = {{"version", 1}, {"base", "EMA-REF-1 datasheet"}, {"terms", terms}};
    std::ofstream(path) << model.dump(2);
    return path.string();
}

double physics_fdj(const TestRunResult& r) {
    if (r.runs.empty() || !r.runs[0].estimates) return NAN;
    const auto* p = r.runs[0].estimates->estimates.at(0).find(kParamFdj);
    return p != nullptr && p->value ? *p->value : NAN;
}

}  // namespace

TEST_F(TestRun, AnAugmentedModelIsRemovedFromTheRunsListedWithItsHashAndNamed) {
    // The EMA has viscous friction the datasheet model lacks; discover's model carries it.
    constexpr double kViscousNmSRad = 2e-4;
    constexpr double kTrueFdjNm = 0.08;
    const std::string model_path =
        write_model(dir_ / "augmented.json", {{{"effect", "viscous_nm_s_rad"}, {"value", kViscousNmSRad}, {"std_error", 1e-6}}});
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    node::EmaNodeConfig c = ema_config(kTrueFdjNm, 0.12, 8);
    c.sim.params.effects.viscous_nm_s_rad = kViscousNmSRad;
    test::NodeRunner ema(hub, c);
    TestRunOptions o = options("N123EM");
    o.sequences = {can::icd::TestSequence::Dyn};
    const TestRunResult plain = run_test(tool, o, interrupt_);
    o.augmented_model_path = model_path;
    std::vector<std::string> progress;
    o.on_progress = [&](const std::string& line) { progress.push_back(line); };
    const TestRunResult with = run_test(tool, o, interrupt_);
    const double fdj_plain = physics_fdj(plain);
    const double fdj_with = physics_fdj(with);
    std::cout << "physics FDJ without the model " << fdj_plain << " N m, with it " << fdj_with << " N m (truth " << kTrueFdjNm << ")\n";
    EXPECT_LT(std::abs(fdj_with - kTrueFdjNm), 0.25 * std::abs(fdj_plain - kTrueFdjNm)) << "the viscous torque is removed";
    EXPECT_LT(std::abs(fdj_with - kTrueFdjNm), 0.01);
    // Which model was used: in the result, the progress, each run's estimates and the stored session.
    ASSERT_TRUE(with.augmented_model.has_value());
    const std::string sha = db::sha256_file_hex(model_path);
    EXPECT_EQ(with.augmented_model->sha256, sha);
    EXPECT_THAT(progress.at(0), HasSubstr("augmented model " + model_path + " (sha256 " + sha + ")"));
    EXPECT_THAT(progress.at(0), HasSubstr("0.0002*w"));
    ASSERT_TRUE(with.runs.at(0).estimates.has_value()) << with.runs[0].estimate_error;
    EXPECT_EQ(with.runs[0].estimates->model_files.at(0), model_path);
    EXPECT_THAT(with.runs[0].estimates->notes.at(0), HasSubstr("removed from the run before estimation"));
    db::Database database(o.db_path);
    const db::StoredTestSession stored = db::load_test_session(database, with.db_session_id);
    bool listed = false;
    for (const auto& a : stored.artifacts) listed = listed || (a.role == "model" && a.name == model_path && a.sha256 == sha);
    EXPECT_TRUE(listed) << "the augmented model with its SHA-256";
    EXPECT_THAT(stored.work_performed, HasSubstr("corrected by the augmented model " + model_path));
    const db::StoredTestSession stored_plain = db::load_test_session(database, plain.db_session_id);
    for (const auto& a : stored_plain.artifacts) EXPECT_NE(a.name, model_path);
    EXPECT_TRUE(db::verify_tail(database, "N123EM").ok());
}

TEST_F(TestRun, ABadAugmentedModelIsRefusedBeforeTheSurfaceMoves) {
    can::MemoryBusHub hub;
    can::MemoryBus tool(hub, "tool");
    test::NodeRunner ema(hub, ema_config(0.08, 0.12, 9));
    TestRunOptions o = options("N123EM");
    auto refused = [&](const std::string& path, const std::string& what) {
        o.augmented_model_path = path;
        EXPECT_THAT([&] { (void)run_test(tool, o, interrupt_); },
                    ::testing::ThrowsMessage<EmadiagError>(AllOf(HasSubstr("--model " + path + ": "), HasSubstr(what))));
    };
    refused((dir_ / "missing.json").string(), "cannot open the augmented model file");
    std::ofstream(dir_ / "bad.json") << "{\"version\": 1, \"terms\": [";
    refused((dir_ / "bad.json").string(), "not valid JSON");
    std::ofstream(dir_ / "network.json") << R"({"layers": [3, 2]})";
    refused((dir_ / "network.json").string(), "not an augmented model from `emadiag discover`");
    refused(write_model(dir_ / "backlash.json", {{{"effect", "backlash_rad"}, {"value", 0.01}, {"std_error", 0}}}), "backlash");
    refused(write_model(dir_ / "unknown.json", {{{"effect", "warp_drive"}, {"value", 1}, {"std_error", 0}}}), "warp_drive");
    EXPECT_EQ(ema.stats().sequences_started, 0u);
    EXPECT_FALSE(std::filesystem::exists(o.db_path)) << "nothing stored, not even an empty database";
}
