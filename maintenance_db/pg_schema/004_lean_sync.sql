-- emadiag fleet server, schema version 4: a sync's cost per session no longer grows with the fleet.
-- Measured on the full-size synthetic fleet (1,000 tails x 4 positions; the first 570,000 of its
-- 5.84 M sessions, batches of 10,000; pg_stat_statements and auto_explain):
--  * series_stats and position_status: every batch rewrites every row it touches (with 1,000 tails a
--    batch touches all 16,000 series), and none of those updates was HOT (9,896 of 848,000): full
--    pages, so each new row version went to another page with a new index entry. The table grew to
--    113 MB for 16,000 rows, and the summary statement's scans of it (the row locks, the join to
--    the stored rows) read all of it: 250 of its ~1,250 ms per batch.
--  * test_sessions: three foreign keys (aircraft, positions, stations) checked per row: three SPI
--    queries and three row locks per session (2.3 s of server time per 570,000 sessions).
--  * session_measurements: a primary key (session_id, ordinal) that nothing reads, 126 bytes per
--    session.
--
-- 1. The summary tables keep room on every page (fillfactor 30): an update that changes no key
--    column stays on its page (a HOT update, no new index entry), and the page's dead versions are
--    pruned when it is next read, so the tables stay at their live size. Rewritten once here.
ALTER TABLE series_stats SET (fillfactor = 30);
ALTER TABLE position_status SET (fillfactor = 30);
CLUSTER series_stats USING series_stats_pkey;
CLUSTER position_status USING position_status_pkey;

-- 2. A session's tail, position and station are checked once per statement (as version 3 does for a
--    session's rows): each distinct value of the statement's sessions looked up in its table's
--    key, the statement refused with SQLSTATE 23503 and a foreign key's message when one is
--    missing. Nobody can delete an aircraft, a position or a station a session names: stations
--    have no DELETE, and the owner removes nothing.
ALTER TABLE test_sessions DROP CONSTRAINT IF EXISTS test_sessions_tail_number_fkey;
ALTER TABLE test_sessions DROP CONSTRAINT IF EXISTS test_sessions_position_fkey;
ALTER TABLE test_sessions DROP CONSTRAINT IF EXISTS test_sessions_station_uuid_station_role_fkey;

CREATE FUNCTION check_sessions_places() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public
    SET enable_hashjoin = off SET enable_mergejoin = off AS $$
DECLARE
    bad record;
BEGIN
    SELECT n.tail_number INTO bad FROM (SELECT DISTINCT r.tail_number FROM new_sessions r) n
    WHERE NOT EXISTS (SELECT 1 FROM aircraft a WHERE a.tail_number = n.tail_number) LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "test_sessions" violates foreign key constraint "test_sessions_tail_number_fkey"'
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (tail_number)=(%s) is not present in table "aircraft".', bad.tail_number);
    END IF;
    SELECT n.position INTO bad FROM (SELECT DISTINCT r.position FROM new_sessions r WHERE r.position IS NOT NULL) n
    WHERE NOT EXISTS (SELECT 1 FROM positions p WHERE p.position = n.position) LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "test_sessions" violates foreign key constraint "test_sessions_position_fkey"'
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (position)=(%s) is not present in table "positions".', bad.position);
    END IF;
    SELECT n.station_uuid, n.station_role INTO bad FROM (SELECT DISTINCT r.station_uuid, r.station_role FROM new_sessions r) n
    WHERE NOT EXISTS (SELECT 1 FROM stations s WHERE s.station_uuid = n.station_uuid AND s.station_role = n.station_role) LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "test_sessions" violates foreign key constraint "test_sessions_station_uuid_station_role_fkey"'
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (station_uuid, station_role)=(%s, %s) is not present in table "stations".', bad.station_uuid,
                                  bad.station_role);
    END IF;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION check_sessions_places() FROM PUBLIC;
CREATE TRIGGER test_sessions_places_check AFTER INSERT ON test_sessions REFERENCING NEW TABLE AS new_sessions FOR EACH STATEMENT
    EXECUTE FUNCTION check_sessions_places();

-- 3. session_measurements without its primary key. What the key could not do (a term added later to
--    a session already summed, under another ordinal), the check now does: a session's terms go in
--    with the session, in the transaction that inserts it (the session's row version was written by
--    this transaction: xmin), so no session is summed twice.
ALTER TABLE session_measurements DROP CONSTRAINT IF EXISTS session_measurements_pkey;
DROP TRIGGER session_measurements_session_check ON session_measurements;

CREATE FUNCTION check_terms_session() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public
    SET enable_hashjoin = off SET enable_mergejoin = off AS $$
DECLARE
    bad record;
    me xid := (pg_current_xact_id()::text::bigint % 4294967296)::text::xid;
BEGIN
    SELECT n.session_id, n.station_role INTO bad
    FROM (SELECT DISTINCT r.session_id, r.station_role FROM new_rows r) n
    WHERE NOT EXISTS (SELECT 1 FROM test_sessions s WHERE s.session_id = n.session_id AND s.station_role = n.station_role AND s.xmin = me)
    LIMIT 1;
    IF FOUND THEN
        RAISE EXCEPTION 'insert or update on table "session_measurements" violates foreign key constraint "session_measurements_session_check"'
            USING ERRCODE = 'foreign_key_violation',
                  DETAIL = format('Key (session_id, station_role)=(%s, %s) is not present in table "test_sessions" among the sessions '
                                  'this transaction inserted (a session''s summary terms go in with the session).', bad.session_id,
                                  bad.station_role);
    END IF;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION check_terms_session() FROM PUBLIC;
CREATE TRIGGER session_measurements_session_check AFTER INSERT ON session_measurements REFERENCING NEW TABLE AS new_rows
    FOR EACH STATEMENT EXECUTE FUNCTION check_terms_session();
