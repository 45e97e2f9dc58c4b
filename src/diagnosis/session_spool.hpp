#pragma once
// The spool of a test session not yet stored: a manifest beside the maintenance database
// (DB.spool/<tail>_<utc>_<phase>.json) that names the session and its raw bus logs. test-run
// writes it before the first command and rewrites it before each sequence, so a tool killed
// outright (kill -9, a flat battery), a locked database or a full disk leaves the raw logs and
// their meaning on disk. recover_spooled_sessions() (run by the next test-run and by
// `emadiag recover`) decodes the logs again, estimates and assesses them with the same code as
// the live run, stores the session in one transaction and only then deletes the manifest.
#include "diagnosis/health_limits.hpp"

#include "emadiag/db/session_store.hpp"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace emadiag {

struct SpooledLog {
    std::string sequence;   ///< "dyn" or "brk"
    int attempt = 1;        ///< 2 for the automatic retry after a transient loss
    std::string log_path;   ///< the raw candump log: its file name inside the spool directory
};

struct SessionManifest {
    std::string tail_number;
    std::string phase;
    std::string started_utc;
    std::string tool_version;
    std::string limits_json = "{}";
    /// The record fields of the session (position, ATA reference, cycles, hours, operator, person,
    /// the position list's hash) as JSON, so a recovered session carries them too.
    std::string record_json = "{}";
    /// test-run --model: the augmented model's path and its text as read at the start (empty: none),
    /// so a recovered session is estimated with the same model and lists it with the same SHA-256.
    std::string augmented_model_path;
    std::string augmented_model_text;
    std::vector<std::string> sequences;  ///< the routine commanded, in order
    std::vector<SpooledLog> logs;        ///< every log started, in order
    /// "recording" while sequences run; "recorded" once the routine ended and only storing is left.
    std::string state = "recording";
};

/// The record fields of `session` as JSON (SessionManifest::record_json), and back.
[[nodiscard]] std::string record_fields_json(const db::StoredTestSession& session);
void apply_record_fields(db::StoredTestSession& session, const std::string& record_json);

/// DB.spool next to the database file.
[[nodiscard]] std::filesystem::path spool_dir_for(const std::string& db_path);

/// One session's manifest file. Every write is atomic (temporary file, fsync, rename). While the
/// SessionSpool lives, it holds an exclusive lock (flock) on NAME.lock beside the manifest: the
/// recovery of another process skips a session that is still being recorded; the kernel releases
/// the lock when the process dies, however it dies.
class SessionSpool {
public:
    /// Creates the spool directory if needed and writes the manifest. Throws EmadiagError naming the
    /// file when it cannot be written (the test must not start unstorable).
    SessionSpool(const std::filesystem::path& dir, SessionManifest manifest);
    void add_log(const SpooledLog& log);
    void set_state(const std::string& state);
    /// The session is stored: the manifest goes (the raw logs stay where they were written).
    void remove();
    ~SessionSpool();
    SessionSpool(const SessionSpool&) = delete;
    SessionSpool& operator=(const SessionSpool&) = delete;
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }
    [[nodiscard]] const SessionManifest& manifest() const { return manifest_; }

private:
    void write() const;
    std::filesystem::path path_;
    int lock_fd_ = -1;
    SessionManifest manifest_;
};

/// Reads a manifest; throws EmadiagError naming the file and the field.
[[nodiscard]] SessionManifest read_session_manifest(const std::filesystem::path& path);

struct RecoveredSession {
    std::filesystem::path manifest;
    std::int64_t db_session_id = 0;   ///< 0 when it was found already stored
    std::string verdict;
    std::string note;
    bool nothing_recorded = false;  ///< no frame reached a raw log: the manifest was removed, nothing stored
    bool refused = false;  ///< the manifest is bad (note says why): left in place, nothing stored
};

/// Stores every spooled session of `db_path` (oldest first). A session already in the database
/// (same tail, phase and start time) is not stored twice: its manifest is just removed. A session
/// whose tool is still running (its lock is held) is left alone. A manifest's raw logs must be
/// regular files inside the spool directory, named by their plain file name (no absolute path, no
/// directory, no .., no symbolic link, one hard link, at most 256 MiB): a manifest naming any other
/// file is never stored (its bytes would go into the database and on to the fleet server). A bad
/// manifest (unreadable, such a log, or a session the database refuses) is reported through
/// `on_progress` and returned with `refused` set, left in place, never deleted; the good ones are
/// still stored.
std::vector<RecoveredSession> recover_spooled_sessions(const std::string& db_path, const std::function<void(const std::string&)>& on_progress);

}  // namespace emadiag
