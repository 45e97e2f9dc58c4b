// The maintenance record at fleet scale (issue 11): a synthetic fleet of TAILS aircraft x 4
// positions x 2 sessions a day for DAYS days (1000 x 4 x 2 x 730 = 5.84 million sessions), each
// with the findings of a ground test (FDJ, FSJ, eta_O, eta_A from the physics estimator, with their
// limits), cycles, hours, operator, technician, a model hash and the hash chain; no runs or
// samples. Prints:
//   - the ingest rate (sessions per second, batches of kBatch sessions per transaction),
//   - the time of `report` for one tail (prognostics::build_fleet_record) and for its JSON,
//   - the time of `fleet` (prognostics::build_fleet_view from the summary tables),
//   - the bytes per session of the database file, the time to open it (with the integrity check at
//     open: the bounded one above db::Database::kFullCheckMaxBytes) and of the full check `verify` runs.
// Goals: ingest >= 10,000 sessions/s, report <= 50 ms, fleet <= 2 s.
//   fleet_scale_bench [TAILS [DAYS [DB_FILE [reuse|ingest|report]]]]   (defaults 1000, 730, fleet_scale_bench.db; CI: 5 30)
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/db/session_store.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/fleet_view.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace {

namespace db = emadiag::db;
namespace pg = emadiag::prognostics;
using Clock = std::chrono::steady_clock;

constexpr int kDefaultTails = 1000;
constexpr int kDefaultDays = 730;
constexpr int kPositions = 4;
constexpr int kSessionsPerDay = 2;
constexpr std::size_t kBatch = 20000;
constexpr int kCyclesPerDay = 6;
constexpr std::uint64_t kSeed = 11;
const char* const kPositionNames[kPositions] = {"LH-ELEV", "RH-ELEV", "LH-AIL", "RH-AIL"};
const char* const kPositionAta[kPositions] = {"27-30", "27-30", "27-10", "27-10"};

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// CPU seconds of this process (user + system): on a shared machine the wall time also counts waiting.
double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

std::string utc(int day, int half) {
    // 2025-01-01 plus day days, 06:00 or 18:00.
    const long days_since_epoch = 20089 + day;
    long z = days_since_epoch + 719468;
    const long era = (z >= 0 ? z : z - 146096) / 146097;
    const long doe = z - era * 146097;
    const long yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const long doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const long mp = (5 * doy + 2) / 153;
    const long d = doy - (153 * mp + 2) / 5 + 1;
    const long m = mp < 10 ? mp + 3 : mp - 9;
    const long y = yoe + era * 400 + (m <= 2 ? 1 : 0);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%04ld-%02ld-%02ldT%02d:00:00Z", y, m, d, half == 0 ? 6 : 18);
    return buf;
}

}  // namespace

