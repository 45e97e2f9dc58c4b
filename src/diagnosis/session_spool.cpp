#include "diagnosis/session_spool.hpp"

#include "diagnosis/augmented_model_use.hpp"
#include "diagnosis/ground_test.hpp"

#include "can_tool/candump_run.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_validity.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/db/database.hpp"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

namespace emadiag {
namespace {

constexpr const char* kManifestFormat = "emadiag-session-spool-1";
/// The largest spooled raw log recover takes: a 2 kHz ground routine's candump log is a few MB.
constexpr std::uintmax_t kMaxSpooledLogBytes = std::uintmax_t{256} << 20;
/// The largest manifest recover reads (a manifest is a few KB, an augmented model's text included).
constexpr std::uintmax_t kMaxManifestBytes = std::uintmax_t{16} << 20;

/// What a spooled log named `name` (a manifest's log_path) is, checked through one open file: a
/// plain file name inside the spool directory, a regular file with one link, bounded. Absent: the
/// tool stopped before the recorder created it.
struct SpooledLogFile {
    std::filesystem::path path;
    bool absent = false;
    std::uintmax_t bytes = 0;
};
SpooledLogFile check_spooled_log(const std::filesystem::path& dir, const std::string& name) {
    const auto refuse = [&](const std::string& why) -> SpooledLogFile {
        throw EmadiagError("log_path \"" + name + "\" " + why + ": recover takes only regular files inside the spool directory " + dir.string() +
                           ", named by their file name");
    };
    if (name.empty()) refuse("is empty");
    if (name.find('/') != std::string::npos || name.find('\0') != std::string::npos || name == "." || name == "..")
        refuse(name.front() == '/' ? "is an absolute path" : "is not a plain file name (no directories, no ..)");
    SpooledLogFile f;
    f.path = dir / name;
    // O_NOFOLLOW: a symbolic link is refused, not followed; O_NONBLOCK: a FIFO does not block the open.
    const int fd = ::open(f.path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        const int e = errno;
        if (e == ENOENT) {
            f.absent = true;
            return f;
        }
        if (e == ELOOP) refuse("is a symbolic link");
        refuse(std::string("cannot be opened: ") + std::strerror(e));
    }
    struct stat st {};
    const int rc = ::fstat(fd, &st);
    ::close(fd);
    if (rc != 0) refuse("cannot be examined");
    if (!S_ISREG(st.st_mode)) refuse("is not a regular file");
    if (st.st_nlink != 1) refuse("has " + std::to_string(st.st_nlink) + " hard links (a link to a file elsewhere)");
    f.bytes = static_cast<std::uintmax_t>(st.st_size);
    if (f.bytes > kMaxSpooledLogBytes)
        refuse("holds " + std::to_string(f.bytes) + " bytes, more than the " + std::to_string(kMaxSpooledLogBytes) + " a raw log may hold");
    return f;
}

std::string compact(const std::string& iso) {
    std::string s;
    for (char c : iso)
        if (c != '-' && c != ':') s += c;
    return s;
}

/// Writes `text` to `path` so that a crash leaves either the old file or the new one (a unique
/// temporary, never a fixed name a link could be planted at: emadiag/io/output_path.hpp).
void write_atomically(const std::filesystem::path& path, const std::string& text) {
    io::write_output_file<EmadiagError>(path.string(), "session spool", {}, text);
}

nlohmann::json to_json(const SessionManifest& m) {
    nlohmann::json logs = nlohmann::json::array();
    for (const auto& l : m.logs) logs.push_back({{"sequence", l.sequence}, {"attempt", l.attempt}, {"log_path", l.log_path}});
    return {{"format", kManifestFormat}, {"tail_number", m.tail_number}, {"phase", m.phase}, {"started_utc", m.started_utc},
            {"tool_version", m.tool_version}, {"limits_json", m.limits_json}, {"sequences", m.sequences},
            {"logs", logs}, {"state", m.state}, {"record_json", m.record_json},
            {"augmented_model_path", m.augmented_model_path}, {"augmented_model_text", m.augmented_model_text}};
}

std::filesystem::path lock_path_for(const std::filesystem::path& manifest) {
    std::filesystem::path p = manifest;
    p.replace_extension(".lock");
    return p;
}

/// Opens (creating) and locks `path` without waiting; -1 when another process holds it.
int try_lock(const std::filesystem::path& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw EmadiagError(path.string() + ": cannot open the session spool lock: " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        return -1;
    }
    return fd;
}

}  // namespace

std::string record_fields_json(const db::StoredTestSession& s) {
    nlohmann::json j = nlohmann::json::object();
    if (s.position) j["position"] = *s.position;
    j["position_ata"] = s.position_ata;
    j["position_description"] = s.position_description;
    if (s.cycles) j["cycles"] = *s.cycles;
    if (s.hours_h) j["hours_h"] = *s.hours_h;
    j["operator_id"] = s.operator_id;
    j["technician_name"] = s.technician_name;
    j["technician_certificate"] = s.technician_certificate;
    nlohmann::json artifacts = nlohmann::json::array();
    for (const auto& a : s.artifacts) artifacts.push_back({{"role", a.role}, {"name", a.name}, {"sha256", a.sha256}});
    j["artifacts"] = artifacts;
    return j.dump();
}

void apply_record_fields(db::StoredTestSession& s, const std::string& record_json) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(record_json);
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(std::string("spooled record fields are not JSON: ") + e.what());
    }
    if (!j.is_object()) throw EmadiagError("spooled record fields are not a JSON object");
    auto text = [&](const char* k) { return j.contains(k) && j[k].is_string() ? j[k].get<std::string>() : std::string(); };
    if (j.contains("position") && j["position"].is_string()) s.position = j["position"].get<std::string>();
    s.position_ata = text("position_ata");
    s.position_description = text("position_description");
    if (j.contains("cycles") && j["cycles"].is_number_integer()) s.cycles = j["cycles"].get<std::int64_t>();
    if (j.contains("hours_h") && j["hours_h"].is_number()) s.hours_h = j["hours_h"].get<double>();
    s.operator_id = text("operator_id");
    s.technician_name = text("technician_name");
    s.technician_certificate = text("technician_certificate");
    if (j.contains("artifacts") && j["artifacts"].is_array())
        for (const auto& a : j["artifacts"])
            if (a.is_object() && a.contains("role") && a.contains("name") && a.contains("sha256") && a["role"].is_string() &&
                a["name"].is_string() && a["sha256"].is_string())
                s.artifacts.push_back({a["role"].get<std::string>(), a["name"].get<std::string>(), a["sha256"].get<std::string>()});
}

