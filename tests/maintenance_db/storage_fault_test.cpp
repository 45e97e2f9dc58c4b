// The maintenance database under faults (issue 12 part 3; the table is in tests/README.md,
// "Storage faults"): a writer killed with SIGKILL at random points, two writers at once, a full disk
// and an I/O error at every write of a transaction (a VFS shim over SQLite's own), a corrupt or
// truncated file, a read-only file. After each: PRAGMA integrity_check is "ok" and every session
// is whole (its two runs with all their samples, raw logs, estimates and its findings) or absent.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/session_store.hpp"

#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

namespace fs = std::filesystem;
using namespace emadiag;
using ::testing::HasSubstr;

namespace {

constexpr int kSamplesPerRun = 2000;
constexpr int kFindingsPerSession = 3;

db::StoredTestSession example_session(int i, const std::string& tail = "F-WEMA") {
    db::StoredTestSession s;
    s.tail_number = tail;
    s.actuator_serial = "SN-0042";
    s.phase = "pre-flight";
    s.started_utc = "2026-11-22T20:00:" + std::string(i % 60 < 10 ? "0" : "") + std::to_string(i % 60) + "Z";
    s.tool_version = "storage-fault-test";
    s.verdict = "SERVICEABLE";
    s.limits_json = "{\"FDJ_Nm\":{\"max\":0.096}}";
    for (const char* seq : {"dyn", "brk"}) {
        db::StoredRun r = test::example_stored_run(seq, s.tail_number);
        r.samples.clear();
        for (int k = 0; k < kSamplesPerRun; ++k) r.samples.push_back({5e-4 * (k + 1), 0.1 * k, -3.0, 0.01 * k, 5.0, -0.1 * i});
        s.runs.push_back(r);
    }
    for (int f = 0; f < kFindingsPerSession; ++f) {
        db::StoredFinding x;
        x.parameter = f == 0 ? "FDJ_Nm" : f == 1 ? "FSJ_Nm" : "eta_A";
        x.estimator = "physics";
        x.value = 0.08;
        x.std_error = 0.001;
        x.limit_kind = "max";
        x.limit_value = 0.096;
        x.status = "WITHIN";
        s.findings.push_back(x);
    }
    return s;
}

/// Opens with plain SQLite (not emadiag::db, so no recovery logic of ours is involved).
struct RawDb {
    explicit RawDb(const std::string& path) {
        if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) throw std::runtime_error(sqlite3_errmsg(db));
    }
    ~RawDb() { sqlite3_close(db); }
    std::string text(const std::string& sql) const {
        sqlite3_stmt* st = nullptr;
        if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) return std::string("prepare failed: ") + sqlite3_errmsg(db);
        std::string out;
        int rc;
        while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
            if (!out.empty()) out += "\n";
            const unsigned char* t = sqlite3_column_text(st, 0);
            out += t ? reinterpret_cast<const char*>(t) : "NULL";
        }
        if (rc != SQLITE_DONE) out += std::string("step failed: ") + sqlite3_errmsg(db);
        sqlite3_finalize(st);
        return out;
    }
    sqlite3* db = nullptr;
};

/// integrity_check is ok and every session is whole; returns the number of sessions.
int check_database(const std::string& path) {
    RawDb raw(path);
    EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok") << path;
    EXPECT_EQ(raw.text("PRAGMA foreign_key_check"), "") << path;
    const std::string bad = raw.text(
        "SELECT s.session_id FROM test_sessions s WHERE "
        " (SELECT COUNT(*) FROM runs r WHERE r.session_id = s.session_id) != 2"
        " OR (SELECT COUNT(*) FROM findings f WHERE f.session_id = s.session_id) != " + std::to_string(kFindingsPerSession) +
        " OR EXISTS (SELECT 1 FROM runs r WHERE r.session_id = s.session_id AND"
        "   ((SELECT COUNT(*) FROM samples m WHERE m.run_id = r.run_id) != " + std::to_string(kSamplesPerRun) +
        "    OR (SELECT COUNT(*) FROM raw_logs l WHERE l.run_id = r.run_id) != 1"
        "    OR (SELECT COUNT(*) FROM estimates e WHERE e.run_id = r.run_id) != 2))");
    EXPECT_EQ(bad, "") << "partial sessions in " << path;
    const std::string orphans = raw.text("SELECT COUNT(*) FROM runs WHERE session_id IS NULL");
    EXPECT_EQ(orphans, "0") << "runs outside a session in " << path;
    return std::stoi(raw.text("SELECT COUNT(*) FROM test_sessions"));
}

