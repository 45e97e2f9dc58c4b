#!/usr/bin/env bash
# The fleet-server tests against the real PostgreSQL server run_pg_tests.sh started (EMADIAG,
# PGSOCK, PGWORK set by it). Each check prints PASS or FAIL with what it saw; any FAIL fails the run.
set -uo pipefail
E="$EMADIAG"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
W="$PGWORK/t"; mkdir -p "$W"; cd "$W"
fails=0
pass() { echo "PASS: $*"; }
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
admin() { psql -X -q -At -v ON_ERROR_STOP=1 "postgresql:///${DB:-fleet}?host=$PGSOCK&user=fleet_admin" "$@"; }
uri() { echo "postgresql:///$1?host=$PGSOCK&user=$2"; }
export PGPASSFILE="$PGWORK/pgpass"
umask 077
: > "$PGPASSFILE"

# ---- the fleet server: schema, two (three) station roles with passwords in PGPASSFILE ----
DB=postgres admin -c "CREATE DATABASE fleet" -c "CREATE DATABASE fleet1"
for db in fleet fleet1; do
  "$E" fleet-server --to "$(uri $db fleet_admin)" --add-station station_a --add-station station_b --add-station station_c \
    || { echo "FAIL: fleet-server"; exit 1; }
done
for r in station_a station_b station_c; do
  pw="$(head -c 18 /dev/urandom | base64 | tr -d '/+=')"
  echo "*:*:*:$r:$pw" >> "$PGPASSFILE"
  DB=postgres admin <<< "ALTER ROLE $r PASSWORD '$pw'"
  echo "$pw" >> "$PGWORK/passwords"
done

