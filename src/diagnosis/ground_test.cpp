#include "diagnosis/ground_test.hpp"

#include "core/run_validity.hpp"

#include "diagnosis/session_storage.hpp"

#include "can_tool/candump_run.hpp"
#include "can_tool/bus_sequence.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/run_summary.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/io/utc_now.hpp"

#include <ctime>
#include <filesystem>
#include <functional>
#include <optional>
#include <fstream>
#include <sstream>

namespace emadiag {
namespace {

using io::utc_now_iso8601;

/// 2026-11-23T01:02:03Z -> 20261123T010203Z (file names).
std::string compact(const std::string& iso) {
    std::string s;
    for (char c : iso)
        if (c != '-' && c != ':') s += c;
    return s;
}

/// An EmadiagError's text without its "[emadiag] " prefix, to be wrapped in another.
std::string without_prefix(const std::string& what) {
    const std::string prefix = "[emadiag] ";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

std::string sequence_name(can::icd::TestSequence s) { return sim::to_string(can_tool::run_sequence_of(s)); }

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
    const RunValidity v = run_validity(r.outcome.run);  // the one decision (core/run_validity.hpp), with the recorder's
    s.valid = r.outcome.valid && v.valid;
    s.status_note = !r.outcome.valid ? r.outcome.status + ": " + r.outcome.invalid_reason : v.valid ? r.outcome.status : v.reason;
    if (r.attempt > 1) s.status_note += " (attempt " + std::to_string(r.attempt) + ")";
    s.raw_log_format = "candump";
    s.raw_log = read_bytes(r.log_path);
    return s;
}

using Say = std::function<void(const std::string&)>;

/// The options checked before anything moves: the phase, the sequences (none listed twice) and the tail number.
void check_options(const TestRunOptions& options) {
    if (options.phase != kPhasePreFlight && options.phase != kPhasePostFlight)
        throw EmadiagError("phase \"" + options.phase + "\": expected " + kPhasePreFlight + " or " + kPhasePostFlight);
    if (options.sequences.empty()) throw EmadiagError("no test sequence to run");
    for (std::size_t i = 0; i < options.sequences.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (options.sequences[i] == options.sequences[j])
                throw EmadiagError("test sequence " + sequence_name(options.sequences[i]) + " is listed twice");
    db::check_tail_number(options.tail_number);
}

/// Moves the raw logs recorded in the spool directory to the output directory once the session is
/// stored (across file systems: copied, then removed from the spool) and points the runs at them.
void move_logs_out(const SessionSpool& spool, const std::filesystem::path& spool_dir, const TestRunOptions& options, TestRunResult& result,
                   const Say& say) {
    for (const auto& l : spool.manifest().logs) {
        const std::filesystem::path from = spool_dir / l.log_path, to = options.out_dir / l.log_path;
        std::error_code move_ec;
        if (!std::filesystem::exists(from, move_ec)) continue;
        std::filesystem::rename(from, to, move_ec);
        if (move_ec) {  // another file system: copy, then remove the spool's copy
            std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing, move_ec);
            if (move_ec) {
                say("raw log " + from.string() + " stays in the spool directory: it could not be moved to " + to.string() + ": " + move_ec.message());
                continue;
            }
            std::filesystem::remove(from, move_ec);
        }
        for (auto& r : result.runs)
            if (r.log_path == from.string()) r.log_path = to.string();
    }
}

/// After the recorder's error: the sequence's partial log, when it holds a run, kept as an
/// incomplete, invalid run.
void keep_partial_run(TestRunRecord& rec, const TestRunOptions& options, const std::string& log_name, const std::optional<std::string>& failure,
                      TestRunResult& result) {
    try {
        rec.outcome.run = read_run_candump(rec.log_path);
        rec.outcome.run.set_meta("log_file", (options.out_dir / log_name).string());
        rec.outcome.run.set_meta("tail_number", options.tail_number);
        rec.outcome.run.set_meta("phase", options.phase);
        rec.outcome.run.set_meta("valid", "false");
        rec.outcome.run.set_meta("invalid_reason", *failure);
        rec.outcome.status = "incomplete";
        rec.outcome.valid = false;
        rec.outcome.invalid_reason = *failure;
        result.runs.push_back(std::move(rec));
    } catch (const std::exception&) {
        // Nothing was started: the log on disk is all there is, and the error names it.
    }
}

/// The progress lines of a recorded sequence: samples and losses, the bus and the heartbeat.
void say_recording(const TestRunRecord& rec, const Say& say) {
    const auto& st = rec.outcome.stats;
    const auto& lp = rec.outcome.loop;
    std::ostringstream bus_line;
    bus_line.precision(3);
    bus_line << "  " << sim::to_string(rec.sequence) << ": bus " << lp.frames_received << " frames in " << lp.wall_s << " s ("
             << (lp.wall_s > 0 ? static_cast<double>(lp.frames_received) / lp.wall_s : 0.0) << " frames/s, "
             << lp.receive_calls << " receive calls), tool CPU "
             << (lp.frames_received > 0 ? 1e6 * lp.cpu_s / static_cast<double>(lp.frames_received) : 0.0)
             << " us/frame; heartbeat " << lp.heartbeat.sent << " sent, longest gap "
             << static_cast<double>(lp.heartbeat.max_gap.count()) / 1000.0 << " ms"
             << (lp.heartbeat.realtime ? " (SCHED_FIFO)" : " (normal priority)");
    say("  " + sim::to_string(rec.sequence) + ": " + rec.outcome.status + ", " + std::to_string(st.samples_complete) + " of " +
        std::to_string(st.samples_expected) + " samples, " + std::to_string(st.frames_lost) + " frames lost, " +
        std::to_string(st.crc_failures) + " CRC failures, " + std::to_string(st.duplicates) + " duplicates; raw log " + rec.log_path);
    say(bus_line.str());
}

/// What the signals of a valid run say before any estimate: the residual torque T_R of eq. 7 while
/// moving fast, and the current and travel the sequence took.
void say_signals(const TestRunRecord& rec, const Say& say) {
    const RunSummary sum = summarise(rec.outcome.run);
    std::ostringstream line;
    line.precision(4);
    line << "  " << sim::to_string(rec.sequence) << ": peak current " << sum.peak_current_a << " A, surface " << sum.min_surface_deg << " .. "
         << sum.max_surface_deg << " deg";
    if (sum.tr_plateau_down_nm && sum.tr_plateau_up_nm)
        line << ", T_R (eq. 7) " << *sum.tr_plateau_down_nm << " N m moving down, " << *sum.tr_plateau_up_nm << " N m moving up";
    say(line.str());
}

/// The session stored (every attempt's run, the artifacts, the work performed, the verdict), the
/// spool removed and the raw logs moved out; the receipt goes into `result`.
void store_result(std::optional<db::Database>& database, SessionSpool& spool, const std::filesystem::path& spool_dir, const TestRunOptions& options,
                  const std::optional<AugmentedModelUse>& model, TestRunResult& result, const Say& say) {
    db::StoredTestSession stored = session_parts::to_stored_session(spool.manifest(), result.runs, result.assessment);
    std::string done;
    for (const auto& r : result.runs) {
        if (r.estimates) add_model_artifacts(stored, r.estimates->model_files);
        done += (done.empty() ? "" : ", ") + sim::to_string(r.sequence);
    }
    stored.work_performed = "ground test run over CAN (" + options.phase + "): " + (done.empty() ? std::string("no sequence") : done) +
                            "; estimates (physics, network)" +
                            (model ? " on the runs corrected by the augmented model " + model->path + " (sha256 " + model->sha256 + ")"
                                   : std::string()) +
                            " and verdict " + std::string(to_string(result.assessment.verdict));
    db::SessionReceipt receipt;
    try {
        receipt = db::store_session(*database, stored);
    } catch (const std::exception& e) {
        throw EmadiagError(std::string(e.what()) + "; nothing was stored: the session stays spooled in " + spool.path().string() +
                           " and `emadiag recover --db " + options.db_path + "` (or the next test-run) stores it");
    }
    spool.remove();
    move_logs_out(spool, spool_dir, options, result, say);
    result.db_session_id = receipt.session_id;
    result.content_sha256 = receipt.content_sha256;
    result.installation = receipt.installation;
    say("stored as test session " + std::to_string(result.db_session_id) + " of " + options.tail_number +
        (stored.position ? " at " + *stored.position : std::string()) + " in " + options.db_path + " (chain " +
        receipt.content_sha256.substr(0, 16) + ")");
    if (receipt.installation) say(describe_installation(*receipt.installation));
}

}  // namespace

namespace session_parts {

void estimate(TestRunRecord& rec, const AugmentedModelUse* model) {
    try {
        rec.estimates = model != nullptr ? estimate_with_augmented_model(rec.outcome.run, *model) : estimate_run(check_run(rec.outcome.run));
    } catch (const EmadiagError& e) {
        rec.estimate_error = e.what();
    }
}

Assessment assess_records(const std::vector<TestRunRecord>& runs, const HealthLimits& limits) {
    std::vector<AssessedRun> assessed;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const auto& r = runs[i];
        // An attempt followed by a retry of the same sequence is superseded by it.
        if (i + 1 < runs.size() && runs[i + 1].sequence == r.sequence) continue;
        AssessedRun a;
        a.sequence = r.sequence;
        const RunValidity v = r.outcome.valid ? run_validity(r.outcome.run) : RunValidity{};
        a.valid = r.outcome.valid && v.valid && r.estimate_error.empty();
        a.invalid_reason = !r.outcome.valid ? r.outcome.status + (r.outcome.invalid_reason.empty() ? "" : ": " + r.outcome.invalid_reason)
                           : !v.valid       ? v.reason
                                            : "not estimated: " + r.estimate_error;
        a.estimates = r.estimates;
        assessed.push_back(std::move(a));
    }
    return assess(assessed, limits);
}

db::StoredTestSession to_stored_session(const SessionManifest& header, const std::vector<TestRunRecord>& runs, const Assessment& assessment) {
    db::StoredTestSession s;
    s.tail_number = header.tail_number;
    for (const auto& r : runs)
        if (s.actuator_serial.empty()) s.actuator_serial = r.outcome.run.meta_value("ema_serial_number").value_or("");
    s.phase = header.phase;
    s.started_utc = header.started_utc;
    s.tool_version = header.tool_version;
    s.limits_json = header.limits_json;
    s.source = "test-run";
    apply_record_fields(s, header.record_json);
    if (!header.augmented_model_path.empty()) {
        s.artifacts.push_back({"model", header.augmented_model_path, db::sha256_hex(header.augmented_model_text)});
    }
    for (const auto& r : runs) s.runs.push_back(to_stored(r, header.tail_number, header.started_utc));
    set_assessment(s, assessment);
    return s;
}

}  // namespace session_parts

