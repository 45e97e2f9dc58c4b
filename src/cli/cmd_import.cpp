// emadiag import RUN.csv|RUN.log --tail T --position POS [--utc TIME] [--cycles N] [--hours H]
//   [--phase in-flight|load-rig] [--serial SN] [--db FILE] [--limits FILE] [--operator ID]
//   [--technician NAME --certificate NO] [--amends SESSION --reason TEXT]:
// stores a run downloaded from the aircraft (in flight, load case B) or from a load rig as a
// session of the record: the run with its raw file kept byte for byte, both estimators' results
// (in flight eta_O and eta_A are identifiable, so their trends come from here), the findings
// against the limits and the verdict, in one transaction under the tail and position.
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/record_options.hpp"
#include "cli/run_file.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_validity.hpp"
#include "diagnosis/health_limits.hpp"
#include "diagnosis/session_storage.hpp"
#include "diagnosis/verdict.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/io/text_field.hpp"
#include "estimation/run_estimator.hpp"
#include "prognostics/utc_time.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

struct ImportOptions {
    std::string file;
    std::string tail;
    std::string db = "maintenance.db";
    std::string utc;
    std::string phase = "in-flight";
    std::string serial;
    std::string limits;
    std::int64_t amends = 0;
    std::string reason;
    SessionRecordInfo record;
};

/// Largest run file import stores byte for byte: a run CSV at the reader's limit (kCsvMaxValues,
/// 2 million rows of six columns) is about 150 MB.
constexpr std::uint64_t kMaxImportFileBytes = std::uint64_t{256} << 20;

/// The file's bytes, read in chunks; a file larger than kMaxImportFileBytes is refused by its size
/// before anything is read (and if it grows while read), and only a regular file is read.
std::string read_bytes(const std::string& path) {
    std::ifstream in;
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::is_regular_file(status)) throw EmadiagError(path + ": the run file is not a regular file");
    const auto too_large = [&](std::uint64_t size) {
        return EmadiagError(path + ": the run file has " + std::to_string(size) + " bytes, more than the limit kMaxImportFileBytes = " +
                            std::to_string(kMaxImportFileBytes));
    };
    const std::uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) throw EmadiagError(path + ": cannot read the run file: " + ec.message());
    if (size > kMaxImportFileBytes) throw too_large(size);
    in.open(path, std::ios::binary);
    if (!in) throw EmadiagError(path + ": cannot read the run file");
    std::string bytes;
    bytes.reserve(size);
    char buf[65536];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        bytes.append(buf, static_cast<std::size_t>(in.gcount()));
        if (bytes.size() > kMaxImportFileBytes) throw too_large(bytes.size());
    }
    if (in.bad()) throw EmadiagError(path + ": read error on the run file");
    return bytes;
}