class StorageFaults : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("emadiag-storage-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        path_ = (dir_ / "maintenance.db").string();
    }
    void TearDown() override { fs::remove_all(dir_); }
    fs::path dir_;
    std::string path_;
};

// ---------------------------------------------------------------- kill -9
TEST_F(StorageFaults, WriterKilledAtRandomPointsFiftyTimesLeavesWholeSessionsOnly) {
    { db::Database init(path_); }
    // The kill window spans a few stores as this build runs them (a sanitizer build with coverage
    // stores several times slower than a release build): from 5 ms to 4 times the time of an open
    // and two stores, at least 120 ms.
    int window_us = 120000;
    {
        const auto t0 = std::chrono::steady_clock::now();
        db::Database timing((dir_ / "timing.db").string());
        (void)db::store_test_session(timing, example_session(0));
        (void)db::store_test_session(timing, example_session(1));
        const auto us = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0).count();
        window_us = std::max(window_us, static_cast<int>(4 * us));
    }
    std::mt19937 rng(12);
    int sessions_before = 0, hot_journals = 0;
    for (int kill = 0; kill < 50; ++kill) {
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            try {
                // A tail per kill: each store verifies its tail's chain first (a few sessions here),
                // so the kill window stays one of writes, as the timing above measured.
                db::Database d(path_);
                const std::string tail = "F-K" + std::to_string(kill);
                for (int i = 0;; ++i) (void)db::store_test_session(d, example_session(i, tail));
            } catch (...) {
            }
            ::_exit(3);
        }
        std::this_thread::sleep_for(std::chrono::microseconds(std::uniform_int_distribution<int>(5000, window_us)(rng)));
        ::kill(pid, SIGKILL);
        int status = 0;
        ::waitpid(pid, &status, 0);
        ASSERT_TRUE(WIFSIGNALED(status)) << "the writer ended by itself (status " << status << ") before kill " << kill;
        if (fs::exists(path_ + "-journal") && fs::file_size(path_ + "-journal") > 0) ++hot_journals;
        const int sessions = check_database(path_);  // rolls a hot journal back first (SQLite's own recovery)
        EXPECT_GE(sessions, sessions_before) << "a committed session was lost at kill " << kill;
        sessions_before = sessions;
        if (::testing::Test::HasFailure()) break;
    }
    std::cout << "50 kills over 5 to " << window_us / 1000 << " ms: " << sessions_before << " whole sessions stored, " << hot_journals
              << " kills interrupted a transaction (hot journal left behind)\n";
    EXPECT_GT(sessions_before, 0);
    EXPECT_GT(hot_journals, 10) << "too few kills hit a transaction to show anything";
    db::Database again(path_);  // the emadiag open (quick_check) accepts it and it takes more
    (void)db::store_test_session(again, example_session(99));
}

// ---------------------------------------------------------------- two writers
TEST_F(StorageFaults, TwoWritersAtOnceBothStoreEverySession) {
    { db::Database init(path_); }
    constexpr int kEach = 15;
    pid_t pids[2];
    for (int w = 0; w < 2; ++w) {
        pids[w] = ::fork();
        ASSERT_GE(pids[w], 0);
        if (pids[w] == 0) {
            try {
                db::Database d(path_);
                for (int i = 0; i < kEach; ++i) (void)db::store_test_session(d, example_session(w * 100 + i));
            } catch (const std::exception& e) {
                std::cerr << "writer " << w << ": " << e.what() << "\n";
                ::_exit(1);
            }
            ::_exit(0);
        }
    }
    for (pid_t pid : pids) {
        int status = 0;
        ::waitpid(pid, &status, 0);
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a writer failed (busy timeout?)";
    }
    EXPECT_EQ(check_database(path_), 2 * kEach);
}

// ---------------------------------------------------------------- VFS shim: full disk, I/O error
// A VFS over the default one whose writes fail: with SQLITE_FULL once `budget` bytes have been
// written (a full disk), or with SQLITE_IOERR_WRITE from the Nth write on (a failing medium).
struct Faults {
    long long budget = -1;   ///< bytes writable before SQLITE_FULL; -1: unlimited
    int fail_from_write = 0; ///< 1-based write index from which writes fail with IOERR; 0: never
    long long written = 0;
    int writes = 0;
    int failures = 0;
};
Faults g_faults;
sqlite3_vfs* g_real = nullptr;