std::filesystem::path spool_dir_for(const std::string& db_path) { return std::filesystem::path(db_path + ".spool"); }

SessionSpool::SessionSpool(const std::filesystem::path& dir, SessionManifest manifest) : manifest_(std::move(manifest)) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw EmadiagError(dir.string() + ": cannot create the session spool directory: " + ec.message());
    path_ = dir / (manifest_.tail_number + "_" + compact(manifest_.started_utc) + "_" + manifest_.phase + ".json");
    lock_fd_ = try_lock(lock_path_for(path_));
    if (lock_fd_ < 0) throw EmadiagError(path_.string() + ": another emadiag process is recording this session");
    write();
}

SessionSpool::~SessionSpool() {
    if (lock_fd_ >= 0) ::close(lock_fd_);
}

void SessionSpool::write() const { write_atomically(path_, to_json(manifest_).dump(2) + "\n"); }

void SessionSpool::add_log(const SpooledLog& log) {
    manifest_.logs.push_back(log);
    write();
}

void SessionSpool::set_state(const std::string& state) {
    manifest_.state = state;
    write();
}

void SessionSpool::remove() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
    std::filesystem::remove(lock_path_for(path_), ec);
}

SessionManifest read_session_manifest(const std::filesystem::path& path) {
    std::error_code ec;
    const auto status = std::filesystem::symlink_status(path, ec);
    if (ec || !std::filesystem::is_regular_file(status))
        throw EmadiagError(path.string() + ": not a regular file (a symbolic link or another kind of file is never read as a manifest)");
    if (const auto bytes = std::filesystem::file_size(path, ec); !ec && bytes > kMaxManifestBytes)
        throw EmadiagError(path.string() + ": holds " + std::to_string(bytes) + " bytes, more than the " + std::to_string(kMaxManifestBytes) +
                           " a manifest may hold");
    std::ifstream in(path);
    if (!in) throw EmadiagError(path.string() + ": cannot read the spooled session");
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(path.string() + ": not a session spool manifest: " + e.what());
    }
    auto text = [&](const char* key) -> std::string {
        if (!j.contains(key) || !j[key].is_string()) throw EmadiagError(path.string() + ": field \"" + key + "\" missing or not a string");
        return j[key].get<std::string>();
    };
    if (!j.is_object() || text("format") != kManifestFormat)
        throw EmadiagError(path.string() + ": field \"format\" is not " + kManifestFormat);
    SessionManifest m;
    m.tail_number = text("tail_number");
    m.phase = text("phase");
    m.started_utc = text("started_utc");
    m.tool_version = text("tool_version");
    m.limits_json = text("limits_json");
    m.state = text("state");
    m.record_json = j.contains("record_json") && j["record_json"].is_string() ? j["record_json"].get<std::string>() : "{}";
    // Absent in manifests written before test-run --model existed: no augmented model.
    auto optional_text = [&](const char* key) {
        return j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string();
    };
    m.augmented_model_path = optional_text("augmented_model_path");
    m.augmented_model_text = optional_text("augmented_model_text");
    if (!j.contains("sequences") || !j["sequences"].is_array()) throw EmadiagError(path.string() + ": field \"sequences\" missing");
    for (const auto& s : j["sequences"]) {
        if (!s.is_string()) throw EmadiagError(path.string() + ": field \"sequences\" holds a non-string");
        m.sequences.push_back(s.get<std::string>());
    }
    if (!j.contains("logs") || !j["logs"].is_array()) throw EmadiagError(path.string() + ": field \"logs\" missing");
    for (std::size_t i = 0; i < j["logs"].size(); ++i) {
        const auto& l = j["logs"][i];
        const std::string where = path.string() + ": logs[" + std::to_string(i) + "]";
        if (!l.is_object() || !l.contains("sequence") || !l["sequence"].is_string() || !l.contains("log_path") ||
            !l["log_path"].is_string() || !l.contains("attempt") || !l["attempt"].is_number_integer())
            throw EmadiagError(where + ": needs sequence, attempt and log_path");
        m.logs.push_back(SpooledLog{l["sequence"].get<std::string>(), l["attempt"].get<int>(), l["log_path"].get<std::string>()});
    }
    return m;
}

