-- emadiag maintenance database, schema version 5 -> 6: each tail's sessions and findings stored
-- together. Before, test_sessions (rowid = session_id) and findings (keyed by session_id) kept rows
-- in the order they were stored, interleaving every tail of the fleet: one tail's report read its
-- sessions from some 20,000 pages of a 1000-tail file. Both tables are rebuilt as WITHOUT ROWID
-- tables whose primary key starts with the tail number (sqlite.org/withoutrowid.html), so a tail's
-- rows sit in a run of adjacent pages. Nothing else changes: every column, value and session_id is
-- kept (the hash chain covers the values, not the layout), and no row is copied twice.
--   test_sessions: key (tail_number, started_utc, session_id), the order the report and export read;
--                  a unique index on session_id serves the references to a session (runs, findings,
--                  artifacts, installations, amends, sync) and sync's reading in session_id order.
--                  session_id is no longer a rowid alias (AUTOINCREMENT): the store gives a new
--                  session the next id above every id used so far (test_sessions, chain_heads).
--   findings:      gains tail_number (its session's) and is keyed (tail_number, session_id,
--                  parameter, estimator); its old key index on (session_id, ...) goes, so it is
--                  smaller than before. A session's findings are found through its tail and id.
-- Applied with foreign keys off (the tables others reference are rebuilt, as in version 3); the
-- append-only triggers of version 4 are created again on the new tables.

CREATE TABLE test_sessions_v6 (
    session_id        INTEGER NOT NULL,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    position          TEXT REFERENCES positions(position),
    actuator_serial   TEXT NOT NULL DEFAULT '',
    phase             TEXT NOT NULL CHECK (phase IN ('pre-flight', 'post-flight', 'in-flight', 'load-rig')),
    started_utc       TEXT NOT NULL,
    cycles            INTEGER CHECK (cycles IS NULL OR cycles >= 0),
    hours_h           REAL CHECK (hours_h IS NULL OR hours_h >= 0),
    operator_id       TEXT NOT NULL DEFAULT '',
    technician_name   TEXT NOT NULL DEFAULT '',
    technician_certificate TEXT NOT NULL DEFAULT '',
    work_performed    TEXT NOT NULL DEFAULT '',
    source            TEXT NOT NULL DEFAULT '',
    tool_version      TEXT NOT NULL DEFAULT '',
    verdict           TEXT NOT NULL CHECK (verdict IN ('SERVICEABLE', 'UNSERVICEABLE', 'INCONCLUSIVE', 'NO_TEST')),
    verdict_note      TEXT NOT NULL DEFAULT '',
    limits_json       TEXT NOT NULL DEFAULT '{}',
    limits_sha256     TEXT NOT NULL DEFAULT '',
    amends_session_id INTEGER REFERENCES test_sessions(session_id),
    correction_reason TEXT NOT NULL DEFAULT '',
    prev_sha256       TEXT,
    content_sha256    TEXT,
    CHECK ((amends_session_id IS NULL) = (correction_reason = '')),
    -- Version 4's trigger test_sessions_sealed as a named CHECK (same rule, same message): a BEFORE
    -- INSERT trigger that may RAISE(ABORT) makes SQLite keep a statement journal of every page each
    -- INSERT into this WITHOUT ROWID table touches (a temporary file some 15 KB per session); a
    -- CHECK is evaluated before anything is written.
    CONSTRAINT "append-only record: a test session is stored with its hash chain (content_sha256, prev_sha256)"
        CHECK (content_sha256 IS NOT NULL AND length(content_sha256) = 64 AND prev_sha256 IS NOT NULL),
    PRIMARY KEY (tail_number, started_utc, session_id)
) WITHOUT ROWID;
INSERT INTO test_sessions_v6(session_id, tail_number, position, actuator_serial, phase, started_utc, cycles, hours_h, operator_id,
                             technician_name, technician_certificate, work_performed, source, tool_version, verdict, verdict_note,
                             limits_json, limits_sha256, amends_session_id, correction_reason, prev_sha256, content_sha256)
    SELECT session_id, tail_number, position, actuator_serial, phase, started_utc, cycles, hours_h, operator_id,
           technician_name, technician_certificate, work_performed, source, tool_version, verdict, verdict_note,
           limits_json, limits_sha256, amends_session_id, correction_reason, prev_sha256, content_sha256
    FROM test_sessions ORDER BY tail_number, started_utc, session_id;

CREATE TABLE findings_v6 (
    tail_number       TEXT NOT NULL,            -- the session's (test_sessions.tail_number)
    session_id        INTEGER NOT NULL REFERENCES test_sessions(session_id) ON DELETE CASCADE,
    parameter         TEXT NOT NULL,            -- FDJ_Nm, FSJ_Nm, eta_O, eta_A
    estimator         TEXT NOT NULL,            -- "physics", "network"
    value             REAL,                     -- NULL: not identifiable or not estimated
    std_error         REAL,                     -- NULL: no uncertainty (value NULL, or none computed)
    limit_value       REAL,                     -- NULL exactly when limit_kind is 'none'
    limit_kind        TEXT NOT NULL CHECK (limit_kind IN ('max', 'min', 'none')),
    status            TEXT NOT NULL,            -- e.g. WITHIN, BEYOND, STRADDLES, NOT_IDENTIFIABLE
    note              TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (tail_number, session_id, parameter, estimator),
    CHECK ((limit_kind = 'none') = (limit_value IS NULL))
) WITHOUT ROWID;
-- Every finding belongs to a stored session (a foreign key since version 2): the join keeps all of
-- them; the migration code compares the counts before it commits.
INSERT INTO findings_v6(tail_number, session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note)
    SELECT s.tail_number, f.session_id, f.parameter, f.estimator, f.value, f.std_error, f.limit_value, f.limit_kind, f.status, f.note
    FROM findings f JOIN test_sessions s ON s.session_id = f.session_id
    ORDER BY s.tail_number, f.session_id, f.parameter, f.estimator;

DROP TABLE findings;
DROP TABLE test_sessions;
ALTER TABLE test_sessions_v6 RENAME TO test_sessions;
ALTER TABLE findings_v6 RENAME TO findings;

CREATE UNIQUE INDEX test_sessions_by_id ON test_sessions(session_id);
CREATE INDEX test_sessions_by_serial ON test_sessions(actuator_serial, started_utc, session_id);
CREATE UNIQUE INDEX test_sessions_amended_once ON test_sessions(amends_session_id) WHERE amends_session_id IS NOT NULL;

CREATE TRIGGER test_sessions_no_update BEFORE UPDATE ON test_sessions
    BEGIN SELECT RAISE(ABORT, 'append-only record: test_sessions rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER test_sessions_no_delete BEFORE DELETE ON test_sessions
    BEGIN SELECT RAISE(ABORT, 'append-only record: test_sessions rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER findings_no_update BEFORE UPDATE ON findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: findings rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER findings_no_delete BEFORE DELETE ON findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: findings rows are never deleted; store a correction that amends the entry'); END;
