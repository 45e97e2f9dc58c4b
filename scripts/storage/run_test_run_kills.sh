#!/usr/bin/env bash
# kill -9 of `emadiag test-run` at random points over vcan, N times (default 50) (issue 12 part 3;
# table in tests/README.md "Storage faults"). Each round starts the simulated EMA (ema-sim) and a
# DYN + BRK test run, kills the tool with SIGKILL at a uniformly drawn moment of one whole run
# (connect, both sequences, estimation, the store transaction), then stops the EMA. After every
# kill, `emadiag recover` stores the killed run's spooled session; then PRAGMA integrity_check is ok,
# every stored session is whole (each run has its raw log), no session went missing and the spool is
# empty. At the end the database holds exactly the finished runs plus the recovered sessions
# (nothing lost, nothing twice) and the tail's hash chain verifies. (The vcan suite covers the next
# test run storing the spool itself.)
#   scripts/storage/run_test_run_kills.sh BUILD_DIR [KILLS]
# Needs vcan0: scripts/vcan/with_vcan.sh runs it directly or inside user-mode Linux.
set -euo pipefail
if [ "${1:-}" != --inner ]; then
  [ $# -ge 1 ] && [ -d "$1" ] || { echo "usage: $0 BUILD_DIR [KILLS]" >&2; exit 2; }
  build=$(cd "$1" && pwd)
  here=$(cd "$(dirname "$0")" && pwd)
  # The guest's time limit grows with the kills: each is a test run of about 8 s in user-mode Linux,
  # then recover and the checks (50 kills ran past with_vcan.sh's default 600 s and were stopped).
  export EMADIAG_UML_TIMEOUT_S=${EMADIAG_UML_TIMEOUT_S:-$((300 + 30 * ${2:-50}))}
  exec "$here/../vcan/with_vcan.sh" "$build/kills-uml" bash "$here/run_test_run_kills.sh" --inner "$build" "${2:-50}"
fi
build=$2
kills=$3
emadiag=$build/src/emadiag
[ -x "$emadiag" ] || { echo "run_test_run_kills: $emadiag not built" >&2; exit 2; }
command -v sqlite3 >/dev/null || { echo "run_test_run_kills: sqlite3 missing (scripts/setup.sh)" >&2; exit 2; }
bus=socketcan:vcan0
scale=${EMADIAG_VCAN_TIME_SCALE:-2}
work=$(mktemp -d)
ema_pid=""
cleanup() {
  [ -n "$ema_pid" ] && kill -9 "$ema_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
db=$work/m.db
tool=(test-run --bus "$bus" --tail N123EM --position LH-ELEV --db "$db" --out-dir "$work/logs" --technician "CI" --certificate "0000")

start_ema() {  # $1: seed. Returns when the EMA listens.
  "$emadiag" ema-sim --bus "$bus" --time-scale "$scale" --idle-exit 3 --case A --noise typical --seed "$1" >"$work/ema.out" 2>&1 &
  ema_pid=$!
  for _ in $(seq 1 200); do
    grep -q "ema-sim on" "$work/ema.out" 2>/dev/null && return 0
    sleep 0.05
  done
  echo "run_test_run_kills: ema-sim did not start: $(cat "$work/ema.out")" >&2
  exit 1
}
stop_ema() {
  kill -9 "$ema_pid" 2>/dev/null || true
  wait "$ema_pid" 2>/dev/null || true
  ema_pid=""
}
# Integrity and whole sessions in one sqlite3 call (every process start is costly in user-mode
# Linux); prints the session count. The hash chain is verified by `emadiag verify` at the end.
check_db() {
  [ -s "$db" ] || { echo 0; return 0; }
  local out
  out=$(sqlite3 "$db" "PRAGMA integrity_check;
      SELECT CASE WHEN (SELECT COUNT(*) FROM sqlite_master WHERE name = 'test_sessions') = 0 THEN '0 0' ELSE
        (SELECT COUNT(*) FROM test_sessions) || ' ' || (SELECT COUNT(*) FROM test_sessions s WHERE
          NOT EXISTS (SELECT 1 FROM runs r WHERE r.session_id = s.session_id)
          OR EXISTS (SELECT 1 FROM runs r WHERE r.session_id = s.session_id AND
                     NOT EXISTS (SELECT 1 FROM raw_logs l WHERE l.run_id = r.run_id))) END;")
  [ "$(head -1 <<<"$out")" = ok ] || { echo "integrity_check: $out" >&2; return 1; }
  read -r count partial <<<"$(tail -1 <<<"$out")"
  [ "$partial" = 0 ] || { echo "$partial partial sessions" >&2; return 1; }
  echo "$count"
}
verify_chain() {
  "$emadiag" verify --db "$db" --tail N123EM >"$work/verify.out" 2>&1 || { echo "verify failed:" >&2; cat "$work/verify.out" >&2; return 1; }
}

echo "== kill -9 of emadiag test-run at random points over $bus (time scale $scale), $kills times =="
# One whole run first, to know the span the kill is drawn from.
start_ema 100
t0=$(date +%s%N)
"$emadiag" "${tool[@]}" >"$work/first.out" 2>&1 || { echo "the first, whole test run failed:" >&2; cat "$work/first.out" >&2; exit 1; }
span_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
echo "one whole run: $span_ms ms"
stop_ema
completed=1
before=$(check_db) || { echo "after the first run: database damaged" >&2; exit 1; }
hot=0 recovered=0 already=0 empty=0
for i in $(seq 1 "$kills"); do
  start_ema "$i"
  "$emadiag" "${tool[@]}" >"$work/tool.out" 2>&1 &
  pid=$!
  sleep "$(awk -v ms=$(( (RANDOM * 32768 + RANDOM) % (span_ms + 1) )) 'BEGIN { printf "%.3f", ms / 1000 }')"
  kill -9 "$pid" 2>/dev/null || true
  if wait "$pid" 2>/dev/null; then completed=$((completed + 1)); fi
  stop_ema
  [ -s "$db-journal" ] && hot=$((hot + 1))
  # The killed run's session is in the spool: recover stores it (invalid runs for logs cut before
  # the EMA identified itself), or drops it when no frame reached a raw log.
  "$emadiag" recover --db "$db" >"$work/recover.out" 2>&1 || { echo "kill $i: recover failed:" >&2; cat "$work/recover.out" >&2; exit 1; }
  read -r st al em <<<"$(sed -n 's/^recover: \([0-9]*\) spooled session(s) stored in .*, \([0-9]*\) found already stored, \([0-9]*\) with nothing recorded.*/\1 \2 \3/p' "$work/recover.out")"
  [ -n "${em:-}" ] || { echo "kill $i: unexpected recover output: $(cat "$work/recover.out")" >&2; exit 1; }
  recovered=$((recovered + st)); already=$((already + al)); empty=$((empty + em))
  left=$(find "$db.spool" -name '*.json' 2>/dev/null | wc -l)
  [ "$left" = 0 ] || { echo "kill $i: $left spooled session(s) left after recover:" >&2; cat "$work/recover.out" >&2; exit 1; }
  n=$(check_db) || { echo "kill $i: database damaged" >&2; exit 1; }
  [ "$n" -ge "$before" ] || { echo "kill $i: sessions went from $before to $n" >&2; exit 1; }
  before=$n
done
n=$(check_db) || { echo "at the end: database damaged" >&2; exit 1; }
verify_chain || exit 1
[ "$n" -eq $((completed + recovered + already)) ] ||
  { echo "at the end: $n sessions, expected $completed finished + $recovered recovered + $already found already stored" >&2; exit 1; }
echo "kill -9 test-run: $kills kills over a ${span_ms} ms run: $completed runs finished (the first one whole), $hot kills interrupted a transaction (hot journal); recover stored $recovered spooled sessions, found $already already stored, dropped $empty with no frame recorded; $n whole sessions, integrity ok, chain verified, no partial session, spool empty"
