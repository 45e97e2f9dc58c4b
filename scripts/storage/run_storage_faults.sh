#!/usr/bin/env bash
# Storage faults with the real command (issue 12 part 3; table in tests/README.md "Storage faults"):
#   1. `emadiag history-sim` killed with SIGKILL at a random point, N times (default 50), on one
#      database; after each kill PRAGMA integrity_check is ok, every session is whole and every
#      history (one transaction) holds all of its sessions or none;
#   2. `emadiag import` of a run killed the same way, N times; every session is whole (its run,
#      samples, raw log and findings) and the next import still stores;
#   3. a full disk: history-sim into a database on a 2 MB tmpfs (needs mount, i.e. root); it must
#      stop with "database or disk is full", storing nothing of the history.
# The unit test maintenance_db_storage_fault_test covers the same with the library (fork + SIGKILL),
# two writers at once, an I/O error at every write and a full disk through a VFS shim, a corrupt,
# truncated or read-only file.
#   scripts/storage/run_storage_faults.sh [BUILD_DIR] [KILLS]
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
kills=${2:-50}
emadiag=$build/src/emadiag
[ -x "$emadiag" ] || { echo "run_storage_faults: $emadiag not built" >&2; exit 2; }
command -v sqlite3 >/dev/null || { echo "run_storage_faults: sqlite3 missing (scripts/setup.sh)" >&2; exit 2; }
work=$(mktemp -d)
mnt=""
cleanup() {
  if [ -n "$mnt" ]; then umount "$mnt" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

# check_db DB RUNS: every session has its RUNS runs (history-sim: 2, import: 1), each with samples
# and its raw log, and its findings; prints the session count. A file killed before its schema was
# committed (absent, or no table yet) holds 0 sessions.
check_db() {
  local db=$1 runs=$2 ic partial
  [ -s "$db" ] || { echo 0; return 0; }
  ic=$(sqlite3 "$db" "PRAGMA integrity_check")
  [ "$ic" = ok ] || { echo "integrity_check: $ic" >&2; return 1; }
  [ "$(sqlite3 "$db" "SELECT COUNT(*) FROM sqlite_master")" != 0 ] || { echo 0; return 0; }
  partial=$(sqlite3 "$db" "SELECT COUNT(*) FROM test_sessions s WHERE
      (SELECT COUNT(*) FROM runs r WHERE r.session_id = s.session_id) != $runs
      OR (SELECT COUNT(*) FROM findings f WHERE f.session_id = s.session_id) = 0
      OR EXISTS (SELECT 1 FROM runs r WHERE r.session_id = s.session_id AND
          (NOT EXISTS (SELECT 1 FROM samples m WHERE m.run_id = r.run_id)
           OR NOT EXISTS (SELECT 1 FROM raw_logs l WHERE l.run_id = r.run_id)))")
  [ "$partial" = 0 ] || { echo "$partial partial sessions" >&2; return 1; }
  sqlite3 "$db" "SELECT COUNT(*) FROM test_sessions"
}

echo "== kill -9 of emadiag history-sim at random points, $kills times =="
# One history is one transaction: after each kill its tail holds all of its sessions or none. Each
# kill is a history of its own tail (H1, H2, ...); the kill time is drawn uniformly over 1.2 times
# one whole history, so some kills land after the commit (whole) and most before (absent).
db=$work/kill.db
hist=4
t0=$(date +%s%N)
"$emadiag" history-sim --db "$work/history_time.db" --tail N123EM --sessions "$hist" --noise none --seed 1 >/dev/null
span_ms=$(( ($(date +%s%N) - t0) * 12 / 10000000 + 1 ))
hot=0
whole=0
absent=0
for i in $(seq 1 "$kills"); do
  "$emadiag" history-sim --db "$db" --tail "H$i" --sessions "$hist" --noise none --seed "$i" >/dev/null 2>&1 &
  pid=$!
  sleep "$(awk -v ms=$((RANDOM % span_ms)) 'BEGIN { printf "%.3f", ms / 1000 }')"
  kill -9 "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  [ -s "$db-journal" ] && hot=$((hot + 1))
  # The library's open (quick_check) must accept it too; sqlite3 rolls a hot journal back first.
  check_db "$db" 2 >/dev/null || { echo "kill $i: database damaged" >&2; exit 1; }
  [ -s "$db" ] && [ "$(sqlite3 "$db" "SELECT COUNT(*) FROM sqlite_master")" != 0 ] || { absent=$((absent + 1)); continue; }
  # Every history so far: all of its sessions or none (a partial history is a failure).
  partial=$(sqlite3 "$db" "SELECT tail_number || ': ' || COUNT(*) FROM test_sessions GROUP BY tail_number HAVING COUNT(*) != $hist")
  [ -z "$partial" ] || { echo "kill $i: partial histories (sessions of $hist): $partial" >&2; exit 1; }
  n=$(sqlite3 "$db" "SELECT COUNT(*) FROM test_sessions WHERE tail_number = 'H$i'")
  if [ "$n" = "$hist" ]; then whole=$((whole + 1)); else absent=$((absent + 1)); fi
done
n=$(check_db "$db" 2)
echo "kill -9 history-sim: $kills kills over ${span_ms} ms, $whole histories whole, $absent absent, none partial; $hot interrupted a transaction (hot journal); $n whole sessions, integrity ok"

echo "== kill -9 of emadiag import at random points, $kills times =="
run=$work/import_run.csv
"$emadiag" simulate --case B --sequence dyn --noise typical --seed 7 --out "$run" >/dev/null
db=$work/import.db
# The kill lands anywhere in one import's lifetime (parse, both estimators, the store transaction):
# measure one import first and draw the kill time uniformly over 1.2 times that.
t0=$(date +%s%N)
"$emadiag" import "$run" --db "$work/import_time.db" --tail N123EM --position LH-ELEV --utc 2026-01-01T00:00:00Z >/dev/null
span_ms=$(( ($(date +%s%N) - t0) * 12 / 10000000 + 1 ))
before=0
hot=0
completed=0
for i in $(seq 1 "$kills"); do
  utc=$(printf '2026-01-%02dT%02d:%02d:00Z' $((i % 28 + 1)) $((i % 24)) $((i % 60)))
  "$emadiag" import "$run" --db "$db" --tail N123EM --position LH-ELEV --utc "$utc" >/dev/null 2>&1 &
  pid=$!
  sleep "$(awk -v ms=$((RANDOM % span_ms)) 'BEGIN { printf "%.3f", ms / 1000 }')"
  kill -9 "$pid" 2>/dev/null || true
  if wait "$pid" 2>/dev/null; then completed=$((completed + 1)); fi
  [ -s "$db-journal" ] && hot=$((hot + 1))
  n=$(check_db "$db" 1) || { echo "import kill $i: database damaged" >&2; exit 1; }
  [ "$n" -ge "$before" ] && [ "$n" -le $((before + 1)) ] ||
    { echo "import kill $i: sessions went from $before to $n" >&2; exit 1; }
  before=$n
done
# The database the kills left behind still takes a new import (the library's open check accepts it).
"$emadiag" import "$run" --db "$db" --tail N123EM --position LH-ELEV --utc 2026-02-01T00:00:00Z >/dev/null ||
  { echo "import after the kills failed" >&2; exit 1; }
n=$(check_db "$db" 1) || { echo "import after the kills: database damaged" >&2; exit 1; }
[ "$n" -eq $((before + 1)) ] || { echo "import after the kills: $before -> $n sessions" >&2; exit 1; }
echo "kill -9 import: $kills kills over ${span_ms} ms, $completed finished before the kill, $hot interrupted a transaction (hot journal), $n whole sessions, integrity ok, no partial session"

echo "== full disk: history-sim on a 2 MB tmpfs =="
mnt=$work/mnt
mkdir -p "$mnt"
if mount -t tmpfs -o size=2m tmpfs "$mnt" 2>/dev/null; then
  set +e
  out=$("$emadiag" history-sim --db "$mnt/full.db" --tail N123EM --sessions 50 --noise none 2>&1)
  rc=$?
  set -e
  [ "$rc" -ne 0 ] || { echo "full disk: history-sim succeeded on a full disk?" >&2; exit 1; }
  grep -q "database or disk is full" <<<"$out" || { echo "full disk: unclear error: $(tail -2 <<<"$out")" >&2; exit 1; }
  n=$(check_db "$mnt/full.db" 2) || { echo "full disk: database damaged" >&2; exit 1; }
  echo "full disk: exit $rc, '$(grep -o 'database or disk is full' <<<"$out" | head -1)', $n whole sessions kept, integrity ok"
  umount "$mnt"
  mnt=""
else
  echo "full disk: SKIPPED (mount -t tmpfs not permitted here; the unit test's VFS shim covers SQLITE_FULL)"
fi
echo "run_storage_faults: passed"
