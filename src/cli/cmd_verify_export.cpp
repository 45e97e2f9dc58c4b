// emadiag verify --tail T [--db FILE] [--anchor FILE] [--expect-head HASH]: recomputes the tail's
// hash chain (every session with its runs, samples, raw logs, estimates, findings and artifacts,
// the discovery findings' chain, the installations the sessions imply), compares the chain heads
// with the anchor file and reports any change made outside the tool; exit 0 when intact, 5 when not.
// emadiag export --tail T [--db FILE] --format json|csv [--out FILE|DIR] [--no-samples]: the whole
// record of a tail in the open format of docs/record-format.md, for the operator's MRO system. JSON
// is one document; CSV is one file per table in the directory --out (required).
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/output_file.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"

#include <nlohmann/json.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

using json = nlohmann::ordered_json;
constexpr int kExitTampered = 5;
/// The database file fails the full integrity check (PRAGMA quick_check).
constexpr int kExitCorrupt = 6;
constexpr const char* kRecordSchema = "emadiag-record";
constexpr int kRecordSchemaVersion = 1;

/// RFC 4648 base64, for the raw logs (bytes as received).
std::string base64(const std::string& in) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        const unsigned v = (static_cast<unsigned char>(in[i]) << 16) | (static_cast<unsigned char>(in[i + 1]) << 8) | static_cast<unsigned char>(in[i + 2]);
        for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(v >> s) & 63];
    }
    if (i < in.size()) {
        unsigned v = static_cast<unsigned char>(in[i]) << 16;
        if (i + 1 < in.size()) v |= static_cast<unsigned char>(in[i + 1]) << 8;
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += i + 1 < in.size() ? kAlphabet[(v >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

json opt(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }
json opt(const std::optional<std::int64_t>& v) { return v ? json(*v) : json(nullptr); }
json opt(const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); }

std::string cell(const std::optional<double>& v) {
    if (!v) return "";
    std::ostringstream s;
    s << std::setprecision(17) << *v;
    return s.str();
}
std::string cell(double v) { return cell(std::optional<double>(v)); }
std::string cell(const std::optional<std::int64_t>& v) { return v ? std::to_string(*v) : ""; }

/// Writes one CSV table into `dir`, whole or not at all.
class CsvTable {
public:
    CsvTable(std::filesystem::path path, const std::string& header, io::OutputInputs inputs)
        : path_(std::move(path)), inputs_(std::move(inputs)) {
        io::check_output_path<EmadiagError>(path_.string(), "output", inputs_);  // every table checked before any is written
        text_ << header << '\n';
    }
    void row(const std::vector<std::string>& fields) {
        for (std::size_t i = 0; i < fields.size(); ++i) text_ << (i ? "," : "") << csv_field(fields[i]);
        text_ << '\n';
    }
    void write() { write_output(path_.string(), text_.str(), inputs_); }

private:
    std::filesystem::path path_;
    io::OutputInputs inputs_;
    std::ostringstream text_;
};

struct ExportOptions {
    std::string db = "maintenance.db";
    std::string tail;
    std::string format = "json";
    std::string out;
    bool no_samples = false;
};

std::vector<db::StoredTestSession> full_sessions(db::Database& database, const std::string& tail, bool samples) {
    std::vector<db::StoredTestSession> out;
    for (const auto& listed : db::list_test_sessions(database, tail)) {
        out.push_back(samples ? db::load_test_session(database, listed.session_id) : listed);
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.session_id < b.session_id; });  // chain order
    return out;
}

json export_json(db::Database& database, const std::string& tail, bool samples, const db::ChainCheck& chain) {
    json j;
    j["schema"] = kRecordSchema;
    j["version"] = kRecordSchemaVersion;
    j["tail_number"] = tail;
    j["exported_by"] = std::string("emadiag ") + EMADIAG_VERSION;
    j["chain"] = {{"sessions", chain.sessions_checked}, {"head_sha256", chain.head_sha256}, {"intact", chain.ok()}, {"problems", chain.problems}};
    j["positions"] = json::array();
    for (const auto& p : db::list_positions(database)) j["positions"].push_back({{"position", p.position}, {"ata_reference", p.ata_reference}, {"description", p.description}});
    j["sessions"] = json::array();
    for (const auto& s : full_sessions(database, tail, samples)) {
        json q;
        q["session_id"] = s.session_id;
        q["tail_number"] = s.tail_number;
        q["position"] = opt(s.position);
        q["ata_reference"] = s.position ? json(s.position_ata) : json(nullptr);
        q["actuator_serial"] = s.actuator_serial;
        q["phase"] = s.phase;
        q["started_utc"] = s.started_utc;
        q["cycles"] = opt(s.cycles);
        q["hours"] = opt(s.hours_h);
        q["operator_id"] = s.operator_id;
        q["technician_name"] = s.technician_name;
        q["technician_certificate"] = s.technician_certificate;
        q["work_performed"] = s.work_performed;
        q["source"] = s.source;
        q["tool_version"] = s.tool_version;
        q["verdict"] = s.verdict;
        q["verdict_note"] = s.verdict_note;
        q["limits"] = json::parse(s.limits_json, nullptr, false).is_discarded() ? json(s.limits_json) : json::parse(s.limits_json);
        q["limits_sha256"] = s.limits_sha256;
        q["artifacts"] = json::array();
        for (const auto& a : s.artifacts) q["artifacts"].push_back({{"role", a.role}, {"name", a.name}, {"sha256", a.sha256}});
        q["amends_session_id"] = opt(s.amends_session_id);
        q["correction_reason"] = s.correction_reason;
        q["prev_sha256"] = s.prev_sha256;
        q["content_sha256"] = s.content_sha256;
        q["findings"] = json::array();
        for (const auto& f : s.findings)
            q["findings"].push_back({{"parameter", f.parameter}, {"estimator", f.estimator}, {"value", opt(f.value)}, {"std_error", opt(f.std_error)},
                                     {"limit_kind", f.limit_kind}, {"limit_value", opt(f.limit_value)}, {"status", f.status}, {"note", f.note}});
        q["runs"] = json::array();
        for (const auto& r : s.runs) {
            json run = {{"run_id", r.run_id}, {"actuator_serial", r.actuator_serial}, {"started_utc", r.started_utc}, {"source", r.source},
                        {"load_case", r.load_case}, {"sequence", r.sequence}, {"k_t_nm_per_a", r.k_t_nm_per_a}, {"j_kgm2", r.j_kgm2},
                        {"tau", r.tau}, {"sample_period_s", r.sample_period_s}, {"valid", r.valid}, {"status_note", r.status_note},
                        {"meta", json::parse(r.meta_json, nullptr, false)}};
            run["estimates"] = json::array();
            for (const auto& e : r.estimates)
                run["estimates"].push_back({{"estimator", e.estimator}, {"parameter", e.parameter}, {"value", opt(e.value)}, {"std_error", e.std_error},
                                            {"identifiable", e.identifiable}, {"method", e.method}, {"note", e.note}});
            if (samples) {
                json cols = {{"t_s", json::array()}, {"current_a", json::array()}, {"speed_rad_s", json::array()}, {"theta_m_rad", json::array()},
                             {"hinge_moment_nm", json::array()}, {"command_deg", json::array()}};
                for (const auto& x : r.samples) {
                    cols["t_s"].push_back(x.t_s);
                    cols["current_a"].push_back(x.current_a);
                    cols["speed_rad_s"].push_back(x.speed_rad_s);
                    cols["theta_m_rad"].push_back(x.theta_m_rad);
                    cols["hinge_moment_nm"].push_back(x.hinge_moment_nm);
                    cols["command_deg"].push_back(x.command_deg);
                }
                run["samples"] = cols;
                run["raw_log"] = {{"format", r.raw_log_format}, {"sha256", db::sha256_hex(r.raw_log)}, {"base64", base64(r.raw_log)}};
            }
            q["runs"].push_back(std::move(run));
        }
        j["sessions"].push_back(std::move(q));
    }
    j["installations"] = json::array();
    for (const auto& i : db::list_installations(database, tail))
        j["installations"].push_back({{"installation_id", i.installation_id}, {"position", i.position}, {"from_serial", i.from_serial},
                                      {"to_serial", i.to_serial}, {"detected_utc", i.detected_utc}, {"cycles", opt(i.cycles)},
                                      {"hours", opt(i.hours_h)}, {"session_id", i.session_id}});
    j["discovery_findings"] = json::array();
    for (const auto& f : db::list_discovery_findings(database, tail))
        j["discovery_findings"].push_back({{"finding_id", f.finding_id}, {"position", opt(f.position)}, {"actuator_serial", f.actuator_serial},
                                           {"found_utc", f.found_utc}, {"summary", f.summary}, {"status", f.status},
                                           {"amends_finding_id", opt(f.amends_finding_id)}, {"tool_version", f.tool_version},
                                           {"model", json::parse(f.model_json, nullptr, false)}, {"content_sha256", f.content_sha256}});
    return j;
}

void export_csv(db::Database& database, const std::string& tail, bool samples, const std::filesystem::path& dir) {
    const io::OutputInputs inputs({}, {database.path()});
    struct stat st {};
    if (::lstat(dir.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
        throw EmadiagError("export directory " + dir.string() + " is not a directory (a file, a link, a device or a FIFO); refusing to write into it");
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw EmadiagError(dir.string() + ": cannot create the export directory: " + ec.message());
    CsvTable sessions(dir / "sessions.csv",
                      "session_id,tail_number,position,ata_reference,actuator_serial,phase,started_utc,cycles,hours,operator_id,technician_name,"
                      "technician_certificate,work_performed,source,tool_version,verdict,verdict_note,limits_json,limits_sha256,amends_session_id,"
                      "correction_reason,prev_sha256,content_sha256", inputs);
    CsvTable findings(dir / "findings.csv", "session_id,parameter,estimator,value,std_error,limit_kind,limit_value,status,note", inputs);
    CsvTable artifacts(dir / "artifacts.csv", "session_id,role,name,sha256", inputs);
    CsvTable runs(dir / "runs.csv",
                  "run_id,session_id,actuator_serial,started_utc,source,load_case,sequence,k_t_nm_per_a,j_kgm2,tau,sample_period_s,valid,"
                  "status_note,meta_json,raw_log_format,raw_log_sha256", inputs);
    CsvTable estimates(dir / "estimates.csv", "run_id,estimator,parameter,value,std_error,identifiable,method,note", inputs);
    CsvTable sample_rows(dir / "samples.csv", "run_id,sample_index,t_s,current_a,speed_rad_s,theta_m_rad,hinge_moment_nm,command_deg", inputs);
    for (const auto& s : full_sessions(database, tail, true)) {
        sessions.row({std::to_string(s.session_id), s.tail_number, s.position.value_or(""), s.position ? s.position_ata : "", s.actuator_serial,
                      s.phase, s.started_utc, cell(s.cycles), cell(s.hours_h), s.operator_id, s.technician_name, s.technician_certificate,
                      s.work_performed, s.source, s.tool_version, s.verdict, s.verdict_note, s.limits_json, s.limits_sha256,
                      cell(s.amends_session_id), s.correction_reason, s.prev_sha256, s.content_sha256});
        for (const auto& f : s.findings)
            findings.row({std::to_string(s.session_id), f.parameter, f.estimator, cell(f.value), cell(f.std_error), f.limit_kind, cell(f.limit_value),
                          f.status, f.note});
        for (const auto& a : s.artifacts) artifacts.row({std::to_string(s.session_id), a.role, a.name, a.sha256});
        for (const auto& r : s.runs) {
            runs.row({std::to_string(r.run_id), std::to_string(s.session_id), r.actuator_serial, r.started_utc, r.source, r.load_case, r.sequence,
                      cell(r.k_t_nm_per_a), cell(r.j_kgm2), cell(r.tau), cell(r.sample_period_s), r.valid ? "1" : "0", r.status_note, r.meta_json,
                      r.raw_log_format, db::sha256_hex(r.raw_log)});
            for (const auto& e : r.estimates)
                estimates.row({std::to_string(r.run_id), e.estimator, e.parameter, cell(e.value), cell(e.std_error), e.identifiable ? "1" : "0",
                               e.method, e.note});
            if (samples)
                for (std::size_t i = 0; i < r.samples.size(); ++i) {
                    const auto& x = r.samples[i];
                    sample_rows.row({std::to_string(r.run_id), std::to_string(i), cell(x.t_s), cell(x.current_a), cell(x.speed_rad_s),
                                     cell(x.theta_m_rad), cell(x.hinge_moment_nm), cell(x.command_deg)});
                }
        }
    }
    CsvTable installations(dir / "installations.csv", "installation_id,tail_number,position,from_serial,to_serial,detected_utc,cycles,hours,session_id", inputs);
    for (const auto& i : db::list_installations(database, tail))
        installations.row({std::to_string(i.installation_id), i.tail_number, i.position, i.from_serial, i.to_serial, i.detected_utc, cell(i.cycles),
                           cell(i.hours_h), std::to_string(i.session_id)});
    CsvTable discovery(dir / "discovery_findings.csv",
                       "finding_id,tail_number,position,actuator_serial,found_utc,summary,status,amends_finding_id,tool_version,model_json,content_sha256", inputs);
    for (const auto& f : db::list_discovery_findings(database, tail))
        discovery.row({std::to_string(f.finding_id), f.tail_number, f.position.value_or(""), f.actuator_serial, f.found_utc, f.summary, f.status,
                       cell(f.amends_finding_id), f.tool_version, f.model_json, f.content_sha256});
    CsvTable positions(dir / "positions.csv", "position,ata_reference,description", inputs);
    for (const auto& p : db::list_positions(database)) positions.row({p.position, p.ata_reference, p.description});
    for (auto* t : {&sessions, &findings, &artifacts, &runs, &estimates, &sample_rows, &installations, &discovery, &positions}) t->write();
}

void check_tail_known(db::Database& database, const std::string& tail) {
    db::check_tail_number(tail);
    db::Statement st(database, "SELECT 1 FROM aircraft WHERE tail_number = ?");
    st.bind(1, tail);
    if (!st.step()) throw EmadiagError("tail number \"" + tail + "\" is not in " + database.path());
}

/// The hex digits of a head given on the command line: 64 lowercase hex digits.
bool is_head_hash(const std::string& h) {
    return h.size() == 64 && std::all_of(h.begin(), h.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

struct VerifyOptions {
    std::string db = "maintenance.db";
    std::string tail;
    std::string anchor;       ///< empty: DB.anchor
    std::string expect_head;  ///< empty: not given
};

const bool verify_registered = register_command(Command{
    "verify", "Check a tail's hash chain: detects any change made to its record outside the tool",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<VerifyOptions>();
        sub.add_option("--db", o->db, "Maintenance database (SQLite)")->capture_default_str()->check(sqlite_file());
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--anchor", o->anchor,
                       "Anchor file to compare the chain heads with (default DB.anchor, which every store appends to; "
                       "docs/record-format.md, \"Anchoring the head\")");
        sub.add_option("--expect-head", o->expect_head,
                       "The tail's head hash as noted elsewhere (e.g. in the MRO system at the last export): exit 5 unless the "
                       "chain still holds it");
        return [o] {
            if (!o->expect_head.empty() && !is_head_hash(o->expect_head))
                throw EmadiagError("--expect-head '" + o->expect_head + "' is not a head hash: give the 64 lowercase hex digits verify or export printed");
            db::Database database(o->db, db::Database::kDefaultBusyTimeoutMs, true, db::Database::Access::ReadOnly);
            if (!o->anchor.empty()) database.set_anchor_path(o->anchor);
            check_tail_known(database, o->tail);
            db::ChainCheck c = db::verify_tail(database, o->tail);
            if (!o->expect_head.empty() && c.head_sha256 != o->expect_head) {
                // The expected head may be an earlier one: the chain must still hold it.
                bool held = false;
                db::Statement st(database, "SELECT 1 FROM test_sessions WHERE tail_number = ? AND content_sha256 = ?");
                st.bind(1, o->tail).bind(2, o->expect_head);
                held = st.step();
                if (!held)
                    c.problems.push_back("the expected head " + o->expect_head.substr(0, 16) + "... is not in the chain (its head is " +
                                         c.head_sha256.substr(0, 16) + "...): sessions were removed or the chain was rewritten outside the tool");
                else
                    c.notes.push_back("the expected head " + o->expect_head.substr(0, 16) + "... is an earlier session of the chain: sessions were added since");
            }
            // The whole file, every page: the check at open is bounded for a large file
            // (db::Database::IntegrityScope), this one is not.
            const auto t0 = std::chrono::steady_clock::now();
            const auto problems = database.integrity_problems(db::Database::IntegrityScope::Full);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::ostringstream file_line;
            file_line << "emadiag verify: database file " << escape_text(database.path()) << ": PRAGMA quick_check of every page "
                      << (problems.empty() ? "ok" : "FAILED") << " (" << std::fixed << std::setprecision(2) << seconds << " s)\n";
            const std::string covered = std::to_string(c.sessions_checked) + " sessions";
            const std::string anchor = c.anchor_path.empty() ? "no anchor compared"
                                                             : "anchor " + escape_text(c.anchor_path) + ": " + std::to_string(c.anchor_lines_checked) + " line(s) compared";
            if (c.ok()) {
                std::cout << "emadiag verify: tail " << o->tail << ": " << covered << ", hash chain intact; head " << c.head_sha256 << '\n';
            } else {
                std::cout << "emadiag verify: tail " << o->tail << ": RECORD CHANGED OUTSIDE THE TOOL (" << c.problems.size() << " problem(s) in "
                          << covered << ")\n";
                for (const auto& p : c.problems) std::cout << "  " << escape_text(p) << '\n';
            }
            std::cout << "emadiag verify: with them " << c.discovery_findings_checked << " discovery finding(s) (their own chain"
                      << (c.discovery_head_sha256.empty() ? "" : ", head " + c.discovery_head_sha256) << ") and " << c.installations_checked
                      << " installation(s) (recomputed from the sessions)\n";
            std::cout << "emadiag verify: " << anchor << '\n';
            for (const auto& n : c.notes) std::cout << "  note: " << n << '\n';
            std::cout << file_line.str();
            for (const auto& p : problems) std::cout << "  " << escape_text(p) << '\n';
            if (!c.ok()) return kExitTampered;
            return problems.empty() ? 0 : kExitCorrupt;
        };
    }});

const bool export_registered = register_command(Command{
    "export", "Export the whole record of a tail (JSON, or CSV tables) in the open format of docs/record-format.md",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<ExportOptions>();
        sub.add_option("--db", o->db, "Maintenance database (SQLite)")->capture_default_str()->check(sqlite_file());
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--format", o->format, "json (one document) or csv (one file per table in --out DIR)")
            ->capture_default_str()
            ->check(CLI::IsMember({"json", "csv"}));
        sub.add_option("--out", o->out, "JSON: the file (default stdout); CSV: the directory (required)");
        sub.add_flag("--no-samples", o->no_samples, "Leave out the 2 kHz samples and raw logs (their hashes stay)");
        return [o] {
            db::Database database(o->db, db::Database::kDefaultBusyTimeoutMs, true, db::Database::Access::ReadOnly);
            check_tail_known(database, o->tail);
            if (o->format == "csv") {
                if (o->out.empty()) throw EmadiagError("--format csv writes one file per table: give --out DIR");
                export_csv(database, o->tail, !o->no_samples, o->out);
                const db::ChainCheck chain = db::verify_tail(database, o->tail);
                std::cout << "exported the record of " << o->tail << " to " << escape_text(o->out) << "/ (sessions, findings, artifacts, runs, estimates, samples, "
                          << "installations, discovery_findings, positions .csv)\n";
                std::cout << "head " << chain.head_sha256 << " (" << chain.sessions_checked << " sessions, chain "
                          << (chain.ok() ? "intact" : "BROKEN: run emadiag verify") << "): note it to check later with emadiag verify --expect-head\n";
                return chain.ok() ? 0 : kExitTampered;
            }
            const db::ChainCheck chain = db::verify_tail(database, o->tail);
            write_output(o->out, export_json(database, o->tail, !o->no_samples, chain).dump(1) + "\n", io::OutputInputs({}, {o->db}));
            // The head, where a person sees it (on stdout the document itself holds it: chain.head_sha256).
            if (!o->out.empty())
                std::cout << "head " << chain.head_sha256 << " (" << chain.sessions_checked << " sessions, chain "
                          << (chain.ok() ? "intact" : "BROKEN: run emadiag verify") << "): note it to check later with emadiag verify --expect-head\n";
            return chain.ok() ? 0 : kExitTampered;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
