#!/usr/bin/env bash
# Starts a real PostgreSQL server (Debian's postgresql package: initdb + pg_ctl) in a temporary
# directory, as an unprivileged user, on a Unix socket only; runs the fleet-server tests
# (pg_tests.sh) against it; stops it and removes the directory afterwards, also on failure.
#   scripts/pg/run_pg_tests.sh [EMADIAG_BINARY]     (default build/src/emadiag)
#   scripts/pg/run_pg_tests.sh EMADIAG_BINARY --run CMD ARGS...   (CMD instead of the tests, e.g. the
#       benchmark: scripts/pg/run_pg_bench.sh; it gets PGSOCK, PGWORK and the admin role fleet_admin)
#   PG_SERVER_OPTS="-c name=value ..." adds server settings (the benchmark's memory and WAL sizes).
# Run as root (CI): the server runs as the system user 'postgres' (made by the package) or, when
# missing, as 'emadiag-pg' (created here). Run as another user: the server runs as that user.
# Exit status: that of the tests; never skipped (no server binaries is a failure).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
emadiag="$(readlink -f "${1:-$root/build/src/emadiag}")"
shift || true
run_cmd=()
if [ "${1:-}" = "--run" ]; then shift; run_cmd=("$@"); fi
[ -x "$emadiag" ] || { echo "run_pg_tests: no emadiag binary at $emadiag (build it first)" >&2; exit 1; }
pgbin="$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1)"
[ -n "$pgbin" ] && [ -x "$pgbin/initdb" ] && [ -x "$pgbin/pg_ctl" ] ||
  { echo "run_pg_tests: PostgreSQL server binaries not found (Debian package 'postgresql'; scripts/setup.sh installs it)" >&2; exit 1; }
command -v psql >/dev/null || { echo "run_pg_tests: psql not found (Debian package postgresql-client)" >&2; exit 1; }

work="$(mktemp -d /tmp/emadiag-pg.XXXXXX)"
chmod 755 "$work"
as_server=()
if [ "$(id -u)" -eq 0 ]; then
  server_user=postgres
  if ! id "$server_user" >/dev/null 2>&1; then
    server_user=emadiag-pg
    id "$server_user" >/dev/null 2>&1 || useradd --system --no-create-home --shell /usr/sbin/nologin "$server_user"
  fi
  as_server=(setpriv --reuid="$server_user" --regid="$(id -g "$server_user")" --init-groups --)
else
  server_user="$(id -un)"
fi
mkdir -p "$work/data" "$work/sock"
[ "$(id -u)" -eq 0 ] && chown "$server_user" "$work/data" "$work/sock"
chmod 700 "$work/data"; chmod 755 "$work/sock"

stop_server() {
  local rc=$?
  if [ -f "$work/data/postmaster.pid" ]; then
    "${as_server[@]}" "$pgbin/pg_ctl" -D "$work/data" -m fast -w stop >/dev/null 2>&1 ||
      "${as_server[@]}" "$pgbin/pg_ctl" -D "$work/data" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  if [ $rc -ne 0 ] && [ -f "$work/server.log" ]; then echo "--- server log (last 30 lines) ---" >&2; tail -30 "$work/server.log" >&2; fi
  rm -rf "$work"
  exit $rc
}
trap stop_server EXIT
trap 'exit 130' INT TERM

# The bootstrap superuser 'fleet_admin' (trust on the socket); every other role authenticates with
# scram-sha-256, its password read from PGPASSFILE.
"${as_server[@]}" "$pgbin/initdb" -D "$work/data" -U fleet_admin --locale=C -E UTF8 --auth-local=scram-sha-256 --auth-host=reject \
  >"$work/initdb.log" 2>&1 || { cat "$work/initdb.log" >&2; exit 1; }
printf 'local all fleet_admin trust\nlocal all all scram-sha-256\n' > "$work/hba.conf"
[ "$(id -u)" -eq 0 ] && chown "$server_user" "$work/hba.conf"
touch "$work/server.log"; [ "$(id -u)" -eq 0 ] && chown "$server_user" "$work/server.log"
"${as_server[@]}" "$pgbin/pg_ctl" -D "$work/data" -l "$work/server.log" -w -t 60 \
  -o "-c listen_addresses='' -k $work/sock -c hba_file=$work/hba.conf -c fsync=off -c max_connections=40 ${PG_SERVER_OPTS:-}" start >/dev/null
echo "run_pg_tests: PostgreSQL $("$pgbin/postgres" --version | awk '{print $3}') as $server_user on socket $work/sock"

export EMADIAG="$emadiag" PGSOCK="$work/sock" PGWORK="$work"
if [ ${#run_cmd[@]} -gt 0 ]; then "${run_cmd[@]}"; else bash "$here/pg_tests.sh"; fi