int main(int argc, char** argv) {
    const int tails = argc > 1 ? std::atoi(argv[1]) : kDefaultTails;
    const int days = argc > 2 ? std::atoi(argv[2]) : kDefaultDays;
    const std::string path = argc > 3 ? argv[3] : "fleet_scale_bench.db";
    if (tails < 1 || days < 3) {
        std::fprintf(stderr, "usage: fleet_scale_bench [TAILS>=1 [DAYS>=3 [DB_FILE]]]\n");
        return 2;
    }
    // REUSE as 4th argument: time report and fleet on a database an earlier run built (no ingest).
    // REPORT as 4th argument: as REUSE, the report's timing only (for profiling it).
    const bool report_only = argc > 4 && std::string(argv[4]) == "report" && std::filesystem::exists(path);
    const bool reuse = argc > 4 && (std::string(argv[4]) == "reuse" || report_only) && std::filesystem::exists(path);
    // INGEST as 4th argument: the ingest only (for profiling it).
    const bool ingest_only = argc > 4 && std::string(argv[4]) == "ingest";
    std::error_code ignored;
    if (!reuse) {
        std::filesystem::remove(path, ignored);
        std::filesystem::remove(path + "-journal", ignored);
    }
    const long long total = static_cast<long long>(tails) * kPositions * kSessionsPerDay * days;
    std::printf("fleet_scale_bench: %d tails x %d positions x %d sessions/day x %d days = %lld sessions (findings only, no samples), "
                "seed %llu, %s\n",
                tails, kPositions, kSessionsPerDay, days, total, static_cast<unsigned long long>(kSeed), path.c_str());

    std::mt19937_64 rng(kSeed);
    std::normal_distribution<double> unit(0.0, 1.0);
    // Each tail/position wears at its own rate: FDJ from 0.08 N m rising 0 .. 0.01 N m per 100 days.
    std::vector<double> fdj_rate_per_day(static_cast<std::size_t>(tails) * kPositions);
    std::uniform_real_distribution<double> rate(0.0, 1e-4);
    for (auto& r : fdj_rate_per_day) r = rate(rng);
    const std::string limits = R"({"FDJ_Nm":{"max":0.12},"FSJ_Nm":{"max":0.2},"eta_O":{"min":0.7},"eta_A":{"min":0.7}})";
    const std::string model_hash = db::sha256_hex("case_a_typical.json");

    double ingest_s = 0, ingest_cpu_s = 0;
    if (!reuse) {
        db::Database database(path);
        std::vector<db::StoredTestSession> batch;
        batch.reserve(kBatch);
        const auto flush = [&] {
            const auto t0 = Clock::now();
            const double c0 = cpu_seconds();
            (void)db::store_sessions(database, batch);
            ingest_s += seconds_since(t0);
            ingest_cpu_s += cpu_seconds() - c0;
            batch.clear();
        };
        long long done = 0;
        for (int day = 0; day < days; ++day) {
            for (int half = 0; half < kSessionsPerDay; ++half) {
                const std::string started = utc(day, half);
                for (int t = 0; t < tails; ++t) {
                    char tail[16];
                    std::snprintf(tail, sizeof tail, "F-W%04d", t);
                    for (int p = 0; p < kPositions; ++p) {
                        db::StoredTestSession s;
                        s.tail_number = tail;
                        s.position = kPositionNames[p];
                        s.position_ata = kPositionAta[p];
                        char serial[24];
                        std::snprintf(serial, sizeof serial, "SN-%05d", t * kPositions + p);
                        s.actuator_serial = serial;
                        s.phase = half == 0 ? "pre-flight" : "post-flight";
                        s.started_utc = started;
                        s.cycles = static_cast<std::int64_t>(day * kCyclesPerDay + half * 3);
                        s.hours_h = static_cast<double>(*s.cycles) * 1.4;
                        s.operator_id = "EMA-AIR";
                        s.technician_name = "A. Mechanic";
                        s.technician_certificate = "B1-12345";
                        s.work_performed = "ground test run over CAN: dyn, brk";
                        s.source = "test-run";
                        s.tool_version = "0.1.0";
                        s.verdict = "SERVICEABLE";
                        s.limits_json = limits;
                        s.artifacts.push_back({"model", "models/case_a_typical.json", model_hash});
                        const double fdj = 0.08 + fdj_rate_per_day[static_cast<std::size_t>(t * kPositions + p)] * day + 0.0006 * unit(rng);
                        s.findings.push_back({"FDJ_Nm", "physics:dyn", fdj, 0.0006, 0.12, "max", "WITHIN", ""});
                        s.findings.push_back({"FSJ_Nm", "physics:brk", 0.12 + 0.0015 * unit(rng), 0.0015, 0.2, "max", "WITHIN", ""});
                        s.findings.push_back({"eta_O", "physics:dyn", 0.85 + 0.002 * unit(rng), 0.002, 0.7, "min", "WITHIN", ""});
                        s.findings.push_back({"eta_A", "physics:dyn", 0.82 + 0.002 * unit(rng), 0.002, 0.7, "min", "WITHIN", ""});
                        batch.push_back(std::move(s));
                        if (batch.size() == kBatch) flush();
                        ++done;
                    }
                }
            }
            if (days >= 20 && (day + 1) % (days / 10) == 0)
                std::printf("  day %d: %lld sessions, %.0f sessions/s so far\n", day + 1, done, static_cast<double>(done) / ingest_s);
            std::fflush(stdout);
        }
        if (!batch.empty()) flush();
    }
    const auto bytes = std::filesystem::file_size(path);
    if (!reuse)
        std::printf("ingest            : %lld sessions in %.1f s wall = %.0f sessions/s (goal >= 10000); %.1f s CPU = %.0f sessions/s per core; "
                "batches of %zu per transaction\n",
                total, ingest_s, static_cast<double>(total) / ingest_s, ingest_cpu_s, static_cast<double>(total) / ingest_cpu_s, kBatch);
    std::printf("database          : %.1f MB, %.0f bytes per session\n", static_cast<double>(bytes) / 1e6,
                static_cast<double>(bytes) / static_cast<double>(total));

    if (ingest_only) return 0;
    auto t0 = Clock::now();
    // Header check and the integrity check at open (not in REPORT mode: it profiles the report).
    db::Database database(path, db::Database::kDefaultBusyTimeoutMs, !report_only);
    std::printf("open + check      : %.2f s (%s check at open: the file is %s %.0f MB)\n", seconds_since(t0),
                bytes > db::Database::kFullCheckMaxBytes ? "bounded" : "full", bytes > db::Database::kFullCheckMaxBytes ? "above" : "within",
                static_cast<double>(db::Database::kFullCheckMaxBytes) / 1e6);

    const std::string tail = "F-W0000";
    pg::FleetRecordOptions ro;
    double best_report = 1e9, best_json = 1e9, best_report_cpu = 1e9;
    std::size_t sessions = 0;
    for (int rep = 0; rep < 3; ++rep) {
        t0 = Clock::now();
        const double c0 = cpu_seconds();
        const pg::FleetRecord record = pg::build_fleet_record(database, tail, ro);
        best_report = std::min(best_report, seconds_since(t0));
        best_report_cpu = std::min(best_report_cpu, cpu_seconds() - c0);
        sessions = record.sessions_total;
        t0 = Clock::now();
        const std::string text = pg::to_json(record).dump();
        best_json = std::min(best_json, seconds_since(t0));
    }
    std::printf("report            : %.1f ms wall, %.1f ms CPU for tail %s (%zu sessions, 4 positions + 4 serials, 4 parameters x 2 axes, "
                "%d draws) (goal <= 50 ms); its JSON %.1f ms more\n",
                best_report * 1e3, best_report_cpu * 1e3, tail.c_str(), sessions, ro.rul.draws, best_json * 1e3);
    {
        double best_load = 1e9;
        for (int rep = 0; rep < 3; ++rep) {
            const double c0 = cpu_seconds();
            const auto all = db::list_test_sessions(database, tail, db::SessionListParts{false, false, false});  // as the report loads them
            best_load = std::min(best_load, cpu_seconds() - c0);
        }
        std::printf("  of which loading the tail's sessions with their findings (no artifacts, no runs): %.1f ms CPU\n", best_load * 1e3);
    }
    if (report_only) return 0;
    pg::FleetOptions fo;
    double best_fleet = 1e9, best_fleet_cpu = 1e9;
    std::size_t rows = 0;
    for (int rep = 0; rep < 2; ++rep) {
        t0 = Clock::now();
        const double c0 = cpu_seconds();
        const auto view = pg::build_fleet_view(database, fo);
        best_fleet = std::min(best_fleet, seconds_since(t0));
        best_fleet_cpu = std::min(best_fleet_cpu, cpu_seconds() - c0);
        rows = view.size();
    }
    std::printf("fleet             : %.2f s wall, %.2f s CPU for %zu tail positions ranked (%d draws each) (goal <= 2 s)\n", best_fleet,
                best_fleet_cpu, rows, fo.rul.draws);
    t0 = Clock::now();
    const auto check = db::verify_tail(database, tail);
    std::printf("verify            : %.2f s for tail %s (%lld sessions, chain %s)\n", seconds_since(t0), tail.c_str(),
                static_cast<long long>(check.sessions_checked), check.ok() ? "intact" : "BROKEN");
    t0 = Clock::now();
    const auto problems = database.integrity_problems(db::Database::IntegrityScope::Full);
    std::printf("full check        : %.2f s (PRAGMA quick_check of every page, as `emadiag verify` runs it): %s\n", seconds_since(t0),
                problems.empty() ? "ok" : problems.front().c_str());
    return check.ok() && problems.empty() ? 0 : 1;
}