const bool registered = register_command(Command{
    "import", "Store a downloaded in-flight or load-rig run (both estimators, findings, verdict) under a tail and position",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<ImportOptions>();
        sub.add_option("run", o->file, "Run file: RUN.csv (run CSV) or RUN.log (candump)")->required()->check(CLI::ExistingFile);
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--db", o->db, "Maintenance database (SQLite; created if missing)")->capture_default_str()->check(sqlite_path());
        sub.add_option("--utc", o->utc, "When the run was recorded (YYYY-MM-DDThh:mm:ssZ; default: the run's started_utc key)");
        sub.add_option("--phase", o->phase, "in-flight or load-rig")->capture_default_str()->check(CLI::IsMember({"in-flight", "load-rig"}));
        sub.add_option("--serial", o->serial, "Actuator serial (default: the EMA identification in the run)");
        sub.add_option("--limits", o->limits, "Limits JSON (default: the datasheet's section-8 envelope)")->check(CLI::ExistingFile);
        sub.add_option("--amends", o->amends, "A correction: the session this import amends (with --reason)");
        sub.add_option("--reason", o->reason, "Why the amended session is corrected");
        add_record_options(sub, o->record);
        sub.get_option("--position")->required();
        return [o] {
            db::check_tail_number(o->tail);
            db::StoredTestSession s;
            set_record_info(s, o->record);  // unknown position: an error before anything is read or stored
            if ((o->amends != 0) != !o->reason.empty()) throw EmadiagError("--amends and --reason go together");
            const HealthLimits limits = o->limits.empty() ? HealthLimits::datasheet_envelope() : HealthLimits::load(o->limits);
            const std::string raw = read_bytes(o->file);
            Run run = read_run_any(o->file);
            std::string utc = !o->utc.empty() ? o->utc : run.meta_value("started_utc").value_or("");
            if (utc.empty()) throw EmadiagError(o->file + ": the run has no started_utc key; give --utc YYYY-MM-DDThh:mm:ssZ");
            (void)prognostics::parse_utc_days_or_throw(utc, "--utc");
            const std::string serial = !o->serial.empty() ? o->serial : run.meta_value("ema_serial_number").value_or("");
            io::check_text_field<EmadiagError>(!o->serial.empty() ? "--serial" : o->file + ": run metadata ema_serial_number", serial);

            // Only a complete, valid run gives a verdict (core/run_validity.hpp); any other is stored
            // with its samples and raw log, valid=false and the reason, and gives NO_TEST.
            const RunValidity validity = run_validity(run);
            AssessedRun a = assess_run(run, run.sequence, validity.valid, validity.reason);
            const Assessment verdict = assess({a}, limits);

            s.tail_number = o->tail;
            s.actuator_serial = serial;
            s.phase = o->phase;
            s.started_utc = utc;
            s.tool_version = EMADIAG_VERSION;
            s.limits_json = limits.to_json().dump();
            s.source = "import";
            s.work_performed = "imported " + o->phase + " run " + o->file + " (case " + sim::to_string(run.load_case) + ", sequence " + sim::to_string(run.sequence) +
                               "); estimates (physics, network) and verdict";
            if (o->amends != 0) {
                s.amends_session_id = o->amends;
                s.correction_reason = o->reason;
            }
            db::StoredRun stored = to_stored_run(run, o->tail, utc, a.estimates);
            stored.actuator_serial = serial;
            stored.source = "import " + o->file;
            stored.raw_log_format = ends_with(o->file, ".log") ? "candump" : "csv";
            stored.raw_log = raw;
            stored.valid = a.valid;
            stored.status_note = a.valid ? "imported" : a.invalid_reason;
            s.runs.push_back(std::move(stored));
            if (a.estimates) add_model_artifacts(s, a.estimates->model_files);
            set_assessment(s, verdict);

            db::Database database(o->db);
            const db::SessionReceipt receipt = db::store_session(database, s);
            std::cout << "emadiag import: " << io::escape_text(o->file) << " (case " << sim::to_string(run.load_case) << ", "
                      << sim::to_string(run.sequence) << ", " << run.samples.size() << " samples) -> tail " << o->tail << ", position "
                      << *s.position << ", serial " << (serial.empty() ? "?" : serial) << ", " << o->phase << ", " << io::escape_text(utc) << '\n';
            for (const auto& f : verdict.findings) {
                std::ostringstream line;
                line.precision(5);
                line << "  " << f.parameter << ' ' << to_string(f.estimator) << ' ';
                if (f.value) {
                    line << *f.value;
                    if (f.std_error) line << " +/- " << *f.std_error;
                } else {
                    line << '-';
                }
                line << "  " << to_string(f.status);
                std::cout << line.str() << '\n';
            }
            if (!a.valid) std::cout << "RUN NOT VALID: " << io::escape_text(a.invalid_reason) << "; stored with valid=false, no verdict is possible\n";
            std::cout << "verdict " << to_string(verdict.verdict) << " -- " << io::escape_text(verdict.reason) << '\n';
            if (receipt.installation) std::cout << "INSTALLATION CHANGE: " << describe_installation(*receipt.installation) << '\n';
            std::cout << "stored as session " << receipt.session_id << " in " << io::escape_text(o->db) << " (chain " << receipt.content_sha256.substr(0, 16)
                      << ")\n";
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
