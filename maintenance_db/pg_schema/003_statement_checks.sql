-- emadiag fleet server, schema version 3: what a sync costs the server per row, cut down.
-- Measured on 58,400 sessions (pg_stat_statements, auto_explain; bench/pg_scale_bench): of the
-- server's ~200 us per session, a quarter was the per-row foreign-key checks of the tables that
-- belong to a session (one SPI query and one row lock per finding, per measurement term, per
-- artifact: 525,640 of them) and a quarter the summary statement's sorts (each of its 18 ordered
-- aggregates sorted every series' terms again).
--
-- 1. A session's rows (runs, findings, session_artifacts, installations, session_measurements) are
--    tied to a session of the same role by one check per statement, not a foreign key per row: an
--    AFTER INSERT trigger over the statement's transition table looks each distinct
--    (session_id, station_role) up in test_sessions' primary key and refuses the statement with
--    SQLSTATE 23503 (foreign_key_violation) and the message of a foreign key when one is missing.
--    So a station still cannot add anything to another station's session (the privilege test).
--    What the per-row keys also did, lock the session against a concurrent DELETE, nobody needs:
--    a station can neither delete nor update (grants), and a session is inserted in the same
--    transaction as its rows. The unique key (session_id, station_role) these foreign keys
--    referenced goes too (one index fewer per session).
-- 2. A series' sums stay the station's left fold in the station's order, but as window sums over
--    the terms already sorted by series and order (one sort, shared by all of them), the starting
--    row's value added to the series' first term: sum(x) OVER (ORDER BY k) over a frame that is
--    the whole partition is float8pl folded in k order, as sum(x ORDER BY k) was. The sync sends
--    the terms sorted by series, so the statement's sorts find their input already in order.
-- 3. serial_seen_elsewhere (report) looks up (actuator_serial, tail_number): two index probes
--    instead of reading every session of the serial.

DO $$
DECLARE c record;
BEGIN
    FOR c IN SELECT conrelid::regclass AS tab, conname FROM pg_constraint
             WHERE contype = 'f' AND confrelid = 'test_sessions'::regclass
               AND conrelid IN ('runs'::regclass, 'findings'::regclass, 'session_artifacts'::regclass, 'installations'::regclass,
                                'session_measurements'::regclass) LOOP
        EXECUTE format('ALTER TABLE %s DROP CONSTRAINT %I', c.tab, c.conname);
    END LOOP;
END $$;
ALTER TABLE test_sessions DROP CONSTRAINT IF EXISTS test_sessions_session_id_station_role_key;

-- The planner cannot estimate a transition table; the lookups are index probes whatever its size.
CREATE FUNCTION check_rows_session() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public
    SET enable_hashjoin = off SET enable_mergejoin = off AS $$
DECLARE
    bad record;
BEGIN
    SELECT n.session_id, n.station_role INTO bad
    FROM (SELECT DISTINCT r.session_id, r.station_role FROM new_rows r) n
    WHERE NOT EXISTS (SELECT 1 FROM test_sessions s WHERE s.session_id = n.session_id AND s.station_role = n.station_role)
    LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "%" violates foreign key constraint "%_session_check"', TG_TABLE_NAME, TG_TABLE_NAME
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (session_id, station_role)=(%s, %s) is not present in table "test_sessions".', bad.session_id,
                                  bad.station_role);
    END IF;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION check_rows_session() FROM PUBLIC;

DO $$
DECLARE t text;
BEGIN
    FOREACH t IN ARRAY ARRAY['runs', 'session_artifacts', 'installations', 'session_measurements'] LOOP
        EXECUTE format('CREATE TRIGGER %I AFTER INSERT ON %I REFERENCING NEW TABLE AS new_rows FOR EACH STATEMENT '
                       'EXECUTE FUNCTION check_rows_session()', t || '_session_check', t);
    END LOOP;
END $$;