struct ShimFile {
    sqlite3_file base;
    sqlite3_file* real;
};

int shim_close(sqlite3_file* f) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    return s->real->pMethods ? s->real->pMethods->xClose(s->real) : SQLITE_OK;
}
int shim_read(sqlite3_file* f, void* p, int n, sqlite3_int64 off) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    return s->real->pMethods->xRead(s->real, p, n, off);
}
int shim_write(sqlite3_file* f, const void* p, int n, sqlite3_int64 off) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    ++g_faults.writes;
    if (g_faults.fail_from_write > 0 && g_faults.writes >= g_faults.fail_from_write) {
        ++g_faults.failures;
        return SQLITE_IOERR_WRITE;
    }
    if (g_faults.budget >= 0 && g_faults.written + n > g_faults.budget) {
        ++g_faults.failures;
        return SQLITE_FULL;
    }
    g_faults.written += n;
    return s->real->pMethods->xWrite(s->real, p, n, off);
}
int shim_truncate(sqlite3_file* f, sqlite3_int64 size) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    return s->real->pMethods->xTruncate(s->real, size);
}
int shim_sync(sqlite3_file* f, int flags) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    return s->real->pMethods->xSync(s->real, flags);
}
int shim_file_size(sqlite3_file* f, sqlite3_int64* size) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    return s->real->pMethods->xFileSize(s->real, size);
}
int shim_lock(sqlite3_file* f, int l) { return reinterpret_cast<ShimFile*>(f)->real->pMethods->xLock(reinterpret_cast<ShimFile*>(f)->real, l); }
int shim_unlock(sqlite3_file* f, int l) {
    return reinterpret_cast<ShimFile*>(f)->real->pMethods->xUnlock(reinterpret_cast<ShimFile*>(f)->real, l);
}
int shim_check_reserved(sqlite3_file* f, int* out) {
    return reinterpret_cast<ShimFile*>(f)->real->pMethods->xCheckReservedLock(reinterpret_cast<ShimFile*>(f)->real, out);
}
int shim_file_control(sqlite3_file* f, int op, void* arg) {
    return reinterpret_cast<ShimFile*>(f)->real->pMethods->xFileControl(reinterpret_cast<ShimFile*>(f)->real, op, arg);
}
int shim_sector_size(sqlite3_file* f) { return reinterpret_cast<ShimFile*>(f)->real->pMethods->xSectorSize(reinterpret_cast<ShimFile*>(f)->real); }
int shim_device(sqlite3_file* f) {
    return reinterpret_cast<ShimFile*>(f)->real->pMethods->xDeviceCharacteristics(reinterpret_cast<ShimFile*>(f)->real);
}

const sqlite3_io_methods kShimMethods = {1,           shim_close, shim_read,      shim_write,        shim_truncate,
                                         shim_sync,   shim_file_size, shim_lock,  shim_unlock,       shim_check_reserved,
                                         shim_file_control, shim_sector_size, shim_device, nullptr, nullptr, nullptr, nullptr,
                                         nullptr,     nullptr};

int shim_open(sqlite3_vfs*, sqlite3_filename name, sqlite3_file* f, int flags, int* out_flags) {
    auto* s = reinterpret_cast<ShimFile*>(f);
    s->real = reinterpret_cast<sqlite3_file*>(s + 1);
    s->base.pMethods = nullptr;
    const int rc = g_real->xOpen(g_real, name, s->real, flags, out_flags);
    if (rc == SQLITE_OK) s->base.pMethods = &kShimMethods;
    return rc;
}
int shim_delete(sqlite3_vfs*, const char* n, int sync) { return g_real->xDelete(g_real, n, sync); }
int shim_access(sqlite3_vfs*, const char* n, int flags, int* out) { return g_real->xAccess(g_real, n, flags, out); }
int shim_full_pathname(sqlite3_vfs*, const char* n, int size, char* out) { return g_real->xFullPathname(g_real, n, size, out); }
int shim_randomness(sqlite3_vfs*, int n, char* out) { return g_real->xRandomness(g_real, n, out); }
int shim_sleep(sqlite3_vfs*, int us) { return g_real->xSleep(g_real, us); }
int shim_current_time(sqlite3_vfs*, double* t) { return g_real->xCurrentTime(g_real, t); }
int shim_last_error(sqlite3_vfs*, int n, char* out) { return g_real->xGetLastError(g_real, n, out); }

