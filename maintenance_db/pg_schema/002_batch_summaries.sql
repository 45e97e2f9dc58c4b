-- emadiag fleet server, schema version 2: the summary tables are kept per statement, not per row.
-- Version 1 applied every session measurement and every session to series_stats and position_status
-- with one upsert per row (about 30 us each, and as many row versions of a series as a batch has
-- sessions of it): most of what a sync cost the server. Here one statement-level trigger per COPY
-- reads the whole batch from its transition table and writes each summary row it touches once.
--
-- The station's arithmetic stays exact: the station adds a series' terms one after the other
-- (add_to_summaries in maintenance_db/src/test_session_store.cpp), and so does sum(x ORDER BY k)
-- here (float8 sum is a left fold with float8pl, in the ORDER BY order), starting from the stored
-- row (k = 0) or, for a series the batch creates, from the row its first term creates. The terms are
-- taken in the order the station applied them: by fleet session id (assigned in the station's order),
-- then by ordinal (an amended session's terms out, then the session's own in).
--
-- A term replaces a series' "last" fields when it is positive and not older than every earlier
-- one (days >= the running last_days); the fields of the last such term win, and last_cycles is
-- that of the last such term with cycles. position_status: the same with started_utc.
--
-- Concurrency: the rows a statement updates are locked first, in key order, so two stations syncing
-- the same tail wait for each other (and never deadlock on these rows); two stations creating the
-- same series at once: the second fails with a unique violation, and its sync retries the batch.
--
-- The functions run with enable_nestloop off: the planner cannot estimate how many rows the CTEs
-- over a transition table give (it guessed 200 for 40,000) and chose nested loops over them, which
-- took minutes for one batch; hash joins take milliseconds for any batch size.

DROP TRIGGER session_measurements_apply ON session_measurements;
DROP FUNCTION apply_session_measurement();
DROP TRIGGER test_sessions_position ON test_sessions;
DROP FUNCTION apply_session_position();

CREATE FUNCTION apply_measurements_batch() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public SET enable_nestloop = off AS $$
BEGIN
    PERFORM 1 FROM series_stats s
        WHERE (s.tail_number, s.position, s.actuator_serial, s.parameter) IN
              (SELECT n.tail_number, n.position, n.actuator_serial, n.parameter FROM new_measurements n)
        ORDER BY s.tail_number, s.position, s.actuator_serial, s.parameter FOR UPDATE;
    WITH m AS (
        SELECT n.*, row_number() OVER (PARTITION BY n.tail_number, n.position, n.actuator_serial, n.parameter
                                       ORDER BY n.session_id, n.ordinal) AS k
        FROM new_measurements n
    ), b AS (  -- each series' starting row: as stored, or as its first term creates it (k = 1, any sign)
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
               CASE WHEN o.tail_number IS NULL THEN m.cycles ELSE o.first_cycles END AS first_cycles,
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
    ), fc AS (  -- first_cycles once the batch is in: as stored, else the first term's with cycles
        SELECT b.tail_number, b.position, b.actuator_serial, b.parameter, coalesce(b.first_cycles, f.first_cycles) AS first_cycles
        FROM b JOIN (SELECT m.tail_number, m.position, m.actuator_serial, m.parameter,
                            (array_agg(m.cycles ORDER BY m.k) FILTER (WHERE m.cycles IS NOT NULL))[1] AS first_cycles
                     FROM m GROUP BY m.tail_number, m.position, m.actuator_serial, m.parameter) f
                USING (tail_number, position, actuator_serial, parameter)
    ), t AS (  -- the terms added to the starting row, with the station's addends
        SELECT m.tail_number, m.position, m.actuator_serial, m.parameter, m.k, m.sign, m.days, m.cycles, m.of_session_id, m.value,
               m.std_error, m.limit_kind, m.limit_value, m.w, m.wy, m.wyy,
               m.w * (m.days - b.first_days) AS wt, m.w * (m.days - b.first_days) * (m.days - b.first_days) AS wtt,
               m.wy * (m.days - b.first_days) AS wty,
               m.w * (m.cycles - fc.first_cycles) AS cwt, m.w * (m.cycles - fc.first_cycles) * (m.cycles - fc.first_cycles) AS cwtt,
               m.wy * (m.cycles - fc.first_cycles) AS cwty,
               m.sign > 0 AND m.days >= greatest(b.last_days, max(m.days) FILTER (WHERE m.sign > 0) OVER (
                   PARTITION BY m.tail_number, m.position, m.actuator_serial, m.parameter ORDER BY m.k
                   ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING)) AS becomes_last
        FROM m JOIN b USING (tail_number, position, actuator_serial, parameter) JOIN fc USING (tail_number, position, actuator_serial, parameter)
        WHERE m.k >= b.first_term
    ), e AS (  -- the elements summed in order: the starting row (k = 0), then the terms
        SELECT tail_number, position, actuator_serial, parameter, 0::bigint AS k, true AS has_cycles,
               s_w, s_wt, s_wtt, s_wy, s_wty, s_wyy, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy
        FROM b
        UNION ALL
        SELECT tail_number, position, actuator_serial, parameter, k, cycles IS NOT NULL, w, wt, wtt, wy, wty, wyy, w, cwt, cwtt, wy, cwty, wyy
        FROM t
    ), sums AS (
        SELECT tail_number, position, actuator_serial, parameter,
               sum(s_w ORDER BY k) AS s_w, sum(s_wt ORDER BY k) AS s_wt, sum(s_wtt ORDER BY k) AS s_wtt,
               sum(s_wy ORDER BY k) AS s_wy, sum(s_wty ORDER BY k) AS s_wty, sum(s_wyy ORDER BY k) AS s_wyy,
               sum(c_w ORDER BY k) FILTER (WHERE has_cycles) AS c_w, sum(c_wt ORDER BY k) FILTER (WHERE has_cycles) AS c_wt,
               sum(c_wtt ORDER BY k) FILTER (WHERE has_cycles) AS c_wtt, sum(c_wy ORDER BY k) FILTER (WHERE has_cycles) AS c_wy,
               sum(c_wty ORDER BY k) FILTER (WHERE has_cycles) AS c_wty, sum(c_wyy ORDER BY k) FILTER (WHERE has_cycles) AS c_wyy
        FROM e GROUP BY tail_number, position, actuator_serial, parameter
    ), lasts AS (
        SELECT tail_number, position, actuator_serial, parameter, sum(sign) AS n, sum(sign) FILTER (WHERE cycles IS NOT NULL) AS n_cycles,
               max(days) FILTER (WHERE sign > 0) AS last_days,
               (array_agg(of_session_id ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS last_session_id,
               (array_agg(value ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS last_value,
               (array_agg(std_error ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS last_std_error,
               (array_agg(limit_kind ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS limit_kind,
               (array_agg(limit_value ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS limit_value,
               bool_or(becomes_last) AS replaced,
               (array_agg(cycles ORDER BY k DESC) FILTER (WHERE becomes_last AND cycles IS NOT NULL))[1] AS last_cycles
        FROM t GROUP BY tail_number, position, actuator_serial, parameter
    ), r AS (
        SELECT b.tail_number, b.position, b.actuator_serial, b.parameter, b.existed,
               b.n + coalesce(l.n, 0) AS n, b.first_days, greatest(b.last_days, l.last_days) AS last_days,
               s.s_w, s.s_wt, s.s_wtt, s.s_wy, s.s_wty, s.s_wyy,
               b.n_cycles + coalesce(l.n_cycles, 0) AS n_cycles, fc.first_cycles, coalesce(l.last_cycles, b.last_cycles) AS last_cycles,
               s.c_w, s.c_wt, s.c_wtt, s.c_wy, s.c_wty, s.c_wyy,
               CASE WHEN l.replaced THEN l.last_session_id ELSE b.last_session_id END AS last_session_id,
               CASE WHEN l.replaced THEN l.last_value ELSE b.last_value END AS last_value,
               CASE WHEN l.replaced THEN l.last_std_error ELSE b.last_std_error END AS last_std_error,
               CASE WHEN l.replaced THEN l.limit_kind ELSE b.limit_kind END AS limit_kind,
               CASE WHEN l.replaced THEN l.limit_value ELSE b.limit_value END AS limit_value
        FROM b JOIN sums s USING (tail_number, position, actuator_serial, parameter)
               JOIN fc USING (tail_number, position, actuator_serial, parameter)
               LEFT JOIN lasts l USING (tail_number, position, actuator_serial, parameter)
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
CREATE TRIGGER session_measurements_apply AFTER INSERT ON session_measurements
    REFERENCING NEW TABLE AS new_measurements FOR EACH STATEMENT EXECUTE FUNCTION apply_measurements_batch();

CREATE FUNCTION apply_sessions_batch() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public SET enable_nestloop = off AS $$
BEGIN
    PERFORM 1 FROM position_status p
        WHERE (p.tail_number, p.position) IN (SELECT n.tail_number, coalesce(n.position, '') FROM new_sessions n)
        ORDER BY p.tail_number, p.position FOR UPDATE;
    WITH m AS (
        SELECT n.tail_number, coalesce(n.position, '') AS position, n.actuator_serial, n.session_id, n.started_utc, n.verdict, n.cycles,
               row_number() OVER (PARTITION BY n.tail_number, coalesce(n.position, '') ORDER BY n.session_id) AS k
        FROM new_sessions n
    ), b AS (
        SELECT m.tail_number, m.position, o.tail_number IS NOT NULL AS existed,
               CASE WHEN o.tail_number IS NULL THEN 2 ELSE 1 END AS first_term,
               CASE WHEN o.tail_number IS NULL THEN 1 ELSE o.sessions END AS sessions,
               CASE WHEN o.tail_number IS NULL THEN m.actuator_serial ELSE o.actuator_serial END AS actuator_serial,
               CASE WHEN o.tail_number IS NULL THEN m.session_id ELSE o.last_session_id END AS last_session_id,
               CASE WHEN o.tail_number IS NULL THEN m.started_utc ELSE o.last_utc END AS last_utc,
               CASE WHEN o.tail_number IS NULL THEN m.verdict ELSE o.last_verdict END AS last_verdict,
               CASE WHEN o.tail_number IS NULL THEN m.cycles ELSE o.last_cycles END AS last_cycles
        FROM m LEFT JOIN position_status o ON (o.tail_number, o.position) = (m.tail_number, m.position)
        WHERE m.k = 1
    ), t AS (
        SELECT m.*, m.started_utc >= greatest(b.last_utc, max(m.started_utc) OVER (PARTITION BY m.tail_number, m.position ORDER BY m.k
                                                             ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING)) AS becomes_last
        FROM m JOIN b USING (tail_number, position)
        WHERE m.k >= b.first_term
    ), l AS (
        SELECT tail_number, position, count(*) AS sessions, max(started_utc) AS last_utc, bool_or(becomes_last) AS replaced,
               (array_agg(actuator_serial ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS actuator_serial,
               (array_agg(session_id ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS last_session_id,
               (array_agg(verdict ORDER BY k DESC) FILTER (WHERE becomes_last))[1] AS last_verdict,
               (array_agg(cycles ORDER BY k DESC) FILTER (WHERE becomes_last AND cycles IS NOT NULL))[1] AS last_cycles
        FROM t GROUP BY tail_number, position
    ), r AS (
        SELECT b.tail_number, b.position, b.existed, b.sessions + coalesce(l.sessions, 0) AS sessions,
               CASE WHEN l.replaced THEN l.actuator_serial ELSE b.actuator_serial END AS actuator_serial,
               CASE WHEN l.replaced THEN l.last_session_id ELSE b.last_session_id END AS last_session_id,
               greatest(b.last_utc, l.last_utc) AS last_utc,
               CASE WHEN l.replaced THEN l.last_verdict ELSE b.last_verdict END AS last_verdict,
               coalesce(l.last_cycles, b.last_cycles) AS last_cycles
        FROM b LEFT JOIN l USING (tail_number, position)
    ), upd AS (
        UPDATE position_status o SET sessions = r.sessions, actuator_serial = r.actuator_serial, last_session_id = r.last_session_id,
               last_utc = r.last_utc, last_verdict = r.last_verdict, last_cycles = r.last_cycles
        FROM r WHERE r.existed AND (o.tail_number, o.position) = (r.tail_number, r.position)
    )
    INSERT INTO position_status (tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, last_cycles)
    SELECT tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, last_cycles FROM r WHERE NOT r.existed;
    RETURN NULL;
END $$;
CREATE TRIGGER test_sessions_position AFTER INSERT ON test_sessions
    REFERENCING NEW TABLE AS new_sessions FOR EACH STATEMENT EXECUTE FUNCTION apply_sessions_batch();

REVOKE EXECUTE ON FUNCTION apply_measurements_batch(), apply_sessions_batch() FROM PUBLIC;
