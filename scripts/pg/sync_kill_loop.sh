#!/usr/bin/env bash
# kill -9 of `emadiag sync` at random points, KILLS times (issue 12 part 3, issue 13 part 1), against
# the real PostgreSQL server run_pg_tests.sh started (EMADIAG, PGSOCK, PGWORK set by it):
#   scripts/pg/run_pg_tests.sh build/src/emadiag --run bash scripts/pg/sync_kill_loop.sh [KILLS [SEED]]
# (ctest: fleet_server_sync_kills, label postgres; SYNC_KILL_SEED=S or the second argument repeats a run).
# A station file (runs, samples, raw logs, estimates, findings, a correction) is synced once cleanly
# into a reference database, which also times a whole sync; then, into another database, syncs are
# started again and again and killed with SIGKILL after a delay drawn uniformly from the time the
# rest of the sync would take (bash's RANDOM, seeded with SEED, printed). After every kill:
#   - the server holds the station's sessions 1..n and nothing else, each whole: its findings, runs,
#     samples, raw-log bytes, estimates and artifacts equal the station file's; none twice;
#   - the report's packed findings (schema 5): one row for each session with findings, equal to them;
#     its packed sessions (schema 6): one row for each session, equal to it;
#   - the station's sync record names only sessions the server has, with their fleet ids;
#   - the station file passes PRAGMA integrity_check.
# When a sync completed before its kill, the server's copy is emptied and the station's record
# cleared, so that the kills keep landing inside syncs. At the end a sync without a kill completes,
# and the server's summary tables equal the clean reference's and the station's own, double for double.
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
E="$EMADIAG"
kills="${1:-50}"
seed="${2:-${SYNC_KILL_SEED:-$(( $(date +%s) % 100000 ))}}"
RANDOM=$seed
W="$PGWORK/kill"; mkdir -p "$W"; cd "$W"
admin() { psql -X -q -At -v ON_ERROR_STOP=1 "postgresql:///${DB:-fleetk}?host=$PGSOCK&user=fleet_admin" "$@"; }
uri() { echo "postgresql:///$1?host=$PGSOCK&user=station_k"; }
die() { echo "FAIL: sync kill loop: $*"; exit 1; }
export PGPASSFILE="$PGWORK/pgpass_k"
umask 077

DB=postgres admin -c "CREATE DATABASE fleetk" -c "CREATE DATABASE fleetk_ref" || die "cannot create the databases"
for db in fleetk fleetk_ref; do
  "$E" fleet-server --to "postgresql:///$db?host=$PGSOCK&user=fleet_admin" --add-station station_k > /dev/null || die "fleet-server $db"
done
pw="$(head -c 18 /dev/urandom | base64 | tr -d '/+=')"
echo "*:*:*:station_k:$pw" > "$PGPASSFILE"
DB=postgres admin <<< "ALTER ROLE station_k PASSWORD '$pw'"

# The station: two tails, ground tests with two runs each (samples, raw logs), cycles, and one
# correction (an import amending a session: its measurements leave the summaries again).
sim() { "$E" history-sim --db k.db "$@" --noise typical > /dev/null || die "history-sim $*"; }
sim --tail N7EM --position LH-ELEV --sessions 24 --days-between 3 --cycles-per-day 4 --seed 5
sim --tail N8EM --position RH-AIL --sessions 24 --days-between 3 --cycles-per-day 4 --seed 6
"$E" simulate --case B --sequence dyn --noise typical --seed 7 --out run.csv > /dev/null || die "simulate"
"$E" import run.csv --db k.db --tail N7EM --position LH-ELEV --utc 2026-12-01T08:00:00Z --cycles 5000 --amends 3 \
  --reason "wrong actuator serial typed" > /dev/null || die "import --amends"
total=$(sqlite3 k.db "SELECT count(*) FROM test_sessions")
station_uuid=$(sqlite3 k.db "SELECT station_uuid FROM station_identity")

detail_columns="(SELECT count(*) FROM findings f WHERE f.session_id = s.session_id),
  (SELECT count(*) FROM runs r WHERE r.session_id = s.session_id),
  (SELECT count(*) FROM estimates e JOIN runs r ON r.run_id = e.run_id WHERE r.session_id = s.session_id),
  (SELECT count(*) FROM samples x JOIN runs r ON r.run_id = x.run_id WHERE r.session_id = s.session_id),
  (SELECT count(*) FROM session_artifacts a WHERE a.session_id = s.session_id),
  s.content_sha256"