/// Makes the shim the default VFS for the scope (emadiag::db::Database opens with the default).
struct ShimScope {
    ShimScope() {
        g_real = sqlite3_vfs_find(nullptr);
        vfs.iVersion = 1;
        vfs.szOsFile = static_cast<int>(sizeof(ShimFile)) + g_real->szOsFile;
        vfs.mxPathname = g_real->mxPathname;
        vfs.zName = "emadiag-fault-shim";
        vfs.xOpen = shim_open;
        vfs.xDelete = shim_delete;
        vfs.xAccess = shim_access;
        vfs.xFullPathname = shim_full_pathname;
        vfs.xDlOpen = nullptr;
        vfs.xDlError = nullptr;
        vfs.xDlSym = nullptr;
        vfs.xDlClose = nullptr;
        vfs.xRandomness = shim_randomness;
        vfs.xSleep = shim_sleep;
        vfs.xCurrentTime = shim_current_time;
        vfs.xGetLastError = shim_last_error;
        sqlite3_vfs_register(&vfs, 1);
        g_faults = Faults{};
    }
    ~ShimScope() {
        sqlite3_vfs_unregister(&vfs);
        sqlite3_vfs_register(g_real, 1);
    }
    sqlite3_vfs vfs{};
};

TEST_F(StorageFaults, FullDiskFailsTheSessionCleanlyAndKeepsEarlierOnes) {
    { db::Database init(path_); }
    {
        db::Database d(path_);
        (void)db::store_test_session(d, example_session(0));
    }
    // Disk full after 20 kB more: the next session (about 200 kB) cannot be written.
    {
        ShimScope shim;
        g_faults.budget = 20000;
        db::Database d(path_);
        EXPECT_THAT([&] { (void)db::store_test_session(d, example_session(1)); },
                    ::testing::ThrowsMessage<db::DbError>(HasSubstr("database or disk is full")));
        EXPECT_GT(g_faults.failures, 0);
    }
    EXPECT_EQ(check_database(path_), 1);
    // Space freed: the same session is stored.
    {
        db::Database d(path_);
        (void)db::store_test_session(d, example_session(1));
    }
    EXPECT_EQ(check_database(path_), 2);
}

TEST_F(StorageFaults, IoErrorAtEveryWriteOfATransactionNeverLeavesAPartialSession) {
    { db::Database init(path_); }
    {
        db::Database d(path_);
        (void)db::store_test_session(d, example_session(0));
    }
    const fs::path pristine = dir_ / "pristine.db";
    fs::copy_file(path_, pristine);
    // Count the writes of one session, then fail the Nth for every N (as SQLite's own ioerr tests).
    int total_writes = 0;
    {
        ShimScope shim;
        db::Database d(path_);
        const int before = g_faults.writes;
        (void)db::store_test_session(d, example_session(1));
        total_writes = g_faults.writes - before;
    }
    ASSERT_GT(total_writes, 5);
    int failed = 0;
    for (int n = 1; n <= total_writes + 1; ++n) {
        fs::copy_file(pristine, path_, fs::copy_options::overwrite_existing);
        fs::remove(path_ + "-journal");
        bool stored = false;
        {
            ShimScope shim;
            try {
                db::Database d(path_);
                g_faults.writes = 0;
                g_faults.fail_from_write = n;
                (void)db::store_test_session(d, example_session(1));
                stored = true;
            } catch (const db::DbError& e) {
                EXPECT_THAT(e.what(), HasSubstr("disk I/O error")) << "write " << n;
                ++failed;
            }
        }
        // After the medium recovers: the old session is intact, the new one whole or absent.
        const int sessions = check_database(path_);
        EXPECT_EQ(sessions, stored ? 2 : 1) << "I/O error at write " << n << " of " << total_writes;
        if (::testing::Test::HasFailure()) break;
    }
    std::cout << "I/O error injected at each of " << total_writes << " writes: " << failed << " sessions refused cleanly\n";
    EXPECT_GE(failed, total_writes - 1);
}

