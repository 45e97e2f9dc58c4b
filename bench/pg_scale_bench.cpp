// The fleet server at fleet scale (issue 13): a station file of the synthetic fleet (built by
// fleet_scale_bench: 1000 tails x 4 positions x 2 sessions a day x 2 years = 5.84 million sessions
// with findings, no samples) synced to PostgreSQL, then the reports read from the server. Prints:
//   - the sync rate (sessions per second; whole sessions per transaction, COPY),
//   - the time of `fleet` (prognostics::build_fleet_view from the server's summary tables),
//   - the time of `report` for one tail (prognostics::build_fleet_record from the server),
//   - the server's database size, total and per session.
// Goals: sync >= 5,000 sessions/s, fleet <= 2 s, report <= 50 ms.
//   pg_scale_bench STATION_DB STATION_URI [BATCH [TAIL [OWNER_URI]]]   (scripts/pg/run_pg_bench.sh runs it on a temporary server;
//   with OWNER_URI the tables are ANALYZEd after the sync, as autovacuum would on a running server)
#include "emadiag/db/database.hpp"
#include "emadiag/db/pg_fleet.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/fleet_view.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

namespace db = emadiag::db;
namespace pg = emadiag::prognostics;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: pg_scale_bench STATION_DB STATION_URI [BATCH [TAIL]]\n");
        return 2;
    }
    const std::string station_path = argv[1], uri = argv[2];
    const std::size_t batch = argc > 3 ? static_cast<std::size_t>(std::atol(argv[3])) : 10000;
    const std::string tail = argc > 4 ? argv[4] : "F-W0000";
    const std::string owner_uri = argc > 5 ? argv[5] : "";
    try {
        db::Database station(station_path);
        std::int64_t total = 0;
        {
            db::Statement st(station, "SELECT count(*) FROM test_sessions");
            st.step();
            total = st.column_int(0);
        }
        std::printf("pg_scale_bench: station %s (%lld sessions) -> %s, batches of %zu sessions\n", station_path.c_str(),
                    static_cast<long long>(total), uri.c_str(), batch);
        db::SyncOptions so;
        so.batch_sessions = batch;
        std::int64_t batches = 0;
        const auto t_sync = Clock::now();
        so.progress = [&](const std::string&) {
            if (++batches % 50 == 0) {
                const double s = seconds_since(t_sync);
                std::printf("  %lld sessions, %.0f sessions/s so far\n", static_cast<long long>(batches) * static_cast<long long>(batch),
                            static_cast<double>(batches) * static_cast<double>(batch) / s);
                std::fflush(stdout);
            }
        };
        const double c0 = cpu_seconds();
        const db::SyncResult r = db::sync_to_fleet(station, uri, so);
        const double sync_cpu = cpu_seconds() - c0;
        std::printf("sync              : %lld sessions in %.1f s wall = %.0f sessions/s (goal >= 5000); client %.1f s CPU; %lld transactions, "
                    "%lld retries\n",
                    static_cast<long long>(r.sessions_pushed), r.seconds, static_cast<double>(r.sessions_pushed) / r.seconds, sync_cpu,
                    static_cast<long long>(r.batches), static_cast<long long>(r.retries));

        if (!owner_uri.empty()) {
            const auto t0 = Clock::now();
            db::PgConnection owner(owner_uri);
            owner.exec("ANALYZE");
            std::printf("analyze           : %.1f s (as the owner, what autovacuum does on a running server)\n", seconds_since(t0));
        }
        db::PgConnection admin(uri);

        const auto size = admin.query("SELECT pg_database_size(current_database())");
        const double bytes = std::stod(*size.at(0).at(0));
        std::printf("database          : %.1f MB on the server, %.0f bytes per session\n", bytes / 1e6,
                    bytes / static_cast<double>(std::max<std::int64_t>(total, 1)));

        db::PgRecordSource source(uri);
        pg::FleetRecordOptions ro;
        double best_report = 1e9, best_report_cpu = 1e9;
        std::int64_t sessions = 0;
        for (int rep = 0; rep < 3; ++rep) {
            const auto t0 = Clock::now();
            const double c1 = cpu_seconds();
            const pg::FleetRecord record = pg::build_fleet_record(source, tail, ro);
            best_report = std::min(best_report, seconds_since(t0));
            best_report_cpu = std::min(best_report_cpu, cpu_seconds() - c1);
            sessions = record.sessions_total;
        }
        std::printf("report            : %.1f ms wall, %.1f ms client CPU for tail %s (%lld sessions, %d draws) (goal <= 50 ms)\n",
                    best_report * 1e3, best_report_cpu * 1e3, tail.c_str(), static_cast<long long>(sessions), ro.rul.draws);
        {
            double best_load = 1e9;
            for (int rep = 0; rep < 3; ++rep) {
                const auto t0 = Clock::now();
                (void)source.sessions_of_tail(tail);
                best_load = std::min(best_load, seconds_since(t0));
            }
            std::printf("  of which loading the tail's sessions with their findings from the server: %.1f ms wall\n", best_load * 1e3);
        }
        pg::FleetOptions fo;
        double best_fleet = 1e9, best_fleet_cpu = 1e9;
        std::size_t rows = 0;
        for (int rep = 0; rep < 2; ++rep) {
            const auto t0 = Clock::now();
            const double c1 = cpu_seconds();
            const auto view = pg::build_fleet_view(source, fo);
            best_fleet = std::min(best_fleet, seconds_since(t0));
            best_fleet_cpu = std::min(best_fleet_cpu, cpu_seconds() - c1);
            rows = view.size();
        }
        std::printf("fleet             : %.2f s wall, %.2f s client CPU for %zu tail positions ranked (%d draws each) (goal <= 2 s)\n",
                    best_fleet, best_fleet_cpu, rows, fo.rul.draws);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "pg_scale_bench: %s\n", e.what());
        return 1;
    }
}
