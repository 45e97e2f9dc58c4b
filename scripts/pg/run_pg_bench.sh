#!/usr/bin/env bash
# The fleet server at scale: builds the synthetic fleet's station file with fleet_scale_bench
# (TAILS x 4 positions x 2 sessions/day x DAYS; 1000 730 is the 5.84 million sessions of issue 11),
# starts a temporary PostgreSQL server (run_pg_tests.sh --run), and runs pg_scale_bench: sync rate,
# database size, report and fleet times from the server (in the syncing process, then in a fresh one).
#   scripts/pg/run_pg_bench.sh [TAILS [DAYS [BUILD_DIR]]]     (defaults 1000 730 build)
#   PG_BENCH_STATION=FILE: use (a copy of) that station file instead of writing one; PG_BENCH_BATCH: sessions per transaction (default 50000).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
tails="${1:-1000}"; days="${2:-730}"; build="$(readlink -f "${3:-$root/build}")"
if [ -z "${PGSOCK:-}" ]; then
  # A fleet server's memory: the tables a report reads stay cached (the default 128 MB does not hold a
  # 5.84 M-session fleet's indexes); WAL checkpoints spaced as on a server that takes bulk loads.
  export PG_SERVER_OPTS="${PG_SERVER_OPTS:--c shared_buffers=2GB -c max_wal_size=16GB -c checkpoint_timeout=30min -c work_mem=64MB}"
  exec "$here/run_pg_tests.sh" "$build/src/emadiag" --run bash "$0" "$tails" "$days" "$build"
fi
station="$PGWORK/station.db"
chmod 755 "$PGWORK"
if [ -n "${PG_BENCH_STATION:-}" ]; then
  # A station file fleet_scale_bench already wrote (TAILS DAYS must match it): copied, since the sync
  # records what it pushed in the station file.
  cp "$PG_BENCH_STATION" "$station"
  echo "station file: copy of $PG_BENCH_STATION ($(sqlite3 "$station" "SELECT count(*) FROM test_sessions") sessions)"
else
  "$build/bench/fleet_scale_bench" "$tails" "$days" "$station" | grep -E "^(fleet_scale_bench|ingest|database)"
fi
echo "server settings: fsync=off ${PG_SERVER_OPTS}; $(uptime)"
psql -X -q "postgresql:///postgres?host=$PGSOCK&user=fleet_admin" -c "CREATE DATABASE fleet"
"$EMADIAG" fleet-server --to "postgresql:///fleet?host=$PGSOCK&user=fleet_admin" --add-station station_bench > /dev/null
pw="$(head -c 18 /dev/urandom | base64 | tr -d '/+=')"
export PGPASSFILE="$PGWORK/pgpass"; (umask 077; echo "*:*:*:station_bench:$pw" > "$PGPASSFILE")
psql -X -q "postgresql:///postgres?host=$PGSOCK&user=fleet_admin" <<< "ALTER ROLE station_bench PASSWORD '$pw'"
PG_POSTMASTER_PID="$(head -1 "$PGWORK/data/postmaster.pid")" "$build/bench/pg_scale_bench" "$station" "postgresql:///fleet?host=$PGSOCK&user=station_bench" "${PG_BENCH_BATCH:-50000}" F-W0000 \
  "postgresql:///fleet?host=$PGSOCK&user=fleet_admin"
# The report and fleet again in a fresh process, as `emadiag report` runs (not after a sync in the same process).
"$build/bench/pg_scale_bench" --reports "postgresql:///fleet?host=$PGSOCK&user=station_bench" F-W0000
# The server's CPU (its backends, ended by now; the machine may be shared, so wall times also count waiting).
pm="$(head -1 "$PGWORK/data/postmaster.pid")"
awk -v hz="$(getconf CLK_TCK)" '{printf "server CPU        : %.1f s (backends, user + system)\n", ($16 + $17) / hz}' "/proc/$pm/stat"