can::icd::TestSequence parse_test_sequence(const std::string& name) {
    for (const auto s : {can::icd::TestSequence::Dyn, can::icd::TestSequence::Brk})
        if (name == sequence_name(s)) return s;  // exactly the printed name, as the CLI lists it
    throw EmadiagError("unknown test sequence \"" + name + "\" (expected dyn or brk)");
}

TestRunResult run_test(can::CanBus& bus, const TestRunOptions& options, const std::atomic<bool>& interrupt) {
    auto say = [&](const std::string& s) {
        if (options.on_progress) options.on_progress(s);
    };
    check_options(options);
    db::StoredTestSession s;
    set_record_info(s, options.record);  // an unknown position, bad cycles or hours: nothing moves
    // The augmented model: missing, unreadable, not a discovery model, a backlash term: nothing moves.
    std::optional<AugmentedModelUse> model;
    if (!options.augmented_model_path.empty()) model = load_augmented_model(options.augmented_model_path);
    // Open (create, migrate) the database before anything moves: a test must never end unstorable.
    std::optional<db::Database> database(std::in_place, options.db_path);
    std::error_code ec;
    std::filesystem::create_directories(options.out_dir, ec);
    if (ec) throw EmadiagError(options.out_dir.string() + ": cannot create the output directory: " + ec.message());

    TestRunResult result;
    result.augmented_model = model;
    if (model) {
        say("augmented model " + model->path + " (sha256 " + model->sha256 + "): each run is estimated with it removed: " +
            model->correction_text);
    }
    // A session an earlier run could not store (killed mid-run, database locked) goes in first.
    database.reset();
    result.recovered = recover_spooled_sessions(options.db_path, say);
    database.emplace(options.db_path);

    result.started_utc = utc_now_iso8601();
    SessionManifest manifest;
    manifest.tail_number = options.tail_number;
    manifest.phase = options.phase;
    manifest.started_utc = result.started_utc;
    manifest.tool_version = options.tool_version;
    manifest.limits_json = options.limits.to_json().dump();
    manifest.record_json = record_fields_json(s);
    if (model) {
        manifest.augmented_model_path = model->path;
        manifest.augmented_model_text = model->text;
    }
    for (const auto seq : options.sequences) manifest.sequences.push_back(sequence_name(seq));
    SessionSpool spool(spool_dir_for(options.db_path), manifest);
    // The raw logs are recorded inside the spool directory (recover takes no file from elsewhere)
    // and moved to the output directory once the session is stored.
    const std::filesystem::path spool_dir = spool.path().parent_path();
    const std::string stem_prefix = options.tail_number + "_" + compact(result.started_utc) + "_" + options.phase + "_";
    std::uint16_t session_id = options.first_session_id;
    std::optional<std::string> failure;
    std::string failed_sequence;
    // One heartbeat for the whole routine: it keeps going between sequences and while a run is
    // estimated, so the EMA never sees a tool that went quiet and no other tool finds the bus free.
    can_tool::HeartbeatSender heartbeat(bus);
    for (const auto seq : options.sequences) {
        bool stop = false;
        for (int attempt = 1; attempt <= 2; ++attempt) {
            TestRunRecord rec;
            rec.sequence = can_tool::run_sequence_of(seq);
            rec.attempt = attempt;
            const std::filesystem::path stem =
                options.out_dir / (stem_prefix + sim::to_string(rec.sequence) + (attempt > 1 ? "_attempt" + std::to_string(attempt) : std::string()));
            const std::string log_name = stem.filename().string() + ".log";
            rec.log_path = (spool_dir / log_name).string();
            rec.csv_path = stem.string() + ".csv";
            can_tool::RecorderOptions ro;
            ro.sequence = seq;
            ro.session_id = session_id++;
            ro.log_path = rec.log_path;
            ro.answer_timeout = options.answer_timeout;
            ro.shared_heartbeat = &heartbeat;
            spool.add_log(SpooledLog{sim::to_string(rec.sequence), attempt, log_name});
            say("running " + sim::to_string(rec.sequence) + (attempt > 1 ? " again" : "") + " (session " + std::to_string(ro.session_id) + ") on " +
                bus.spec());
            try {
                can_tool::Recorder recorder(bus, ro);
                rec.outcome = recorder.record(interrupt);
            } catch (const EmadiagError& e) {
                // No answer, a refusal, no GROUND_TEST, bus-off, another tool: the runs already
                // recorded are stored before the error goes to the technician, and so is this
                // sequence's partial log when it holds a run (the EMA identified itself and the
                // sequence started).
                failure = without_prefix(e.what());
                failed_sequence = sim::to_string(rec.sequence);
                stop = true;
                keep_partial_run(rec, options, log_name, failure, result);
                break;
            }
            rec.outcome.run.set_meta("tail_number", options.tail_number);
            rec.outcome.run.set_meta("phase", options.phase);
            // Where the raw log will be once the session is stored (it is recorded in the spool).
            rec.outcome.run.set_meta("log_file", (options.out_dir / log_name).string());
            write_run_csv_file(rec.csv_path, rec.outcome.run);
            say_recording(rec, say);
            if (result.actuator_serial.empty()) result.actuator_serial = rec.outcome.run.meta_value("ema_serial_number").value_or("");
            if (rec.outcome.valid) {
                say_signals(rec, say);
                session_parts::estimate(rec, model ? &*model : nullptr);
                if (!rec.estimate_error.empty()) say("  " + sim::to_string(rec.sequence) + ": not estimated: " + rec.estimate_error);
            }
            const bool retry = !rec.outcome.valid && rec.outcome.transient_loss && attempt == 1 && options.retry_transient && !interrupt.load();
            if (retry)
                say("  " + sim::to_string(rec.sequence) + ": invalid after a transient loss (" + rec.outcome.invalid_reason + "); running " + sim::to_string(rec.sequence) +
                    " once more");
            stop = interrupt.load() || (!rec.outcome.valid && !retry);
            result.runs.push_back(std::move(rec));
            if (!retry) break;
        }
        if (stop) break;  // an aborted or invalid run ends the session: nothing more is commanded
    }
    heartbeat.stop();
    result.interrupted = interrupt.load();

    if (failure) {
        result.assessment.findings = session_parts::assess_records(result.runs, options.limits).findings;
        result.assessment.verdict = Verdict::NoTest;
        result.assessment.reason = "the " + failed_sequence + " sequence could not be run: " + *failure;
        if (result.runs.empty()) {
            spool.remove();  // nothing was recorded: nothing to store
            move_logs_out(spool, spool_dir, options, result, say);
            throw EmadiagError(*failure);
        }
    } else if (result.interrupted) {
        result.assessment.verdict = Verdict::NoTest;
        result.assessment.reason = "interrupted by the technician (Ctrl-C); the EMA was sent ABORT";
    } else {
        result.assessment = session_parts::assess_records(result.runs, options.limits);  // stops early only at an invalid run: NO_TEST
    }
    spool.set_state("recorded");

    store_result(database, spool, spool_dir, options, model, result, say);
    if (failure) throw EmadiagError(*failure + " (the " + std::to_string(result.runs.size()) + " run(s) recorded are stored as test session " +
                                    std::to_string(result.db_session_id) + ", verdict NO_TEST)");
    return result;
}

}  // namespace emadiag