TEST_F(StorageFaults, IoErrorAtEveryWriteOfANewFileLeavesItEmptyOrAtTheNewestVersion) {
    // A new file passes every schema step; a kill -9 or an I/O error on the way must leave it with
    // no schema at all or the newest one, never a middle version (a version-1 file with no
    // test_sessions table was once seen after a kill -9 of the first import).
    int total_writes = 0;
    int newest = 0;
    {
        ShimScope shim;
        const int before = g_faults.writes;
        db::Database d(path_);
        total_writes = g_faults.writes - before;
        newest = d.schema_version();
    }
    ASSERT_GT(total_writes, 2);
    int failed = 0;
    for (int n = 1; n <= total_writes + 1; ++n) {
        fs::remove(path_);
        fs::remove(path_ + "-journal");
        {
            ShimScope shim;
            try {
                g_faults.writes = 0;
                g_faults.fail_from_write = n;
                db::Database d(path_);
            } catch (const db::DbError& e) {
                EXPECT_THAT(e.what(), HasSubstr("disk I/O error")) << "write " << n;
                ++failed;
            }
        }
        RawDb raw(path_);
        EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok") << "write " << n;
        const std::string version = raw.text("PRAGMA user_version");
        const std::string tables = raw.text("SELECT COUNT(*) FROM sqlite_schema");
        if (version == "0") {
            EXPECT_EQ(tables, "0") << "a version-0 file with tables after an I/O error at write " << n;
        } else {
            EXPECT_EQ(version, std::to_string(newest)) << "a middle schema version after an I/O error at write " << n;
            EXPECT_EQ(raw.text("SELECT COUNT(*) FROM test_sessions"), "0") << "write " << n;
        }
        if (::testing::Test::HasFailure()) break;
    }
    std::cout << "I/O error injected at each of " << total_writes << " writes of a new file: " << failed
              << " refused cleanly, none left at a middle version\n";
    EXPECT_GE(failed, total_writes - 1);
}

