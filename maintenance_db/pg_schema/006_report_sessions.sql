-- emadiag fleet server, schema version 6: a tail's sessions for the report as one value per session.
-- After version 5 (the findings packed per session), the report's read of a tail (50 x 730 fleet,
-- F-W0000: 5,840 sessions) was mostly its sessions: 18 columns a row, 8-13 ms for the server to
-- scan and send them (COPY of the report's query to /dev/null) and as long again for the client to
-- take them apart (session 9, docs/fleet-server.md).
--
-- session_rows holds the columns a report reads of each session (not the limits text, its hash and
-- the chain link, which a report never shows) as one bytea, written by a trigger owned by the
-- schema owner in the statement that inserts the session. Stations only read it. Sessions are never
-- updated (stations have no UPDATE; the owner changes no session), so the copy stays the session's.
--
-- The bytes, in this order (text, number: as version 5's finding_bytes; a bigint is one byte 0
-- (NULL) or 1 followed by its int8send, 8 bytes big-endian; "text or NULL" is one byte 0 (NULL) or
-- 1 followed by the text):
--   text actuator_serial, text phase, text tool_version, text verdict, text verdict_note,
--   text or NULL position, bigint cycles, number hours_h, text operator_id, text technician_name,
--   text technician_certificate, text work_performed, text source, bigint amends_session_id,
--   text correction_reason, text content_sha256
-- (session_id, tail_number and started_utc are columns of the table: the report selects and orders by them).
CREATE FUNCTION session_bytes(actuator_serial text, phase text, tool_version text, verdict text, verdict_note text, "position" text,
                              cycles bigint, hours_h double precision, operator_id text, technician_name text,
                              technician_certificate text, work_performed text, source text, amends_session_id bigint,
                              correction_reason text, content_sha256 text)
    RETURNS bytea LANGUAGE sql STABLE PARALLEL SAFE AS $$
    SELECT int4send(octet_length(actuator_serial)) || convert_to(actuator_serial, getdatabaseencoding())
        || int4send(octet_length(phase)) || convert_to(phase, getdatabaseencoding())
        || int4send(octet_length(tool_version)) || convert_to(tool_version, getdatabaseencoding())
        || int4send(octet_length(verdict)) || convert_to(verdict, getdatabaseencoding())
        || int4send(octet_length(verdict_note)) || convert_to(verdict_note, getdatabaseencoding())
        || CASE WHEN "position" IS NULL THEN '\x00'::bytea
                ELSE '\x01'::bytea || int4send(octet_length("position")) || convert_to("position", getdatabaseencoding()) END
        || CASE WHEN cycles IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || int8send(cycles) END
        || CASE WHEN hours_h IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || float8send(hours_h) END
        || int4send(octet_length(operator_id)) || convert_to(operator_id, getdatabaseencoding())
        || int4send(octet_length(technician_name)) || convert_to(technician_name, getdatabaseencoding())
        || int4send(octet_length(technician_certificate)) || convert_to(technician_certificate, getdatabaseencoding())
        || int4send(octet_length(work_performed)) || convert_to(work_performed, getdatabaseencoding())
        || int4send(octet_length(source)) || convert_to(source, getdatabaseencoding())
        || CASE WHEN amends_session_id IS NULL THEN '\x00'::bytea ELSE '\x01'::bytea || int8send(amends_session_id) END
        || int4send(octet_length(correction_reason)) || convert_to(correction_reason, getdatabaseencoding())
        || int4send(octet_length(content_sha256)) || convert_to(content_sha256, getdatabaseencoding())
$$;

CREATE TABLE session_rows (
    tail_number       text COLLATE "C" NOT NULL,
    started_utc       text COLLATE "C" NOT NULL,
    session_id        bigint NOT NULL,
    session           bytea NOT NULL
);
-- The order of test_sessions_by_tail, in which the report lists a tail's sessions.
CREATE UNIQUE INDEX session_rows_by_tail ON session_rows(tail_number, started_utc, session_id);
REVOKE ALL ON session_rows FROM PUBLIC;
GRANT SELECT ON session_rows TO emadiag_station;

INSERT INTO session_rows (tail_number, started_utc, session_id, session)
SELECT s.tail_number, s.started_utc, s.session_id,
       session_bytes(s.actuator_serial, s.phase, s.tool_version, s.verdict, s.verdict_note, s.position, s.cycles, s.hours_h,
                     s.operator_id, s.technician_name, s.technician_certificate, s.work_performed, s.source,
                     s.amends_session_id, s.correction_reason, s.content_sha256)
FROM test_sessions s;

CREATE FUNCTION pack_session_rows() RETURNS trigger LANGUAGE plpgsql SECURITY DEFINER SET search_path = public AS $$
BEGIN
    INSERT INTO session_rows (tail_number, started_utc, session_id, session)
    SELECT s.tail_number, s.started_utc, s.session_id,
           session_bytes(s.actuator_serial, s.phase, s.tool_version, s.verdict, s.verdict_note, s.position, s.cycles, s.hours_h,
                         s.operator_id, s.technician_name, s.technician_certificate, s.work_performed, s.source,
                         s.amends_session_id, s.correction_reason, s.content_sha256)
    FROM new_sessions s;
    RETURN NULL;
END $$;
REVOKE EXECUTE ON FUNCTION pack_session_rows() FROM PUBLIC;
CREATE TRIGGER test_sessions_rows_pack AFTER INSERT ON test_sessions REFERENCING NEW TABLE AS new_sessions FOR EACH STATEMENT
    EXECUTE FUNCTION pack_session_rows();
