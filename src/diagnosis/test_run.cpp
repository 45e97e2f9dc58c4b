#include "diagnosis/test_run.hpp"

#include "diagnosis/session_storage.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/run_summary.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/test_session_store.hpp"

#include <ctime>
#include <fstream>
#include <sstream>

namespace emadiag {
namespace {

std::string utc_now_iso8601() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

/// 2026-11-23T01:02:03Z -> 20261123T010203Z (file names).
std::string compact(const std::string& iso) {
    std::string s;
    for (char c : iso)
        if (c != '-' && c != ':') s += c;
    return s;
}

std::string sequence_name(can::icd::TestSequence s) { return s == can::icd::TestSequence::Brk ? "brk" : "dyn"; }

std::string read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw EmadiagError(path + ": cannot read back the raw bus log to store it");
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

db::StoredRun to_stored(const TestRunRecord& r, const std::string& tail, const std::string& started_utc) {
    db::StoredRun s = to_stored_run(r.outcome.run, tail, started_utc, r.estimates);
    s.source = r.outcome.run.meta_value("source").value_or("emadiag test-run") + " " + r.outcome.run.meta_value("bus").value_or("");
    s.sequence = r.sequence;
    s.valid = r.outcome.valid;
    s.status_note = r.outcome.valid ? r.outcome.status : r.outcome.status + ": " + r.outcome.invalid_reason;
    s.raw_log_format = "candump";
    s.raw_log = read_bytes(r.log_path);
    return s;
}

}  // namespace

can::icd::TestSequence parse_test_sequence(const std::string& name) {
    if (name == "dyn") return can::icd::TestSequence::Dyn;
    if (name == "brk") return can::icd::TestSequence::Brk;
    throw EmadiagError("unknown test sequence \"" + name + "\" (expected dyn or brk)");
}

TestRunResult run_test(can::CanBus& bus, const TestRunOptions& options, const std::atomic<bool>& interrupt) {
    auto say = [&](const std::string& s) {
        if (options.on_progress) options.on_progress(s);
    };
    if (options.phase != kPhasePreFlight && options.phase != kPhasePostFlight)
        throw EmadiagError("phase \"" + options.phase + "\": expected " + kPhasePreFlight + " or " + kPhasePostFlight);
    if (options.sequences.empty()) throw EmadiagError("no test sequence to run");
    for (std::size_t i = 0; i < options.sequences.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (options.sequences[i] == options.sequences[j])
                throw EmadiagError("test sequence " + sequence_name(options.sequences[i]) + " is listed twice");
    db::check_tail_number(options.tail_number);
    db::StoredTestSession s;
    set_record_info(s, options.record);  // an unknown position, bad cycles or hours: nothing moves
    // Open (create, migrate) the database before anything moves: a test must never end unstorable.
    db::Database database(options.db_path);
    std::error_code ec;
    std::filesystem::create_directories(options.out_dir, ec);
    if (ec) throw EmadiagError(options.out_dir.string() + ": cannot create the output directory: " + ec.message());

    TestRunResult result;
    result.started_utc = utc_now_iso8601();
    const std::string stem_prefix = options.tail_number + "_" + compact(result.started_utc) + "_" + options.phase + "_";
    std::uint16_t session_id = options.first_session_id;
    std::optional<std::string> failure;
    for (const auto seq : options.sequences) {
        TestRunRecord rec;
        rec.sequence = sequence_name(seq);
        const std::filesystem::path stem = options.out_dir / (stem_prefix + rec.sequence);
        rec.log_path = stem.string() + ".log";
        rec.csv_path = stem.string() + ".csv";
        can_tool::RecorderOptions ro;
        ro.sequence = seq;
        ro.session_id = session_id++;
        ro.log_path = rec.log_path;
        ro.answer_timeout = options.answer_timeout;
        say("running " + rec.sequence + " (session " + std::to_string(ro.session_id) + ") on " + bus.spec());
        can_tool::Recorder recorder(bus, ro);
        try {
            rec.outcome = recorder.record(interrupt);
        } catch (const EmadiagError& e) {
            // No answer, a refusal, no GROUND_TEST: the runs already recorded are stored before
            // the error goes to the technician.
            failure = e.what();
            break;
        }
        rec.outcome.run.set_meta("tail_number", options.tail_number);
        rec.outcome.run.set_meta("phase", options.phase);
        write_run_csv_file(rec.csv_path, rec.outcome.run);
        const auto& st = rec.outcome.stats;
        say("  " + rec.sequence + ": " + rec.outcome.status + ", " + std::to_string(st.samples_complete) + " of " +
            std::to_string(st.samples_expected) + " samples, " + std::to_string(st.frames_lost) + " frames lost; raw log " + rec.log_path);
        if (result.actuator_serial.empty()) result.actuator_serial = rec.outcome.run.meta_value("ema_serial_number").value_or("");
        if (rec.outcome.valid) {
            // What the signals say before any estimate: the residual torque T_R of eq. 7 while
            // moving fast, and the current and travel the sequence took.
            const RunSummary sum = summarise(rec.outcome.run);
            std::ostringstream line;
            line.precision(4);
            line << "  " << rec.sequence << ": peak current " << sum.peak_current_a << " A, surface " << sum.min_surface_deg << " .. "
                 << sum.max_surface_deg << " deg";
            if (sum.tr_plateau_down_nm && sum.tr_plateau_up_nm)
                line << ", T_R (eq. 7) " << *sum.tr_plateau_down_nm << " N m moving down, " << *sum.tr_plateau_up_nm << " N m moving up";
            say(line.str());
            try {
                rec.estimates = estimate_run(rec.outcome.run);
            } catch (const EmadiagError& e) {
                rec.estimate_error = e.what();
                say("  " + rec.sequence + ": not estimated: " + rec.estimate_error);
            }
        }
        const bool stop = interrupt.load() || !rec.outcome.valid;
        result.runs.push_back(std::move(rec));
        if (stop) break;  // an aborted or invalid run ends the session: nothing more is commanded
    }
    result.interrupted = interrupt.load();

    std::vector<AssessedRun> assessed;
    for (const auto& r : result.runs) {
        AssessedRun a;
        a.sequence = r.sequence;
        a.valid = r.outcome.valid && r.estimate_error.empty();
        a.invalid_reason = !r.outcome.valid ? r.outcome.status + (r.outcome.invalid_reason.empty() ? "" : ": " + r.outcome.invalid_reason)
                                            : "not estimated: " + r.estimate_error;
        a.estimates = r.estimates;
        assessed.push_back(std::move(a));
    }
    if (failure) {
        result.assessment.findings = assess(assessed, options.limits).findings;
        result.assessment.verdict = Verdict::NoTest;
        result.assessment.reason = "the " + sequence_name(options.sequences[result.runs.size()]) + " sequence could not be run: " + *failure;
        if (result.runs.empty()) throw EmadiagError(*failure);  // nothing to store
    } else if (result.interrupted) {
        result.assessment.verdict = Verdict::NoTest;
        result.assessment.reason = "interrupted by the technician (Ctrl-C); the EMA was sent ABORT";
    } else {
        result.assessment = assess(assessed, options.limits);  // the loop stops early only at an invalid run: NO_TEST
    }

    s.tail_number = options.tail_number;
    s.actuator_serial = result.actuator_serial;
    s.phase = options.phase;
    s.started_utc = result.started_utc;
    s.tool_version = options.tool_version;
    s.limits_json = options.limits.to_json().dump();
    s.source = "test-run";
    std::string done;
    for (const auto& r : result.runs) {
        s.runs.push_back(to_stored(r, options.tail_number, result.started_utc));
        if (r.estimates) add_model_artifacts(s, r.estimates->model_files);
        done += (done.empty() ? "" : ", ") + r.sequence;
    }
    s.work_performed = "ground test run over CAN (" + options.phase + "): " + (done.empty() ? std::string("no sequence") : done) +
                       "; estimates (physics, network) and verdict " + std::string(to_string(result.assessment.verdict));
    set_assessment(s, result.assessment);
    const db::SessionReceipt receipt = db::store_session(database, s);
    result.db_session_id = receipt.session_id;
    result.content_sha256 = receipt.content_sha256;
    result.installation = receipt.installation;
    say("stored as test session " + std::to_string(result.db_session_id) + " of " + options.tail_number +
        (s.position ? " at " + *s.position : std::string()) + " in " + options.db_path + " (chain " + receipt.content_sha256.substr(0, 16) + ")");
    if (receipt.installation) say(describe_installation(*receipt.installation));
    if (failure) throw EmadiagError(*failure + " (the " + std::to_string(result.runs.size()) + " run(s) before it are stored as test session " +
                                    std::to_string(result.db_session_id) + ", verdict NO_TEST)");
    return result;
}

}  // namespace emadiag