station_detail() {
  sqlite3 k.db "SELECT s.session_id, $detail_columns,
    (SELECT coalesce(sum(length(g.content)), 0) FROM raw_logs g JOIN runs r ON r.run_id = g.run_id WHERE r.session_id = s.session_id)
    FROM test_sessions s WHERE s.session_id <= $1 ORDER BY 1" | tr '|' ' '
}
server_detail() {
  DB=$1 admin -c "SELECT s.station_session_id, $detail_columns,
    (SELECT coalesce(sum(length(c.content)), 0) FROM raw_log_chunks c JOIN runs r ON r.run_id = c.run_id WHERE r.session_id = s.session_id)
    FROM test_sessions s WHERE s.station_uuid = '$station_uuid' ORDER BY 1" | tr '|' ' '
}

# Schema 5: each session with findings has one row of packed findings (the sync adds no findings to a
# session later), equal to its findings packed anew; no packed row without findings.
packed_mismatches="SELECT count(*) FROM
  (SELECT session_id, string_agg(finding_bytes(parameter, estimator, value, std_error, limit_value, limit_kind, status, note), ''::bytea
                                 ORDER BY parameter, estimator) AS b FROM findings GROUP BY session_id) f
  FULL JOIN (SELECT session_id, (array_agg(findings))[1] AS b, count(*) AS n FROM session_findings GROUP BY session_id) p USING (session_id)
  WHERE f.b IS DISTINCT FROM p.b OR p.n <> 1"
# Schema 6: each session has exactly one packed row, equal to the session packed anew.
packed_session_mismatches="SELECT count(*) FROM
  (SELECT tail_number, started_utc, session_id,
          session_bytes(actuator_serial, phase, tool_version, verdict, verdict_note, position, cycles, hours_h, operator_id, technician_name,
                        technician_certificate, work_performed, source, amends_session_id, correction_reason, content_sha256) AS b
   FROM test_sessions) s
  FULL JOIN (SELECT tail_number, started_utc, session_id, session AS b FROM session_rows) p USING (tail_number, started_utc, session_id)
  WHERE s.b IS DISTINCT FROM p.b"

# The reference: one whole sync, timed (the kill delays are drawn from this span).
t0=$(date +%s%N)
"$E" sync --db k.db --to "$(uri fleetk_ref)" --batch 2 > ref.txt 2>&1 || { cat ref.txt; die "reference sync"; }
span_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
sqlite3 k.db "DELETE FROM synced_sessions; DELETE FROM synced_discovery_findings"
[ "$(server_detail fleetk_ref)" = "$(station_detail "$total")" ] || die "the reference sync is not the station file"
echo "sync kill loop: seed $seed; station of $total sessions ($(sqlite3 k.db "SELECT count(*) FROM runs") runs, $(sqlite3 k.db "SELECT count(*) FROM samples") samples); a whole sync takes $span_ms ms"