# ---- station files (simulated ground tests with runs, samples and raw logs) ----
sim() { "$E" history-sim "$@" --noise typical > /dev/null || { echo "FAIL: history-sim $*"; exit 1; }; }
sim --db a.db --tail N1EM --position LH-ELEV --sessions 6 --cycles-per-day 4 --fdj-rate-per-100d 0.01 --fsj-rate-per-100d 0.012 --operator OPA --technician "A. Smith" --certificate L-1
sim --db a.db --tail N1EM --position LH-ELEV --sessions 4 --serial NEW-1 --start-utc 2026-08-01T08:00:00Z --cycles-per-day 4 --cycles 800
sim --db a.db --tail N2EM --position RH-ELEV --sessions 5 --days-between 20 --fsj-rate-per-100d 0.02
sim --db b.db --tail N1EM --position RH-ELEV --sessions 6 --cycles-per-day 4 --seed 7
sim --db c.db --tail N3EM --position LH-AIL --sessions 60 --days-between 5 --seed 3
# Discovery findings of N1EM (as `emadiag discover --tail` stores them): one open, one closed by a later entry.
# Each with its content hash and the tail's chain of findings (docs/record-format.md), so that the
# station's record verifies (a report of a changed record says so and exits 5).
dlink=""
dcount=0
disc() {  # disc UTC SUMMARY STATUS AMENDS(- for none)
  local f content sha amends_sql
  content="emadiag-discovery-v1"$'\n'
  for f in "tail_number=N1EM" "position=LH-ELEV" "actuator_serial=NEW-1" "found_utc=$1" "summary=$2" "model_json={}" "status=$3" \
           "amends_finding_id=$4" "tool_version=test"; do
    content+="${f%%=*}:$(printf '%s' "${f#*=}" | wc -c):${f#*=}"$'\n'
  done
  sha=$(printf '%s' "$content" | sha256sum | cut -c1-64)
  dlink=$(printf 'emadiag-discovery-chain-v1\n%s\n%s\n' "$dlink" "$sha" | sha256sum | cut -c1-64)
  dcount=$((dcount + 1))
  amends_sql=$([ "$4" = - ] && echo NULL || echo "$4")
  sqlite3 a.db "INSERT INTO discovery_findings(tail_number, position, actuator_serial, found_utc, summary, model_json, status, amends_finding_id, tool_version, content_sha256)
    VALUES ('N1EM', 'LH-ELEV', 'NEW-1', '$1', '$2', '{}', '$3', $amends_sql, 'test', '$sha');
    UPDATE chain_heads SET discovery_findings = $dcount, discovery_head_sha256 = '$dlink' WHERE tail_number = 'N1EM'"
}
disc 2026-09-01T10:00:00Z 'Stribeck term: +0.012 N m below 0.5 rad/s; RMS error 0.031 -> 0.012 A' open -
disc 2026-09-02T10:00:00Z 'backlash 0.4 mrad' open -
disc 2026-09-03T10:00:00Z 'backlash 0.4 mrad: closed, shim replaced' closed 2
"$E" verify --db a.db --tail N1EM > verify_a.txt 2>&1 || { echo "FAIL: the station file does not verify:"; cat verify_a.txt; exit 1; }
count() { sqlite3 "$1" "SELECT count(*) FROM test_sessions"; }

# ---- 1. a password in the URI is refused and never printed ----
out="$("$E" sync --db a.db --to "postgresql://station_a:Hunter2Secret@/fleet?host=$PGSOCK" 2>&1)"; rc=$?
if [ $rc -ne 0 ] && grep -q "carries a password" <<< "$out" && ! grep -q Hunter2Secret <<< "$out"; then
  pass "a URI with a password is refused without repeating it: $(head -1 <<< "$out" | cut -c1-150)"
else fail "password URI: rc=$rc: $out"; fi

# ---- 2. two stations sync at once, the same tail N1EM, both land ----
"$E" sync --db a.db --to "$(uri fleet station_a)" --batch 3 > sync_a.txt 2>&1 & pa=$!
"$E" sync --db b.db --to "$(uri fleet station_b)" --batch 3 > sync_b.txt 2>&1 & pb=$!
wait $pa; ra=$?; wait $pb; rb=$?
cat sync_a.txt sync_b.txt
na=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_a'")
nb=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_b'")
n1=$(admin -c "SELECT count(*) FROM test_sessions WHERE tail_number = 'N1EM'")
if [ $ra -eq 0 ] && [ $rb -eq 0 ] && [ "$na" = "$(count a.db)" ] && [ "$nb" = "$(count b.db)" ] && [ "$n1" = 16 ]; then
  pass "concurrent syncs: station_a $na/$(count a.db), station_b $nb/$(count b.db) sessions; tail N1EM has $n1 from both stations"
else fail "concurrent syncs: rc $ra $rb, station_a $na/$(count a.db), station_b $nb/$(count b.db), N1EM $n1"; fi
# Everything of every session is there: findings, runs, samples, raw-log bytes per session match the station files.
server_detail() {
  admin -c "SELECT s.station_session_id, (SELECT count(*) FROM findings f WHERE f.session_id = s.session_id),
              (SELECT count(*) FROM runs r WHERE r.session_id = s.session_id),
              (SELECT count(*) FROM samples x JOIN runs r ON r.run_id = x.run_id WHERE r.session_id = s.session_id),
              (SELECT coalesce(sum(length(c.content)), 0) FROM raw_log_chunks c JOIN runs r ON r.run_id = c.run_id WHERE r.session_id = s.session_id),
              s.content_sha256
            FROM test_sessions s JOIN stations t ON t.station_uuid = s.station_uuid WHERE t.station_uuid = '$(sqlite3 "$1" "SELECT station_uuid FROM station_identity")'
            ORDER BY 1" | tr '|' ' '
}
station_detail() {
  sqlite3 "$1" "SELECT s.session_id, (SELECT count(*) FROM findings f WHERE f.session_id = s.session_id),
              (SELECT count(*) FROM runs r WHERE r.session_id = s.session_id),
              (SELECT count(*) FROM samples x JOIN runs r ON r.run_id = x.run_id WHERE r.session_id = s.session_id),
              (SELECT coalesce(sum(length(g.content)), 0) FROM raw_logs g JOIN runs r ON r.run_id = g.run_id WHERE r.session_id = s.session_id),
              s.content_sha256
            FROM test_sessions s ${2:-} ORDER BY 1" | tr '|' ' '
}
for s in a b; do
  if diff <(station_detail $s.db) <(server_detail $s.db) > /dev/null; then
    pass "station $s: every session on the server with all its findings, runs, samples and raw-log bytes ($(station_detail $s.db | awk '{f+=$2; r+=$3; x+=$4; b+=$5} END {print NR" sessions, "f" findings, "r" runs, "x" samples, "b" raw-log bytes"}'))"
  else fail "station $s: server differs: $(diff <(station_detail $s.db) <(server_detail $s.db) | head -5)"; fi
done
nd=$(admin -c "SELECT count(*) FROM discovery_findings d JOIN discovery_findings o ON d.amends_finding_id = o.finding_id WHERE o.summary = 'backlash 0.4 mrad'")
[ "$nd" = 1 ] && pass "discovery findings synced with the closing entry pointing to the one it closes" || fail "discovery findings: $nd"
ni=$(admin -c "SELECT count(*) FROM installations WHERE tail_number = 'N1EM'")
[ "$ni" = 3 ] && pass "installations synced: $ni on N1EM (LH-ELEV first serial, LH-ELEV change to NEW-1, RH-ELEV from station b)" || fail "installations: $ni"

# The summary tables the server keeps per COPY statement equal the station's, double for double.
for s in a b; do
  if out="$(python3 "$here/compare_summaries.py" $s.db "$(uri fleet station_$s)")"; then pass "station $s: $out"; else fail "station $s: $out"; fi
done

seed="0.$(printf '%04d' $((RANDOM % 10000)))"
if out="$(bash "$here/summary_equivalence.sh" "$seed" 2>&1)"; then pass "summaries per COPY statement = per row (schema 1), seed $seed: $(tr '\n' ';' <<< "$out")"
else fail "summary equivalence, seed $seed: $out"; fi

# ---- 3. a re-sync inserts nothing twice ----
out="$("$E" sync --db a.db --to "$(uri fleet station_a)" 2>&1)"; rc=$?
na2=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_a'")
if [ $rc -eq 0 ] && grep -q ": 0 session(s) pushed" <<< "$out" && [ "$na2" = "$na" ]; then pass "re-sync pushes nothing: $out"
else fail "re-sync: rc=$rc $out ($na2 vs $na)"; fi

# 60 sessions in batches of 2: the sync runs for seconds, so the lock below is taken long before its end
# however loaded the machine (with 20 in batches of 4 it could finish before the lock, and nothing was caught).
# ---- 4. kill -9 in the middle of a sync transaction, then re-sync: nothing lost, nothing twice ----
"$E" sync --db c.db --to "$(uri fleet station_c)" --batch 2 --verbose > sync_c1.txt 2>&1 & pc=$!
for _ in $(seq 1 200); do
  [ "$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_c'")" -ge 4 ] && break; sleep 0.05
done
# Hold the summary table the next batch writes last, so that the sync is caught inside its transaction.
( admin -c "BEGIN; LOCK TABLE session_measurements IN ACCESS EXCLUSIVE MODE; SELECT pg_sleep(20); COMMIT" > /dev/null 2>&1 ) & plock=$!
caught=0
for _ in $(seq 1 200); do
  if [ "$(admin -c "SELECT count(*) FROM pg_stat_activity WHERE usename = 'station_c' AND wait_event_type = 'Lock'")" -ge 1 ]; then caught=1; break; fi
  kill -0 $pc 2>/dev/null || break; sleep 0.05
done
inflight=$(admin -c "SELECT count(*) FROM pg_stat_activity WHERE usename = 'station_c' AND state = 'active'")
kill -9 $pc 2>/dev/null; wait $pc 2>/dev/null; rck=$?
admin -c "SELECT pg_cancel_backend(pid) FROM pg_stat_activity WHERE query LIKE '%pg_sleep(20)%' AND pid <> pg_backend_pid()" > /dev/null
wait $plock 2>/dev/null
for _ in $(seq 1 100); do [ "$(admin -c "SELECT count(*) FROM pg_stat_activity WHERE usename = 'station_c'")" = 0 ] && break; sleep 0.05; done
nc_server=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_c'")
nc_recorded=$(sqlite3 c.db "SELECT count(*) FROM synced_sessions")
cat sync_c1.txt
# The sync reads the next batch from the station while the server inserts this one: the batch read
# ahead when the kill came is neither on the server nor in the station's record.
ahead=$(grep -o 'sessions [0-9]*\.\.[0-9]* read ahead' sync_c1.txt | tail -1 | grep -o '[0-9][0-9]*' | head -1)
ahead_held=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_c' AND station_session_id >= ${ahead:-0}")
ahead_recorded=$(sqlite3 c.db "SELECT count(*) FROM synced_sessions WHERE session_id >= ${ahead:-0}")
echo "kill -9: sync caught inside its transaction: $caught (active backend: $inflight), exit status $rck; server has $nc_server of $(count c.db) sessions, station recorded $nc_recorded; the batch read ahead from session ${ahead:-none}: $ahead_held on the server, $ahead_recorded recorded"
if [ $caught = 1 ] && [ $rck = 137 ] && [ "$nc_server" -lt "$(count c.db)" ] && [ "$nc_recorded" -le "$nc_server" ] &&
   [ -n "$ahead" ] && [ "$ahead" -gt "$nc_server" ] && [ "$ahead_held" = 0 ] && [ "$ahead_recorded" = 0 ] &&
   diff <(station_detail c.db "WHERE s.session_id <= $nc_server") <(server_detail c.db) > /dev/null &&
   [ "$(admin -c "SELECT count(*) FROM session_measurements m JOIN test_sessions s ON s.session_id = m.session_id WHERE s.station_role = 'station_c'")" -le $((nc_server * 4)) ]; then
  pass "after kill -9 mid-transaction the server holds $nc_server whole sessions and no part of the killed batch nor of the one read ahead (from session $ahead); the station records $nc_recorded"
else fail "after kill -9: caught=$caught rc=$rck server=$nc_server recorded=$nc_recorded ahead=${ahead:-none} ($ahead_held held, $ahead_recorded recorded); $(diff <(station_detail c.db "WHERE s.session_id <= $nc_server") <(server_detail c.db) | head -3)"; fi
# The other window: the server committed, the station had not yet recorded it (kill between the two).
sqlite3 c.db "DELETE FROM synced_sessions WHERE session_id > (SELECT max(session_id) - 2 FROM synced_sessions)"
out="$("$E" sync --db c.db --to "$(uri fleet station_c)" --batch 4 2>&1)"; rc=$?
echo "$out"
nc2=$(admin -c "SELECT count(*) FROM test_sessions WHERE station_role = 'station_c'")
dup=$(admin -c "SELECT count(*) - count(DISTINCT (station_uuid, station_session_id)) FROM test_sessions")
if [ $rc -eq 0 ] && grep -q "2 already on the server" <<< "$out" && [ "$nc2" = "$(count c.db)" ] && [ "$dup" = 0 ] &&
   diff <(station_detail c.db) <(server_detail c.db) > /dev/null && [ "$(sqlite3 c.db "SELECT count(*) FROM synced_sessions")" = "$(count c.db)" ]; then
  pass "re-sync after kill -9: $nc2 of $(count c.db) sessions on the server, each whole, none twice ($dup duplicates); the station records all"
else fail "re-sync after kill -9: rc=$rc server=$nc2 dup=$dup"; fi

# ---- 5. least privilege: a station cannot alter another station's session (nor its own) ----
st() { psql -X -q -At "$(uri fleet "$1")" -c "$2" 2>&1; }
a_sid=$(admin -c "SELECT min(session_id) FROM test_sessions WHERE station_role = 'station_a'")
b_sid=$(admin -c "SELECT min(session_id) FROM test_sessions WHERE station_role = 'station_b'")
before=$(admin -c "SELECT md5(string_agg(t::text, '' ORDER BY session_id)) FROM test_sessions t")
check_refused() {  # what, expected message part, output
  if grep -q "$2" <<< "$3"; then pass "station_b $1: refused ($(grep -m1 ERROR <<< "$3"))"; else fail "station_b $1 was not refused: $3"; fi
}
check_refused "UPDATE of station_a's session" "permission denied" "$(st station_b "UPDATE test_sessions SET verdict = 'SERVICEABLE' WHERE session_id = $a_sid")"
check_refused "DELETE of station_a's session" "permission denied" "$(st station_b "DELETE FROM test_sessions WHERE session_id = $a_sid")"
check_refused "DELETE of station_a's findings" "permission denied" "$(st station_b "DELETE FROM findings WHERE session_id = $a_sid")"
check_refused "TRUNCATE of the findings" "permission denied" "$(st station_b "TRUNCATE findings")"
check_refused "UPDATE of its own session" "permission denied" "$(st station_b "UPDATE test_sessions SET verdict = 'SERVICEABLE' WHERE session_id = $b_sid")"
check_refused "UPDATE of the fleet summary" "permission denied" "$(st station_b "UPDATE series_stats SET n = 0")"
# Schema 5: the report's packed findings are written by the findings' trigger alone.
check_refused "INSERT of packed findings" "permission denied" "$(st station_b "INSERT INTO session_findings VALUES ('N1EM', $b_sid, '')")"
check_refused "UPDATE of packed findings" "permission denied" "$(st station_b "UPDATE session_findings SET findings = '' WHERE session_id = $a_sid")"
check_refused "DELETE of packed findings" "permission denied" "$(st station_b "DELETE FROM session_findings WHERE session_id = $a_sid")"
# Schema 6: so are the report's packed sessions, by the sessions' trigger.
check_refused "INSERT of a packed session" "permission denied" "$(st station_b "INSERT INTO session_rows VALUES ('N1EM', '2027-01-01T00:00:00Z', $b_sid, '')")"
check_refused "UPDATE of a packed session" "permission denied" "$(st station_b "UPDATE session_rows SET session = '' WHERE session_id = $a_sid")"
check_refused "DELETE of a packed session" "permission denied" "$(st station_b "DELETE FROM session_rows WHERE session_id = $a_sid")"
check_refused "INSERT of a finding into station_a's session" "violates foreign key" \
  "$(st station_b "INSERT INTO findings(session_id, parameter, estimator, limit_kind, status) VALUES ($a_sid, 'X', 'physics', 'none', 'WITHIN')")"
check_refused "INSERT of a finding into station_a's session posing as station_a" "permission denied" \
  "$(st station_b "INSERT INTO findings(session_id, station_role, parameter, estimator, limit_kind, status) VALUES ($a_sid, 'station_a', 'X', 'physics', 'none', 'WITHIN')")"
check_refused "INSERT of a session under station_a's station identity" "violates foreign key constraint \"test_sessions_station_uuid_station_role_fkey\"" \
  "$(st station_b "INSERT INTO test_sessions(session_uuid, station_uuid, station_session_id, tail_number, phase, started_utc, verdict, prev_sha256, content_sha256) SELECT gen_random_uuid(), station_uuid, 999999, 'N1EM', 'pre-flight', '2027-01-01T00:00:00Z', 'SERVICEABLE', '', repeat('0', 64) FROM stations WHERE station_role = 'station_a'")"
check_refused "INSERT of a session of a tail the fleet does not know" "violates foreign key constraint \"test_sessions_tail_number_fkey\"" \
  "$(st station_b "INSERT INTO test_sessions(session_uuid, station_uuid, station_session_id, tail_number, phase, started_utc, verdict, prev_sha256, content_sha256) SELECT gen_random_uuid(), station_uuid, 999999, 'N0NE', 'pre-flight', '2027-01-01T00:00:00Z', 'SERVICEABLE', '', repeat('0', 64) FROM stations WHERE station_role = 'station_b'")"
# Schema 4: a session's summary terms go in with the session; more terms for a session already summed are refused.
series_before=$(admin -c "SELECT md5(string_agg(t::text, '' ORDER BY tail_number, position, actuator_serial, parameter)) FROM series_stats t")
check_refused "INSERT of summary terms for its own session already synced" "violates foreign key constraint \"session_measurements_session_check\"" \
  "$(st station_b "INSERT INTO session_measurements(session_id, ordinal, sign, of_session_id, tail_number, position, actuator_serial, parameter, days, w, wy, wyy, value, std_error, limit_kind) SELECT session_id, 99, 1, session_id, tail_number, position, actuator_serial, 'FDJ_Nm', 20000, 1, 1, 1, 1, 1, 'none' FROM test_sessions WHERE session_id = $b_sid")"
[ "$series_before" = "$(admin -c "SELECT md5(string_agg(t::text, '' ORDER BY tail_number, position, actuator_serial, parameter)) FROM series_stats t")" ] &&
  pass "the fleet summary is unchanged after the refused terms" || fail "series_stats changed by refused terms"
check_refused "INSERT of a finding into its own session under another tail" "violates foreign key constraint \"findings_session_check\"" \
  "$(st station_b "INSERT INTO findings(session_id, parameter, estimator, limit_kind, status, tail_number) VALUES ($b_sid, 'Z', 'physics', 'none', 'WITHIN', 'N3EM')")"
# A finding as a sync older than schema 3 sends it (no tail): accepted, its tail taken from its session.
own="$(st station_b "INSERT INTO findings(session_id, parameter, estimator, limit_kind, status) VALUES ($b_sid, 'Y', 'physics', 'none', 'WITHIN')")"
filled=$(admin -c "SELECT f.tail_number || ' ' || (f.tail_number = s.tail_number) FROM findings f JOIN test_sessions s USING (session_id) WHERE f.session_id = $b_sid AND f.parameter = 'Y'")
[ -z "$own" ] && [ "${filled#* }" = true ] && pass "a finding without a tail into station_b's own session: accepted, tail ${filled% *} filled in from the session" ||
  fail "finding without a tail: '$own', tail '$filled'"
after=$(admin -c "SELECT md5(string_agg(t::text, '' ORDER BY session_id)) FROM test_sessions t")
reads=$(st station_b "SELECT count(*) FROM test_sessions")
[ "$before" = "$after" ] && [ "$reads" = "$(admin -c "SELECT count(*) FROM test_sessions")" ] &&
  pass "the sessions are unchanged; station_b reads the whole fleet ($reads sessions)" || fail "sessions changed or not readable ($reads)"
if grep -rqF -f "$PGWORK/passwords" "$PGWORK"/server.log sync_*.txt 2>/dev/null; then fail "a password appears in a log"; else pass "no password in the server log or the sync output"; fi

# ---- 6. report, fleet and trend print the same from PostgreSQL as from SQLite, byte for byte ----
"$E" sync --db a.db --to "$(uri fleet1 station_a)" > /dev/null || fail "sync to fleet1"
if out="$(python3 "$here/compare_summaries.py" a.db "$(uri fleet1 station_a)")"; then pass "fleet1: $out"; else fail "fleet1: $out"; fi
U="$(uri fleet1 station_a)"
same() {  # label, then the command's arguments after --db
  local label="$1"; shift
  local cmd="$1"; shift
  local lite pgout
  local file="${LITE:-a.db}"
  if [ -n "${CHANGED:-}" ]; then
    # The station file was changed outside the tool (CHANGED=1): its report says so (exit 5, a first
    # line "# RECORD CHANGED ..." in text, a last key "record_integrity" in JSON); the rest is compared.
    lite="$("$E" "$cmd" --db "$file" "$@" 2>/dev/null)"; local rc=$?
    [ $rc -eq 5 ] || { fail "$label from SQLite: exit $rc, not 5 (the record was changed outside the tool): $lite"; return; }
    lite="$(python3 -c 'import sys
t = sys.stdin.read()
if t.startswith("# RECORD CHANGED"): t = t.split("\n", 1)[1]
k = t.find(",\n  \"record_integrity\": ")
if k >= 0: t = t[:k] + "\n}\n"
sys.stdout.write(t)' <<< "$lite")"
  else
    lite="$("$E" "$cmd" --db "$file" "$@" 2>&1)" || { fail "$label from SQLite: $lite"; return; }
  fi
  pgout="$("$E" "$cmd" --db "$U" "$@" 2>&1)" || { fail "$label from PostgreSQL: $pgout"; return; }
  lite="${lite//"$file"/"$U"}"  # the one difference: the database is named as given
  if [ "$lite" = "$pgout" ]; then pass "$label: byte for byte the same ($(wc -c <<< "$pgout") bytes)"
  else fail "$label differs:"; diff <(echo "$lite") <(echo "$pgout") | head -10; fi
}
for fmt in text json csv; do
  same "report N1EM --format $fmt" report --tail N1EM --format "$fmt" --draws 500
  same "report N2EM --format $fmt" report --tail N2EM --format "$fmt" --draws 500
  same "fleet --format $fmt" fleet --format "$fmt" --draws 500
done
same "trend N1EM text" trend --tail N1EM --phase all --draws 500
same "trend N2EM json" trend --tail N2EM --format json --draws 500
out="$("$E" report --db "$U" --tail N9ZZ 2>&1)"; rc=$?
[ $rc -ne 0 ] && grep -q "is not in" <<< "$out" && pass "an unknown tail from PostgreSQL: $(head -1 <<< "$out" | cut -c1-120)" || fail "unknown tail: $out"
# A query that fails inside the report's pipeline (the tail's sessions, then its findings, in one round
# trip): the server's error comes out whole, the command fails at once (no wait for results that
# never come), and with the grant back the report is the same as before. (Schema 5: the report reads
# a tail's findings from session_findings.)
DB=fleet1 admin -c "REVOKE SELECT ON session_findings FROM emadiag_station"
out="$(timeout 60 "$E" report --db "$U" --tail N1EM 2>&1)"; rc=$?
DB=fleet1 admin -c "GRANT SELECT ON session_findings TO emadiag_station"
if [ $rc -ne 0 ] && [ $rc -ne 124 ] && grep -q "permission denied for table session_findings" <<< "$out" && grep -q "SQLSTATE 42501" <<< "$out"; then
  pass "an error inside the report's pipeline: exit $rc, $(grep -m1 -o 'fleet server: .*' <<< "$out" | cut -c1-140)"
else fail "an error inside the report's pipeline: exit $rc: $out"; fi
same "report N1EM --format json, the findings' grant given back" report --tail N1EM --format json --draws 500

# An actuator moved from one tail to another: the report reads its sessions on the other tail too
# (serial_seen_elsewhere, sessions_of_serial: by tails and ids on schema 3).
sim --db m.db --tail N1EM --position LH-ELEV --sessions 4 --serial S-MOVED
sim --db m.db --tail N2EM --position LH-ELEV --sessions 3 --serial S-MOVED --start-utc 2026-08-01T08:00:00Z
DB=postgres admin -c "CREATE DATABASE fleet2"
"$E" fleet-server --to "$(uri fleet2 fleet_admin)" > /dev/null || fail "fleet-server fleet2"
"$E" sync --db m.db --to "$(uri fleet2 station_c)" > /dev/null || fail "sync m.db to fleet2"
U="$(uri fleet2 station_c)"
for t in N1EM N2EM; do LITE=m.db same "report $t, its actuator S-MOVED also on the other tail" report --tail $t --format json --draws 500; done

# Findings added to a session by a later statement (the record allows it, the sync never does it): the
# server keeps them as a second packed row of the session, and the report reads both in (parameter,
# estimator) order. The late finding sorts before the session's own FDJ_Nm finding and has another
# limit: read in the wrong order, the limit of the series and its notes would differ. The same finding
# added to the station file: the reports are byte for byte the same.
sim --db d.db --tail N4EM --position LH-ELEV --sessions 5 --seed 11
DB=postgres admin -c "CREATE DATABASE fleet3"
"$E" fleet-server --to "$(uri fleet3 fleet_admin)" > /dev/null || fail "fleet-server fleet3"
"$E" sync --db d.db --to "$(uri fleet3 station_a)" > /dev/null || fail "sync d.db to fleet3"
late=$(sqlite3 d.db "SELECT min(session_id) + 2 FROM test_sessions")
late_finding="'FDJ_Nm', 'physics:aaa', 0.09, 0.01, 0.5, 'max', 'WITHIN', 'added later'"
sqlite3 d.db "INSERT INTO findings(tail_number, session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note)
              VALUES ('N4EM', $late, $late_finding)" || fail "late finding into d.db"
out="$(psql -X -q -At "$(uri fleet3 station_a)" -c "INSERT INTO findings(tail_number, session_id, parameter, estimator, value, std_error,
                     limit_value, limit_kind, status, note) SELECT 'N4EM', session_id, $late_finding FROM test_sessions
                     WHERE station_session_id = $late" 2>&1)"
rows=$(DB=fleet3 admin -c "SELECT count(*) FROM session_findings p JOIN test_sessions s USING (session_id) WHERE s.station_session_id = $late")
[ -z "$out" ] && [ "$rows" = 2 ] && pass "a finding added later to session $late: accepted, 2 packed rows for the session" ||
  fail "a finding added later: '$out', $rows packed rows"
U="$(uri fleet3 station_a)"
for fmt in text json; do LITE=d.db CHANGED=1 same "report N4EM --format $fmt, a finding added later to session $late" report --tail N4EM --format "$fmt" --draws 500; done

# ---- 7. a fleet server at every earlier schema version, with sessions, migrated to the newest ----
S="$here/../../maintenance_db/pg_schema"
newest=$(ls "$S"/*.sql | wc -l)
for v in $(seq 1 $((newest - 1))); do
  db="fleet_v$v"
  DB=postgres admin -c "CREATE DATABASE $db"
  for f in $(ls "$S"/*.sql | sort | head -$v); do DB=$db admin -f "$f" > /dev/null || fail "schema $f on $db"; done
  DB=$db admin -c "CREATE TABLE fleet_schema_version (version integer NOT NULL); INSERT INTO fleet_schema_version VALUES ($v);
                   GRANT SELECT ON fleet_schema_version TO emadiag_station"
  # The station syncs to the old server (this emadiag's sync writes what every version accepts), then
  # the server is migrated in place, and another station syncs to it, the same tail N1EM.
  "$E" sync --db a.db --to "$(uri $db station_a)" --batch 4 > "sync_v$v.txt" 2>&1 || fail "sync to schema $v: $(tail -2 sync_v$v.txt)"
  out="$("$E" fleet-server --to "$(uri $db fleet_admin)" 2>&1)" || fail "migrating $db: $out"
  "$E" sync --db b.db --to "$(uri $db station_b)" --batch 4 >> "sync_v$v.txt" 2>&1 || fail "sync after migrating $db: $(tail -2 sync_v$v.txt)"
  again="$("$E" sync --db a.db --to "$(uri $db station_a)" 2>&1)"
  got=$(DB=$db admin -c "SELECT (SELECT version FROM fleet_schema_version) || ' ' || count(*) FROM test_sessions")
  refused="$(psql -X -q -At "$(uri $db station_b)" -c "INSERT INTO findings(session_id, parameter, estimator, limit_kind, status) SELECT min(session_id), 'X', 'physics', 'none', 'WITHIN' FROM test_sessions WHERE station_role = 'station_a'" 2>&1)"
  if [ "$got" = "$newest $(( $(count a.db) + $(count b.db) ))" ] && grep -q ": 0 session(s) pushed" <<< "$again" && grep -q "violates foreign key" <<< "$refused" &&
     oa="$(python3 "$here/compare_summaries.py" a.db "$(uri $db station_a)")" && ob="$(python3 "$here/compare_summaries.py" b.db "$(uri $db station_b)")"; then
    pass "schema $v -> $newest with sessions on it: version and sessions '$got'; re-sync pushes nothing; a finding into another station's session refused; a: $oa; b: $ob"
  else fail "schema $v -> $newest: '$got' (want '$newest $(( $(count a.db) + $(count b.db) ))'); re-sync: $again; refused: $refused; a: ${oa:-}; b: ${ob:-}"; fi
done
U="$(uri fleet_v1 station_a)"
# N2EM is station a's alone (N1EM has sessions of station b too): its report equals the one from a.db.
for fmt in text json; do same "report N2EM --format $fmt from a server migrated from schema 1" report --tail N2EM --format "$fmt" --draws 500; done

echo "pg_tests: $fails failure(s)"
[ $fails -eq 0 ]