-- 4. Each finding keeps its session's tail, and an index by tail holds every column the report reads:
--    a tail's findings are one index range (an index-only scan), not a probe per session. A sync
--    of this version sends the tail (checked against the session's below); an older one does not,
--    and the check fills it in from the session.
--    That index is also the findings' key (a session has one tail, so (session_id, parameter,
--    estimator) stays unique), and replaces the primary key: one index per finding, not two.
ALTER TABLE findings ADD COLUMN tail_number text COLLATE "C";
UPDATE findings f SET tail_number = s.tail_number FROM test_sessions s WHERE s.session_id = f.session_id;
CREATE UNIQUE INDEX findings_by_tail ON findings(tail_number, session_id, parameter, estimator)
    INCLUDE (value, std_error, limit_value, limit_kind, status, note);
ALTER TABLE findings DROP CONSTRAINT findings_pkey;
CREATE INDEX findings_without_tail ON findings(session_id) WHERE tail_number IS NULL;  -- an older sync's rows, until filled in
GRANT INSERT (tail_number) ON findings TO emadiag_station;

CREATE FUNCTION check_findings_session() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public
    SET enable_hashjoin = off SET enable_mergejoin = off AS $$
DECLARE
    bad record;
BEGIN
    IF EXISTS (SELECT 1 FROM new_rows r WHERE r.tail_number IS NULL) THEN
        UPDATE findings f SET tail_number = s.tail_number FROM test_sessions s
        WHERE f.tail_number IS NULL AND s.session_id = f.session_id AND s.station_role = f.station_role;
    END IF;
    SELECT n.session_id, n.station_role, n.tail_number INTO bad
    FROM (SELECT DISTINCT r.session_id, r.station_role, r.tail_number FROM new_rows r) n
    WHERE NOT EXISTS (SELECT 1 FROM test_sessions s WHERE s.session_id = n.session_id AND s.station_role = n.station_role
                                                      AND (n.tail_number IS NULL OR s.tail_number = n.tail_number))
    LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "findings" violates foreign key constraint "findings_session_check"'
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (session_id, station_role, tail_number)=(%s, %s, %s) is not present in table "test_sessions".',
                                  bad.session_id, bad.station_role, bad.tail_number);
    END IF;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION check_findings_session() FROM PUBLIC;

DROP INDEX test_sessions_by_serial;
CREATE INDEX test_sessions_by_serial ON test_sessions(actuator_serial, tail_number, started_utc, session_id);

CREATE TRIGGER findings_session_check AFTER INSERT ON findings REFERENCING NEW TABLE AS new_rows FOR EACH STATEMENT
    EXECUTE FUNCTION check_findings_session();