eof_lines() { grep -c "unexpected EOF on client connection with an open transaction" "$PGWORK/server.log"; }
interrupted=0; completed=0; recovered_window=0; resets=0; progress=0; checked=0; t_start=$(date +%s%N)
for i in $(seq 1 "$kills"); do
  have=$(admin -c "SELECT count(*) FROM test_sessions")
  if [ "$have" -ge "$total" ]; then  # all there: start over, so that the next kill lands inside a sync
    admin -c "TRUNCATE test_sessions, session_rows, runs, samples, raw_log_chunks, estimates, findings, session_findings, session_artifacts,
              installations, session_measurements, series_stats, position_status, discovery_findings" || die "reset"
    sqlite3 k.db "DELETE FROM synced_sessions; DELETE FROM synced_discovery_findings"
    resets=$((resets + 1)); have=0
  fi
  eof_before=$(eof_lines)
  batch=$((RANDOM % 3 + 1))
  delay_ms=$(( (RANDOM * 32768 + RANDOM) % (span_ms * (total - have) / total + 30) ))
  "$E" sync --db k.db --to "$(uri fleetk)" --batch "$batch" > "sync_$i.txt" 2>&1 & pid=$!
  sleep "$(awk -v ms="$delay_ms" 'BEGIN { printf "%.3f", ms / 1000 }')"
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null; rc=$?
  [ $rc -eq 0 ] && completed=$((completed + 1))
  [ $rc -eq 0 ] || [ $rc -eq 137 ] || { cat "sync_$i.txt"; die "kill $i: sync failed by itself (exit status $rc)"; }
  # The server ends the killed session's backend (rolling its transaction back) when it sees the EOF.
  for _ in $(seq 1 200); do [ "$(admin -c "SELECT count(*) FROM pg_stat_activity WHERE usename = 'station_k'")" = 0 ] && break; sleep 0.02; done
  [ "$(eof_lines)" -gt "$eof_before" ] && interrupted=$((interrupted + 1))
  n=$(admin -c "SELECT count(*) FROM test_sessions")
  [ "$(sqlite3 k.db "PRAGMA integrity_check")" = ok ] || die "kill $i: station file damaged"
  got="$(server_detail fleetk)"; want="$(station_detail "$n")"
  [ "$got" = "$want" ] || { diff <(echo "$want") <(echo "$got") | head -5; die "kill $i (after $delay_ms ms, batch $batch): the server's $n sessions are not sessions 1..$n whole"; }
  dup=$(admin -c "SELECT count(*) - count(DISTINCT (station_uuid, station_session_id)) FROM test_sessions")
  [ "$dup" = 0 ] || die "kill $i: $dup sessions twice"
  packed=$(admin -c "$packed_mismatches")
  [ "$packed" = 0 ] || die "kill $i: $packed sessions whose packed findings (schema 5) are not their findings, once"
  packed=$(admin -c "$packed_session_mismatches")
  [ "$packed" = 0 ] || die "kill $i: $packed sessions whose packed row (schema 6) is not the session, once"
  # The station's record: only sessions the server holds, under the fleet ids the server gave them.
  recorded=$(sqlite3 k.db "SELECT count(*) FROM synced_sessions")
  on_server=$(admin -c "SELECT string_agg(station_session_id || ':' || session_id, ' ' ORDER BY station_session_id) FROM test_sessions")
  mine=$(sqlite3 k.db "SELECT group_concat(session_id || ':' || fleet_session_id, ' ') FROM (SELECT * FROM synced_sessions ORDER BY session_id)")
  [ -z "$mine" ] || [[ "$on_server " == "$mine "* ]] ||
    die "kill $i: the station records sessions the server does not have as recorded: $mine vs $on_server"
  [ "$recorded" -lt "$n" ] && recovered_window=$((recovered_window + 1))
  [ "$n" -gt "$have" ] && progress=$((progress + n - have))
  checked=$((checked + n))
done
span_s=$(awk -v ns=$(( $(date +%s%N) - t_start )) 'BEGIN { printf "%.0f", ns / 1e9 }')
# The next sync finishes the job: every session whole, none twice, the record complete, the
# summaries those of the clean sync and of the station.
"$E" sync --db k.db --to "$(uri fleetk)" --batch 3 > final.txt 2>&1 || { cat final.txt; die "the sync after the kills failed"; }
cat final.txt
[ "$(server_detail fleetk)" = "$(station_detail "$total")" ] || die "after the final sync the server is not the station file"
[ "$(sqlite3 k.db "SELECT count(*) FROM synced_sessions")" = "$total" ] || die "after the final sync the station's record is incomplete"
[ "$(admin -c "SELECT count(*) - count(DISTINCT station_session_id) FROM test_sessions")" = 0 ] || die "sessions twice after the final sync"
[ "$(admin -c "$packed_mismatches")" = 0 ] || die "after the final sync, packed findings (schema 5) that are not their sessions' findings, once"
[ "$(admin -c "$packed_session_mismatches")" = 0 ] || die "after the final sync, packed session rows (schema 6) that are not their sessions, once"
cmp_ref=$(python3 "$here/compare_summaries.py" k.db "$(uri fleetk)" "$(uri fleetk_ref)") || die "$cmp_ref"
cmp_station=$(python3 "$here/compare_summaries.py" k.db "$(uri fleetk)") || die "$cmp_station"
echo "$cmp_ref"
echo "$cmp_station"
echo "kill -9 sync: $kills kills over ${span_s} s (seed $seed, delays 0..$span_ms ms, batches of 1-3 sessions), $interrupted interrupted a server transaction, $recovered_window left the station's record behind the server (between its commit and the record; the next sync recovers it), $completed finished before the kill, $resets restarts from empty; $checked whole sessions checked after the kills, no partial session, none twice; the final sync completed ($total sessions)"
