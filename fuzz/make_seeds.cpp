// Writes small valid inputs for the fuzz corpora (fuzz/corpus/<target>/), made with the project's own
// writers so they match the formats exactly: a recorded test session as a candump log and as the
// frame-stream layout, a run CSV, a dataset, an augmented model and limits JSON. The script
// scripts/fuzz/run_fuzz.sh adds the files of tests/data, models/ and sim_backend/params.
// Usage: fuzz_make_seeds OUT_DIR (the corpus folders are created in it).
#include "core/run_csv.hpp"
#include "diagnosis/health_limits.hpp"
#include "discovery/model/augmented_model.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "estimation/dataset.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace fs = std::filesystem;
using namespace emadiag;

namespace {

/// A short DYN session as the tool records it: identification, ground test, START, telemetry with
/// good CRCs (one corrupt), status DONE.
std::vector<can::CanFrame> session_frames(int samples) {
    const can::EmaIcd icd;
    std::vector<can::CanFrame> f;
    can::EmaStatus st;
    st.mode = can::icd::Mode::GroundTest;
    st.weight_on_wheels = true;
    st.load_case = can::icd::LoadCase::B;
    f.push_back(icd.encode_command({can::icd::Command::RequestIdent, can::icd::TestSequence::None, 0}));
    can::EmaIdentification id;
    id.serial_number = 1234;
    id.part_number = 42;
    id.firmware_major = 1;
    id.k_t_nm_per_a = 0.0625;
    id.j_kgm2 = 1.6e-5;
    id.tau = 0.006;
    id.sample_period_s = 0.0005;
    for (const auto& p : icd.encode_ident(id)) f.push_back(p);
    f.push_back(icd.encode_command({can::icd::Command::EnterGroundTest, can::icd::TestSequence::None, 0}));
    f.push_back(icd.encode_ack({can::icd::Command::EnterGroundTest, can::icd::AckResult::Accepted, 0}));
    f.push_back(icd.encode_status(st));
    f.push_back(icd.encode_command({can::icd::Command::StartSequence, can::icd::TestSequence::Dyn, 7}));
    f.push_back(icd.encode_ack({can::icd::Command::StartSequence, can::icd::AckResult::Accepted, 7}));
    st.state = can::icd::SequenceState::Running;
    st.sequence = can::icd::TestSequence::Dyn;
    st.session_id = 7;
    f.push_back(icd.encode_status(st));
    for (int k = 0; k < samples; ++k) {
        const auto idx = static_cast<std::uint16_t>(k);
        const auto ctr = static_cast<std::uint8_t>(k % 16);
        f.push_back(icd.encode_heartbeat(ctr));
        f.push_back(icd.encode_telemetry_a(idx, ctr, 2.0 * std::sin(0.3 * k), 100.0 * std::cos(0.3 * k)));
        can::CanFrame b = icd.encode_telemetry_b(idx, ctr, 0.01 * k, -3.0 + 0.1 * k);
        if (k == samples / 2) b.data[7] ^= 0x5A;  // one corrupt CRC
        f.push_back(b);
    }
    st.state = can::icd::SequenceState::Done;
    st.samples_sent = static_cast<std::uint16_t>(samples);
    f.push_back(icd.encode_status(st));
    f.push_back(icd.encode_command({can::icd::Command::LeaveGroundTest, can::icd::TestSequence::None, 0}));
    for (std::size_t i = 0; i < f.size(); ++i) f[i].timestamp = std::chrono::milliseconds(1700000000000LL + static_cast<long long>(i));
    return f;
}

/// The frame-stream layout of fuzz_entries.cpp (frame_stream_frames), the inverse of its decoder.
std::string frame_stream_bytes(const std::vector<can::CanFrame>& frames) {
    static constexpr std::uint32_t kIds[7] = {can::icd::kToolCommandId, can::icd::kToolHeartbeatId, can::icd::kStatusId,
                                              can::icd::kCommandAckId,  can::icd::kIdentId,         can::icd::kTelemetryAId,
                                              can::icd::kTelemetryBId};
    std::string out;
    for (const auto& f : frames) {
        int sel = 7;
        for (int k = 0; k < 7; ++k)
            if (kIds[k] == f.id) sel = k;
        out += static_cast<char>(sel);
        if (sel == 7) {
            out += static_cast<char>(f.id >> 8);
            out += static_cast<char>(f.id & 0xFF);
        }
        out += static_cast<char>(f.len);
        out.append(reinterpret_cast<const char*>(f.data.data()), f.len);
    }
    return out;
}

void write(const fs::path& path, const std::string& bytes) {
    fs::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary);
    out << bytes;
    if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: fuzz_make_seeds OUT_DIR\n";
        return 2;
    }
    const fs::path dir = argv[1];
    // candump and frame stream: a session of 12 samples, and one of 2.
    for (int samples : {12, 2}) {
        const auto frames = session_frames(samples);
        std::string log;
        for (const auto& f : frames) log += can::format_candump_line(f, "vcan0") + "\n";
        write(dir / "candump" / ("session_" + std::to_string(samples) + ".log"), log);
        write(dir / "frame_stream" / ("session_" + std::to_string(samples) + ".bin"), frame_stream_bytes(frames));
    }
    // run CSV: 20 samples of a plausible DYN run, with one extra column.
    Run run;
    run.constants = RunConstants{0.0625, 1.6e-5, 0.006, 0.0005};
    run.load_case = emadiag::sim::LoadCase::B;
    run.sequence = emadiag::sim::Sequence::Dyn;
    run.set_meta("source", "fuzz seed");
    run.extra_columns.emplace_back("T_R_Nm", std::vector<double>{});
    for (int k = 0; k < 20; ++k) {
        const double t = 0.0005 * (k + 1);
        run.samples.push_back(RunSample{t, 2.0 * std::sin(40 * t), 100 * std::cos(40 * t), 0.1 * k, -3 + 0.2 * k, 5 * std::sin(20 * t)});
        run.extra_columns[0].second.push_back(0.08 * std::sin(40 * t));
    }
    {
        std::ostringstream s;
        write_run_csv(s, run);
        write(dir / "run_csv" / "dyn_20.csv", s.str());
    }
    // dataset: 2 runs of 5 samples.
    Dataset d;
    d.constants = run.constants;
    d.spec.count = 2;
    d.filter = FilterCounts{2, 2, 0, 0, 0};
    for (int r = 0; r < 2; ++r) {
        DatasetRun dr;
        dr.labels = HealthLabels{0.08, 0.12, 0.85, 0.82};
        dr.noise_seed = static_cast<std::uint64_t>(r + 1);
        for (int k = 0; k < 5; ++k) dr.samples.push_back(sim::Sample{0.0005 * (k + 1), 1.0 * k, 2.0 * k, 0.1 * k, -1.0 * k, 0.5 * k});
        d.runs.push_back(dr);
    }
    fs::create_directories(dir / "dataset");
    write_dataset((dir / "dataset" / "two_runs.dataset").string(), d);
    // model JSON: the augmented model of the datasheet with one effect term.
    discovery::AugmentedModel m;
    m.health.push_back(discovery::HealthValue{"FDJ_Nm", 0.08, 0.001, "estimated", ""});
    m.terms.push_back(discovery::EffectTerm{"viscous_nm_s_rad", 1e-4, 1e-5});
    write(dir / "model_json" / "augmented.json", m.to_json().dump(1) + "\n");
    // limits JSON: the datasheet envelope and the example of docs/test-run.md.
    write(dir / "limits_json" / "datasheet.json", HealthLimits::datasheet_envelope().to_json().dump(1) + "\n");
    write(dir / "limits_json" / "manual.json", "{\"FDJ_Nm\": {\"max\": 0.092}, \"FSJ_Nm\": {\"max\": 0.140}}\n");
    std::cout << "seeds written to " << dir.string() << "\n";
    return 0;
}
