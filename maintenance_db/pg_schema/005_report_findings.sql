-- emadiag fleet server, schema version 5: a tail's findings for the report as one row per session.
-- Measured on a 50 x 730 fleet (tail F-W0000: 5,840 sessions, 23,360 findings; session 9,
-- docs/fleet-server.md): the server took 11.5-14 ms to scan and send the tail's findings row by row
-- (COPY of the report's query to /dev/null), most of it per row (a DataRow and a send call per
-- column), and the client as long again to take 23,360 rows apart; the same findings as one value
-- per session took 2.5 ms.
--
-- session_findings holds each session's findings as one bytea, written by a trigger owned by the
-- schema owner in the statement (so the transaction) that inserts the findings: a sync killed
-- before its commit leaves neither. Stations only read it. A statement that adds findings to a
-- session that already has some (the record allows it, the sync never does it) adds a second row
-- for that session; the reader merges a session's rows and orders its findings by (parameter,
-- estimator), as the findings' query does.
--
-- The bytes of one finding, the findings of a row in (parameter, estimator) order, COLLATE "C":
--   text parameter, text estimator, number value, number std_error, number limit_value,
--   text limit_kind, text status, text note
-- where a text is its length in bytes (int4, big-endian) and its bytes in the database's encoding,
-- and a number is one byte 0 (NULL) or 1 followed by the float8 (float8send: IEEE 754, big-endian:
-- the stored double, bit for bit).
-- STABLE as its body (convert_to, getdatabaseencoding): a SQL function is inlined only when it claims
-- no more than its body does. Declared IMMUTABLE, each finding was a function call: 5.5 us a finding
-- against 1.35 us inlined (93,440 findings; 8 us a session with the aggregate below).
CREATE FUNCTION finding_bytes(parameter text, estimator text, value double precision, std_error double precision,
                              limit_value double precision, limit_kind text, status text, note text)
    RETURNS bytea LANGUAGE sql STABLE PARALLEL SAFE AS $$
    SELECT int4send(octet_length(parameter)) || convert_to(parameter, getdatabaseencoding())
        || int4send(octet_length(estimator)) || convert_to(estimator, getdatabaseencoding())
        || CASE WHEN value IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || float8send(value) END
        || CASE WHEN std_error IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || float8send(std_error) END
        || CASE WHEN limit_value IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || float8send(limit_value) END
        || int4send(octet_length(limit_kind)) || convert_to(limit_kind, getdatabaseencoding())
        || int4send(octet_length(status)) || convert_to(status, getdatabaseencoding())
        || int4send(octet_length(note)) || convert_to(note, getdatabaseencoding())
$$;

CREATE TABLE session_findings (
    tail_number       text COLLATE "C" NOT NULL,
    session_id        bigint NOT NULL,
    findings          bytea NOT NULL
);
-- Not unique: a session has a second row when a later statement added findings to it (above).
CREATE INDEX session_findings_by_tail ON session_findings(tail_number, session_id);
REVOKE ALL ON session_findings FROM PUBLIC;
GRANT SELECT ON session_findings TO emadiag_station;

-- The findings already on the server (their tails were filled in by version 3).
INSERT INTO session_findings (tail_number, session_id, findings)
SELECT f.tail_number, f.session_id,
       string_agg(finding_bytes(f.parameter, f.estimator, f.value, f.std_error, f.limit_value, f.limit_kind, f.status, f.note),
                  ''::bytea ORDER BY f.parameter, f.estimator)
FROM findings f GROUP BY f.tail_number, f.session_id;

-- After findings_session_check (triggers on one event fire in name order): the rows are checked,
-- and an older sync's rows (no tail) have their tail filled in from their session.
CREATE FUNCTION pack_session_findings() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public AS $$
BEGIN
    IF EXISTS (SELECT 1 FROM new_rows r WHERE r.tail_number IS NULL) THEN
        INSERT INTO session_findings (tail_number, session_id, findings)
        SELECT s.tail_number, r.session_id,
               string_agg(finding_bytes(r.parameter, r.estimator, r.value, r.std_error, r.limit_value, r.limit_kind, r.status, r.note),
                          ''::bytea ORDER BY r.parameter, r.estimator)
        FROM new_rows r JOIN test_sessions s ON s.session_id = r.session_id
        GROUP BY s.tail_number, r.session_id;
    ELSE
        INSERT INTO session_findings (tail_number, session_id, findings)
        SELECT r.tail_number, r.session_id,
               string_agg(finding_bytes(r.parameter, r.estimator, r.value, r.std_error, r.limit_value, r.limit_kind, r.status, r.note),
                          ''::bytea ORDER BY r.parameter, r.estimator)
        FROM new_rows r GROUP BY r.tail_number, r.session_id;
    END IF;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION pack_session_findings() FROM PUBLIC;
CREATE TRIGGER findings_session_pack AFTER INSERT ON findings REFERENCING NEW TABLE AS new_rows FOR EACH STATEMENT
    EXECUTE FUNCTION pack_session_findings();