namespace {
/// Recovers the session of one manifest (see recover_spooled_sessions); throws EmadiagError naming
/// what is wrong with it (the caller reports it and leaves the manifest in place).
void recover_one(db::Database& database, const std::filesystem::path& dir, const std::filesystem::path& path,
                 const std::function<void(const std::string&)>& say, std::vector<RecoveredSession>& out) {
    std::error_code ec;
    const SessionManifest m = read_session_manifest(path);
    // A session still being recorded by a live tool holds its lock: not ours to store.
    const int lock_fd = try_lock(lock_path_for(path));
    if (lock_fd < 0) return;
    struct Unlock {
        int fd;
        ~Unlock() { ::close(fd); }
    } unlock{lock_fd};
    RecoveredSession rs;
    rs.manifest = path;
    // Stored already (the tool stopped between storing and removing the manifest)?
    {
        db::Statement q(database, "SELECT session_id FROM test_sessions WHERE tail_number = ?1 AND phase = ?2 AND started_utc = ?3");
        q.bind(1, m.tail_number).bind(2, m.phase).bind(3, m.started_utc);
        if (q.step()) {
            rs.note = "already stored as test session " + std::to_string(q.column_int(0));
            std::filesystem::remove(path, ec);
            std::filesystem::remove(lock_path_for(path), ec);
            say("spool: " + path.filename().string() + ": " + rs.note + "; manifest removed");
            out.push_back(rs);
            return;
        }
    }
    std::vector<TestRunRecord> runs;
    std::vector<std::string> unreadable;
    // test-run --model: the spool's copy of the augmented model (checked when the session started).
    std::optional<AugmentedModelUse> model;
    std::string model_error;
    if (!m.augmented_model_text.empty()) {
        try {
            model = augmented_model_from_text(m.augmented_model_path, m.augmented_model_text);
        } catch (const std::exception& e) {
            model_error = e.what();
            say("spool: " + path.filename().string() + ": " + model_error + "; its runs are not estimated");
        }
    }
    for (const auto& l : m.logs) {
        TestRunRecord rec;
        rec.sequence = sim::parse_sequence(l.sequence);  // the manifest's text, by the one parser
        rec.attempt = l.attempt;
        rec.log_path = l.log_path;
        // Only a file inside this spool directory (never one a manifest names elsewhere: its bytes
        // would be stored and synced); checked before anything is read.
        const SpooledLogFile file = check_spooled_log(dir, l.log_path);
        rec.log_path = file.path.string();
        if (file.absent || file.bytes == 0) {
            // Killed before a single frame was written: there is nothing to keep.
            unreadable.push_back(l.sequence + " (" + l.log_path + "): " + (file.absent ? "absent" : "empty") + ", nothing recorded");
            continue;
        }
        try {
            rec.outcome.run = read_run_candump(rec.log_path);
        } catch (const std::exception& e) {
            // A log cut before the EMA identified itself holds no run, but its frames are the
            // record of what happened on the bus: stored as an invalid run with no samples.
            rec.outcome.run = Run{};
            if (!metadata_value_problem("sequence", l.sequence)) rec.outcome.run.sequence = sim::parse_sequence(l.sequence);
            rec.outcome.run.set_meta("source", "candump log");
            rec.outcome.run.set_meta("log_file", rec.log_path);
            rec.outcome.run.set_meta("status", "incomplete");
            rec.outcome.run.set_meta("valid", "false");
            rec.outcome.run.set_meta("invalid_reason", std::string("no run could be decoded from the raw log: ") + e.what());
        }
        rec.outcome.run.set_meta("tail_number", m.tail_number);
        rec.outcome.run.set_meta("phase", m.phase);
        rec.outcome.run.set_meta("recovered_from_spool", path.filename().string());
        rec.outcome.status = rec.outcome.run.meta_value("status").value_or("incomplete");
        rec.outcome.valid = rec.outcome.run.meta_value("valid").value_or("false") == "true";
        rec.outcome.invalid_reason = rec.outcome.run.meta_value("invalid_reason").value_or("");
        if (rec.outcome.valid && !model_error.empty()) rec.estimate_error = model_error;
        else if (rec.outcome.valid) session_parts::estimate(rec, model ? &*model : nullptr);
        runs.push_back(std::move(rec));
    }
    HealthLimits limits = HealthLimits::datasheet_envelope();
    try {
        limits = HealthLimits::from_json(nlohmann::json::parse(m.limits_json), path.string() + ": limits_json");
    } catch (const std::exception& e) {
        say(std::string("spool: ") + e.what() + "; judged against the datasheet envelope");
    }
    Assessment a;
    if (m.state == "recorded") {
        a = session_parts::assess_records(runs, limits);
    } else {
        a.findings = session_parts::assess_records(runs, limits).findings;
        a.verdict = Verdict::NoTest;
        a.reason = "recovered from the spool: the tool stopped mid-session (while recording " +
                   (m.logs.empty() ? std::string("nothing") : m.logs.back().sequence) + ")";
    }
    if (!unreadable.empty()) {
        a.reason += "; raw log with no frame:";
        for (const auto& u : unreadable) a.reason += " " + u;
    }
    if (runs.empty()) {
        // No frame reached any raw log: the tool stopped before it commanded anything.
        std::filesystem::remove(path, ec);
        std::filesystem::remove(lock_path_for(path), ec);
        rs.note = "nothing was recorded on the bus before the tool stopped";
        rs.nothing_recorded = true;
        say("spool: " + path.filename().string() + ": " + rs.note + " (" + a.reason + "); manifest removed");
        out.push_back(rs);
        return;
    }
    db::StoredTestSession s = session_parts::to_stored_session(m, runs, a);
    s.work_performed = "ground test run over CAN (" + m.phase + "), recovered from the spool after the tool stopped: verdict " +
                       std::string(to_string(a.verdict));
    rs.db_session_id = db::store_session(database, s).session_id;
    rs.verdict = to_string(a.verdict);
    rs.note = a.reason;
    std::filesystem::remove(path, ec);
    std::filesystem::remove(lock_path_for(path), ec);
    say("recovered spooled session " + path.filename().string() + ": stored as test session " + std::to_string(rs.db_session_id) +
        " of " + m.tail_number + ", verdict " + rs.verdict + " (" + a.reason + ")");
    out.push_back(rs);
}
}  // namespace

std::vector<RecoveredSession> recover_spooled_sessions(const std::string& db_path, const std::function<void(const std::string&)>& on_progress) {
    auto say = [&](const std::string& s) {
        if (on_progress) on_progress(s);
    };
    std::vector<RecoveredSession> out;
    const std::filesystem::path dir = spool_dir_for(db_path);
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) return out;
    std::vector<std::filesystem::path> manifests;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec))
        if (e.path().extension() == ".json") manifests.push_back(e.path());
    std::sort(manifests.begin(), manifests.end());
    if (manifests.empty()) return out;
    db::Database database(db_path);
    for (const auto& path : manifests) {
        // One bad manifest is reported and left in place; the others are still stored.
        try {
            recover_one(database, dir, path, say, out);
        } catch (const std::exception& e) {
            RecoveredSession bad;
            bad.manifest = path;
            bad.refused = true;
            bad.note = e.what();
            if (const std::string tag = "[emadiag] "; bad.note.rfind(tag, 0) == 0) bad.note.erase(0, tag.size());
            say("spool: " + path.filename().string() + ": left in place, not stored: " + bad.note);
            out.push_back(bad);
        }
    }
    return out;
}

}  // namespace emadiag