-- The summary function of version 2 with its sums and "last" fields as window aggregates (see 2.).
CREATE OR REPLACE FUNCTION apply_measurements_batch() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public SET enable_nestloop = off AS $$
BEGIN
    PERFORM 1 FROM series_stats s
        WHERE (s.tail_number, s.position, s.actuator_serial, s.parameter) IN
              (SELECT n.tail_number, n.position, n.actuator_serial, n.parameter FROM new_measurements n)
        ORDER BY s.tail_number, s.position, s.actuator_serial, s.parameter FOR UPDATE;
    WITH m AS MATERIALIZED (  -- the terms in the station's order within each series: k = 1, 2, ...
        SELECT n.tail_number, n.position, n.actuator_serial, n.parameter, n.sign, n.days, n.w, n.wy, n.wyy, n.cycles, n.of_session_id,
               n.value, n.std_error, n.limit_kind, n.limit_value,
               row_number() OVER o AS k,
               (array_agg(n.cycles) FILTER (WHERE n.cycles IS NOT NULL) OVER (o ROWS BETWEEN UNBOUNDED PRECEDING AND UNBOUNDED FOLLOWING))[1]
                   AS batch_first_cycles
        FROM new_measurements n
        WINDOW o AS (PARTITION BY n.tail_number, n.position, n.actuator_serial, n.parameter ORDER BY n.session_id, n.ordinal)
    ), b AS MATERIALIZED (  -- each series' starting row: as stored, or as its first term creates it (k = 1, any sign)
        SELECT m.tail_number, m.position, m.actuator_serial, m.parameter, o.tail_number IS NOT NULL AS existed,
               CASE WHEN o.tail_number IS NULL THEN 2 ELSE 1 END AS first_term,
               CASE WHEN o.tail_number IS NULL THEN m.sign ELSE o.n END AS n,
               CASE WHEN o.tail_number IS NULL THEN m.days ELSE o.first_days END AS first_days,
               CASE WHEN o.tail_number IS NULL THEN m.days ELSE o.last_days END AS last_days,
               CASE WHEN o.tail_number IS NULL THEN m.w ELSE o.s_w END AS s_w,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.s_wt END AS s_wt,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.s_wtt END AS s_wtt,
               CASE WHEN o.tail_number IS NULL THEN m.wy ELSE o.s_wy END AS s_wy,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.s_wty END AS s_wty,
               CASE WHEN o.tail_number IS NULL THEN m.wyy ELSE o.s_wyy END AS s_wyy,
               CASE WHEN o.tail_number IS NULL THEN CASE WHEN m.cycles IS NULL THEN 0 ELSE m.sign END ELSE o.n_cycles END AS n_cycles,
               -- first_cycles once the batch is in: as stored, else the first term's with cycles
               coalesce(CASE WHEN o.tail_number IS NULL THEN m.cycles ELSE o.first_cycles END, m.batch_first_cycles) AS first_cycles,
               CASE WHEN o.tail_number IS NULL THEN m.cycles ELSE o.last_cycles END AS last_cycles,
               CASE WHEN o.tail_number IS NULL THEN CASE WHEN m.cycles IS NULL THEN 0 ELSE m.w END ELSE o.c_w END AS c_w,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.c_wt END AS c_wt,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.c_wtt END AS c_wtt,
               CASE WHEN o.tail_number IS NULL THEN CASE WHEN m.cycles IS NULL THEN 0 ELSE m.wy END ELSE o.c_wy END AS c_wy,
               CASE WHEN o.tail_number IS NULL THEN 0 ELSE o.c_wty END AS c_wty,
               CASE WHEN o.tail_number IS NULL THEN CASE WHEN m.cycles IS NULL THEN 0 ELSE m.wyy END ELSE o.c_wyy END AS c_wyy,
               CASE WHEN o.tail_number IS NULL THEN m.of_session_id ELSE o.last_session_id END AS last_session_id,
               CASE WHEN o.tail_number IS NULL THEN m.value ELSE o.last_value END AS last_value,
               CASE WHEN o.tail_number IS NULL THEN m.std_error ELSE o.last_std_error END AS last_std_error,
               CASE WHEN o.tail_number IS NULL THEN m.limit_kind ELSE o.limit_kind END AS limit_kind,
               CASE WHEN o.tail_number IS NULL THEN m.limit_value ELSE o.limit_value END AS limit_value
        FROM m LEFT JOIN series_stats o
            ON (o.tail_number, o.position, o.actuator_serial, o.parameter) = (m.tail_number, m.position, m.actuator_serial, m.parameter)
        WHERE m.k = 1
    ), t AS (  -- the terms added to the starting row, with the station's addends
        SELECT m.tail_number, m.position, m.actuator_serial, m.parameter, m.k, m.sign, m.days, m.cycles, m.of_session_id, m.value,
               m.std_error, m.limit_kind, m.limit_value, m.w, m.wy, m.wyy,
               m.w * (m.days - b.first_days) AS wt, m.w * (m.days - b.first_days) * (m.days - b.first_days) AS wtt,
               m.wy * (m.days - b.first_days) AS wty,
               m.w * (m.cycles - b.first_cycles) AS cwt, m.w * (m.cycles - b.first_cycles) * (m.cycles - b.first_cycles) AS cwtt,
               m.wy * (m.cycles - b.first_cycles) AS cwty,
               m.sign > 0 AND m.days >= greatest(b.last_days, max(m.days) FILTER (WHERE m.sign > 0) OVER (
                   PARTITION BY m.tail_number, m.position, m.actuator_serial, m.parameter ORDER BY m.k
                   ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING)) AS becomes_last,
               m.k = b.first_term AS first,  -- the starting row's sums are added to the first term
               m.k = min(m.k) FILTER (WHERE m.cycles IS NOT NULL) OVER (PARTITION BY m.tail_number, m.position, m.actuator_serial, m.parameter)
                   AS first_with_cycles,     -- and its cycle sums to the first term with cycles
               b.s_w AS b_s_w, b.s_wt AS b_s_wt, b.s_wtt AS b_s_wtt, b.s_wy AS b_s_wy, b.s_wty AS b_s_wty, b.s_wyy AS b_s_wyy,
               b.c_w AS b_c_w, b.c_wt AS b_c_wt, b.c_wtt AS b_c_wtt, b.c_wy AS b_c_wy, b.c_wty AS b_c_wty, b.c_wyy AS b_c_wyy
        FROM m JOIN b USING (tail_number, position, actuator_serial, parameter)
        WHERE m.k >= b.first_term
    ), x AS (  -- per series: the sums (folded in k order from the starting row) and the fields of the last term that replaced "last"
        SELECT * FROM (
            SELECT t.tail_number, t.position, t.actuator_serial, t.parameter, t.first,
                   sum(CASE WHEN t.first THEN t.b_s_w + t.w ELSE t.w END) OVER w AS s_w,
                   sum(CASE WHEN t.first THEN t.b_s_wt + t.wt ELSE t.wt END) OVER w AS s_wt,
                   sum(CASE WHEN t.first THEN t.b_s_wtt + t.wtt ELSE t.wtt END) OVER w AS s_wtt,
                   sum(CASE WHEN t.first THEN t.b_s_wy + t.wy ELSE t.wy END) OVER w AS s_wy,
                   sum(CASE WHEN t.first THEN t.b_s_wty + t.wty ELSE t.wty END) OVER w AS s_wty,
                   sum(CASE WHEN t.first THEN t.b_s_wyy + t.wyy ELSE t.wyy END) OVER w AS s_wyy,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_w + t.w ELSE t.w END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_w,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_wt + t.cwt ELSE t.cwt END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_wt,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_wtt + t.cwtt ELSE t.cwtt END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_wtt,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_wy + t.wy ELSE t.wy END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_wy,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_wty + t.cwty ELSE t.cwty END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_wty,
                   sum(CASE WHEN t.first_with_cycles THEN t.b_c_wyy + t.wyy ELSE t.wyy END) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS c_wyy,
                   sum(t.sign) OVER w AS n, sum(t.sign) FILTER (WHERE t.cycles IS NOT NULL) OVER w AS n_cycles,
                   max(t.days) FILTER (WHERE t.sign > 0) OVER w AS last_days,
                   bool_or(t.becomes_last) OVER w AS replaced,
                   array_agg(t.of_session_id) FILTER (WHERE t.becomes_last) OVER w AS a_session_id,
                   array_agg(t.value) FILTER (WHERE t.becomes_last) OVER w AS a_value,
                   array_agg(t.std_error) FILTER (WHERE t.becomes_last) OVER w AS a_std_error,
                   array_agg(t.limit_kind) FILTER (WHERE t.becomes_last) OVER w AS a_limit_kind,
                   array_agg(t.limit_value) FILTER (WHERE t.becomes_last) OVER w AS a_limit_value,
                   array_agg(t.cycles) FILTER (WHERE t.becomes_last AND t.cycles IS NOT NULL) OVER w AS a_cycles
            FROM t
            WINDOW w AS (PARTITION BY t.tail_number, t.position, t.actuator_serial, t.parameter ORDER BY t.k
                         ROWS BETWEEN UNBOUNDED PRECEDING AND UNBOUNDED FOLLOWING)
        ) y WHERE y.first
    ), r AS (
        SELECT b.tail_number, b.position, b.actuator_serial, b.parameter, b.existed,
               b.n + coalesce(x.n, 0) AS n, b.first_days, greatest(b.last_days, x.last_days) AS last_days,
               coalesce(x.s_w, b.s_w) AS s_w, coalesce(x.s_wt, b.s_wt) AS s_wt, coalesce(x.s_wtt, b.s_wtt) AS s_wtt,
               coalesce(x.s_wy, b.s_wy) AS s_wy, coalesce(x.s_wty, b.s_wty) AS s_wty, coalesce(x.s_wyy, b.s_wyy) AS s_wyy,
               b.n_cycles + coalesce(x.n_cycles, 0) AS n_cycles, b.first_cycles,
               coalesce(x.a_cycles[array_upper(x.a_cycles, 1)], b.last_cycles) AS last_cycles,
               coalesce(x.c_w, b.c_w) AS c_w, coalesce(x.c_wt, b.c_wt) AS c_wt, coalesce(x.c_wtt, b.c_wtt) AS c_wtt,
               coalesce(x.c_wy, b.c_wy) AS c_wy, coalesce(x.c_wty, b.c_wty) AS c_wty, coalesce(x.c_wyy, b.c_wyy) AS c_wyy,
               CASE WHEN x.replaced THEN x.a_session_id[array_upper(x.a_session_id, 1)] ELSE b.last_session_id END AS last_session_id,
               CASE WHEN x.replaced THEN x.a_value[array_upper(x.a_value, 1)] ELSE b.last_value END AS last_value,
               CASE WHEN x.replaced THEN x.a_std_error[array_upper(x.a_std_error, 1)] ELSE b.last_std_error END AS last_std_error,
               CASE WHEN x.replaced THEN x.a_limit_kind[array_upper(x.a_limit_kind, 1)] ELSE b.limit_kind END AS limit_kind,
               CASE WHEN x.replaced THEN x.a_limit_value[array_upper(x.a_limit_value, 1)] ELSE b.limit_value END AS limit_value
        FROM b LEFT JOIN x USING (tail_number, position, actuator_serial, parameter)
    ), upd AS (
        UPDATE series_stats o SET n = r.n, last_days = r.last_days, s_w = r.s_w, s_wt = r.s_wt, s_wtt = r.s_wtt, s_wy = r.s_wy,
               s_wty = r.s_wty, s_wyy = r.s_wyy, n_cycles = r.n_cycles, first_cycles = r.first_cycles, last_cycles = r.last_cycles,
               c_w = r.c_w, c_wt = r.c_wt, c_wtt = r.c_wtt, c_wy = r.c_wy, c_wty = r.c_wty, c_wyy = r.c_wyy,
               last_session_id = r.last_session_id, last_value = r.last_value, last_std_error = r.last_std_error,
               limit_kind = r.limit_kind, limit_value = r.limit_value
        FROM r
        WHERE r.existed AND (o.tail_number, o.position, o.actuator_serial, o.parameter) = (r.tail_number, r.position, r.actuator_serial, r.parameter)
    )
    INSERT INTO series_stats (tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, s_wy, s_wty,
                              s_wyy, n_cycles, first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, last_session_id,
                              last_value, last_std_error, limit_kind, limit_value)
    SELECT tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, s_wy, s_wty, s_wyy, n_cycles,
           first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, last_session_id, last_value, last_std_error, limit_kind,
           limit_value
    FROM r WHERE NOT r.existed;
    RETURN NULL;
END $$;
