#!/usr/bin/env bash
# The summary tables kept per statement (pg_schema/002, and 003's window sums) against those kept
# per row (pg_schema/001, the station's add_to_summaries expression for expression): the same random
# sessions and measurements (signs -1 and +1, cycles or none, dates in any order, new and existing
# series and positions) inserted batch by batch into a schema-1, a schema-2 and a newest-schema (3 and on) database
# must leave identical series_stats and position_status, every double's shortest exact text equal. Run by pg_tests.sh on
# the server run_pg_tests.sh started:   summary_equivalence.sh SEED   (SEED in [-1, 1], printed)
set -euo pipefail
S="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../maintenance_db/pg_schema" && pwd)"
a() { psql -X -q -At -v ON_ERROR_STOP=1 "postgresql:///$1?host=$PGSOCK&user=fleet_admin" "${@:2}"; }
a postgres -c "CREATE DATABASE ta" -c "CREATE DATABASE tb" -c "CREATE DATABASE tc" > /dev/null
a ta -f $S/001_fleet.sql; a tb -f $S/001_fleet.sql; a tb -f $S/002_batch_summaries.sql
# tc: every version from 3 on (the newest summary statement; 004 changed the tables' storage, not the sums).
for f in $(ls "$S"/*.sql | sort); do a tc -f "$f"; done
# The terms go in before their sessions here: the check that each term's session exists (schema 3 on) is off.
a tc -c "ALTER TABLE session_measurements DISABLE TRIGGER session_measurements_session_check" > /dev/null
seed=${1:-0.42}
for db in ta tb tc; do
a $db > /dev/null <<SQL
SET client_min_messages = warning;
ALTER TABLE session_measurements DROP CONSTRAINT IF EXISTS session_measurements_session_id_station_role_fkey;
INSERT INTO stations(station_uuid) VALUES ('00000000-0000-0000-0000-000000000001');
INSERT INTO aircraft SELECT 'T' || i FROM generate_series(1, 3) i;
INSERT INTO positions VALUES ('P1', '27-10', ''), ('P2', '27-20', '');
SELECT setseed($seed);
CREATE TABLE src AS
  SELECT (s / 7) AS batch, s AS session_id, o AS ordinal,
         CASE WHEN random() < 0.15 THEN -1 ELSE 1 END AS sign,
         'T' || (1 + floor(random() * 3)::int) AS tail, CASE WHEN random() < 0.5 THEN 'P1' ELSE '' END AS pos,
         'SN' || floor(random() * 2)::int AS serial, 'p' || floor(random() * 3)::int AS par,
         20000 + floor(random() * 40) + floor(random() * 4) / 4.0 AS days,
         0.001 + random() * 0.01 AS se, random() AS v,
         CASE WHEN random() < 0.3 THEN NULL ELSE floor(random() * 5000) END AS cyc,
         CASE WHEN random() < 0.5 THEN 'max' ELSE 'none' END AS lk
  FROM generate_series(1, 400) s, generate_series(0, 2) o;
CREATE TABLE ssrc AS
  SELECT s / 5 AS batch, s AS session_id, 'T' || (1 + floor(random() * 3)::int) AS tail,
         CASE WHEN random() < 0.3 THEN NULL WHEN random() < 0.5 THEN 'P1' ELSE 'P2' END AS pos,
         'SN' || floor(random() * 2)::int AS serial,
         '2026-0' || (1 + floor(random() * 3)::int) || '-1' || floor(random() * 10)::int || 'T00:00:00Z' AS utc,
         CASE WHEN random() < 0.5 THEN 'SERVICEABLE' ELSE 'UNSERVICEABLE' END AS verdict,
         CASE WHEN random() < 0.4 THEN NULL ELSE floor(random() * 900)::bigint END AS cyc
  FROM generate_series(1, 300) s;
SQL
for b in $(seq 0 60); do
a $db -c "INSERT INTO session_measurements (session_id, ordinal, sign, of_session_id, tail_number, position, actuator_serial, parameter, days, w, wy, wyy, cycles, value, std_error, limit_kind, limit_value)
  SELECT session_id, ordinal, sign, session_id, tail, pos, serial, par, days, sign / (se * se), (sign / (se * se)) * v, (sign / (se * se)) * v * v, cyc, v, se, lk,
         CASE WHEN lk = 'max' THEN 0.5 END FROM src WHERE batch = $b ORDER BY session_id, ordinal" \
  -c "INSERT INTO test_sessions (session_id, session_uuid, station_uuid, station_session_id, tail_number, position, actuator_serial, phase, started_utc, cycles, verdict, prev_sha256, content_sha256)
  SELECT session_id, gen_random_uuid(), '00000000-0000-0000-0000-000000000001', session_id, tail, pos, serial, 'pre-flight', utc, cyc, verdict, '', repeat('0', 64) FROM ssrc WHERE batch = $b ORDER BY session_id"
done
done
for t in series_stats position_status; do
  x=$(a ta -c "SELECT count(*), md5(string_agg(t::text, '|' ORDER BY t::text)) FROM $t t")
  for db in tb tc; do
    y=$(a $db -c "SELECT count(*), md5(string_agg(t::text, '|' ORDER BY t::text)) FROM $t t")
    [ "$x" = "$y" ] || { echo "$t differs (seed $seed): per row $x, per statement ($db) $y"; diff <(a ta -c "SELECT * FROM $t ORDER BY 1,2,3") <(a $db -c "SELECT * FROM $t ORDER BY 1,2,3") | head -10; exit 1; }
  done
  echo "$t: ${x%%|*} rows, identical per row (schema 1) and per statement (schema 2 and schema $(ls "$S"/*.sql | wc -l)) (md5 ${x#*|})"
done