// ---------------------------------------------------------------- corrupt, truncated, read-only
std::string file_bytes(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_F(StorageFaults, NotADatabaseIsRefusedAndNeverWritten) {
    {
        std::ofstream out(path_, std::ios::binary);
        for (int i = 0; i < 8192; ++i) out.put(static_cast<char>((i * 7919) & 0xFF));
    }
    const std::string before = file_bytes(path_);
    EXPECT_THAT([&] { db::Database d(path_); },
                ::testing::ThrowsMessage<db::DbError>(AllOf(HasSubstr("corrupt or truncated"), HasSubstr(path_))));
    EXPECT_EQ(file_bytes(path_), before);
}

TEST_F(StorageFaults, TruncatedDatabaseIsRefusedAndNeverWritten) {
    {
        db::Database d(path_);
        for (int i = 0; i < 3; ++i) (void)db::store_test_session(d, example_session(i));
    }
    fs::resize_file(path_, fs::file_size(path_) / 2);
    const std::string before = file_bytes(path_);
    EXPECT_THAT([&] { db::Database d(path_); },
                ::testing::ThrowsMessage<db::DbError>(AllOf(HasSubstr("corrupt or truncated"), HasSubstr("not opened"))));
    EXPECT_EQ(file_bytes(path_), before);
}

TEST_F(StorageFaults, CorruptPageIsRefusedAndNeverWritten) {
    {
        db::Database d(path_);
        for (int i = 0; i < 3; ++i) (void)db::store_test_session(d, example_session(i));
    }
    std::string bytes = file_bytes(path_);
    const std::size_t page = 4096;
    ASSERT_GT(bytes.size(), 8 * page);
    for (std::size_t k = 0; k < 64; ++k) bytes[5 * page + k] = static_cast<char>(0xA5);  // a b-tree page header
    {
        std::ofstream out(path_, std::ios::binary | std::ios::trunc);
        out << bytes;
    }
    EXPECT_THAT([&] { db::Database d(path_); }, ::testing::ThrowsMessage<db::DbError>(HasSubstr("corrupt or truncated")));
    EXPECT_EQ(file_bytes(path_), bytes);
}

// The bounded check at open (a file above Database::kFullCheckMaxBytes; called here directly on a
// small file): it finds a truncated file and a corrupt page of a table updated in place; a corrupt
// page of a large append-only table it does not read is found by the write that meets it (cell
// size check on), which fails and leaves the file as it was; the full check finds both.
std::int64_t root_page(const std::string& path, const std::string& table) {
    RawDb raw(path);
    return std::stoll(raw.text("SELECT rootpage FROM sqlite_schema WHERE name = '" + table + "'"));
}

void smash_page(const std::string& path, std::int64_t page) {
    std::string bytes = file_bytes(path);
    const std::size_t at = static_cast<std::size_t>(page - 1) * 4096;
    ASSERT_LT(at + 64, bytes.size());
    for (std::size_t k = 0; k < 64; ++k) bytes[at + k] = static_cast<char>(0xA5);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << bytes;
}

TEST_F(StorageFaults, BoundedOpenCheckFindsATruncatedFile) {
    {
        db::Database d(path_);
        for (int i = 0; i < 3; ++i) (void)db::store_test_session(d, example_session(i));
    }
    fs::resize_file(path_, fs::file_size(path_) - 4096);
    const std::string before = file_bytes(path_);
    // Opened without the check at open, SQLite itself may already refuse the file (it compares the
    // header's page count with the file); else the bounded check names the truncation.
    std::vector<std::string> problems;
    try {
        db::Database d(path_, db::Database::kDefaultBusyTimeoutMs, false);
        problems = d.integrity_problems(db::Database::IntegrityScope::Open);
        ASSERT_FALSE(problems.empty());
        EXPECT_THAT(problems.front(), HasSubstr("truncated"));
    } catch (const db::DbError& e) {
        EXPECT_EQ(e.kind(), db::DbErrorKind::Corrupt) << e.what();
    }
    // And the normal open refuses it.
    EXPECT_THAT([&] { db::Database d(path_); }, ::testing::ThrowsMessage<db::DbError>(HasSubstr("corrupt or truncated")));
    EXPECT_EQ(file_bytes(path_), before);
}

TEST_F(StorageFaults, BoundedOpenCheckFindsACorruptSummaryPage) {
    {
        db::Database d(path_);
        for (int i = 0; i < 3; ++i) (void)db::store_test_session(d, example_session(i));
        EXPECT_TRUE(d.integrity_problems(db::Database::IntegrityScope::Open).empty());
    }
    smash_page(path_, root_page(path_, "series_stats"));
    db::Database d(path_, db::Database::kDefaultBusyTimeoutMs, false);
    std::vector<std::string> problems;
    try {
        problems = d.integrity_problems(db::Database::IntegrityScope::Open);
    } catch (const db::DbError& e) {
        problems.push_back(e.what());  // SQLITE_CORRUPT on reading the page is a finding too
    }
    EXPECT_FALSE(problems.empty());
}

TEST_F(StorageFaults, ACorruptAppendOnlyPageFailsTheWriteThatMeetsItAndTheFullCheckFindsIt) {
    {
        db::Database d(path_);
        for (int i = 0; i < 3; ++i) (void)db::store_test_session(d, example_session(i));
    }
    smash_page(path_, root_page(path_, "findings"));
    const std::string before = file_bytes(path_);
    db::Database d(path_, db::Database::kDefaultBusyTimeoutMs, false);
    EXPECT_TRUE(d.integrity_problems(db::Database::IntegrityScope::Open).empty());  // not read at open
    EXPECT_THAT([&] { (void)db::store_test_session(d, example_session(7)); },
                ::testing::ThrowsMessage<db::DbError>(HasSubstr("corrupt")));
    EXPECT_EQ(file_bytes(path_), before);
    std::vector<std::string> full;
    try {
        full = d.integrity_problems(db::Database::IntegrityScope::Full);
    } catch (const db::DbError& e) {
        full.push_back(e.what());
    }
    EXPECT_FALSE(full.empty());
}

TEST_F(StorageFaults, ReadOnlyDatabaseIsAClearError) {
    {
        db::Database d(path_);
        (void)db::store_test_session(d, example_session(0));
    }
    fs::permissions(path_, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
    fs::permissions(dir_, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                              fs::perms::others_exec);
    const std::string before = file_bytes(path_);
    // root writes any file: test as an unprivileged user then (nobody), in a child process.
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(4);
        try {
            db::Database d(path_);
            ::_exit(1);  // opened: wrong
        } catch (const db::DbError& e) {
            const std::string m = e.what();
            ::_exit(m.find("is read-only") != std::string::npos && m.find(path_) != std::string::npos ? 0 : 2);
        } catch (...) {
            ::_exit(3);
        }
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << "1: opened for writing, 2: other message, 3: other exception, 4: setuid failed";
    EXPECT_EQ(file_bytes(path_), before);
}

}  // namespace
