-- emadiag maintenance database, schema version 2 -> 3: the maintenance record of a fleet.
-- Positions with their ATA chapter 27 reference, the actuator serial, flight cycles and hours, the
-- operator, the person and certificate, what was done, the model files and limits used (SHA-256),
-- corrections, installations, discovery findings, the per-tail hash chain, and two summary tables
-- the fleet view reads. Applied with foreign keys off (the test_sessions rebuild); the hash chain of
-- sessions stored before version 3 is computed by the migration code (database.cpp) right after.

-- The positions an EMA is installed at; rows are added from the position list in force
-- (docs/fleet-record.md) the first time a session uses a position.
CREATE TABLE positions (
    position          TEXT PRIMARY KEY NOT NULL CHECK (length(position) BETWEEN 1 AND 16),
    ata_reference     TEXT NOT NULL CHECK (ata_reference GLOB '27-[0-9][0-9]*'),  -- ATA chapter 27, flight controls
    description       TEXT NOT NULL DEFAULT ''
);

-- test_sessions rebuilt (SQLite cannot change a CHECK in place): phases in-flight and load-rig for
-- imported runs, and the columns of the record. Every existing row and id is kept.
CREATE TABLE test_sessions_v3 (
    session_id        INTEGER PRIMARY KEY AUTOINCREMENT,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    position          TEXT REFERENCES positions(position),  -- NULL: not given (every session before version 3)
    actuator_serial   TEXT NOT NULL DEFAULT '',             -- from the EMA's identification; '' unknown
    phase             TEXT NOT NULL CHECK (phase IN ('pre-flight', 'post-flight', 'in-flight', 'load-rig')),
    started_utc       TEXT NOT NULL,            -- ISO 8601
    cycles            INTEGER CHECK (cycles IS NULL OR cycles >= 0),   -- aircraft flight cycles (technical log)
    hours_h           REAL CHECK (hours_h IS NULL OR hours_h >= 0),    -- aircraft flight hours
    operator_id       TEXT NOT NULL DEFAULT '',
    technician_name   TEXT NOT NULL DEFAULT '',
    technician_certificate TEXT NOT NULL DEFAULT '',
    work_performed    TEXT NOT NULL DEFAULT '', -- what was done, in words
    source            TEXT NOT NULL DEFAULT '', -- the command: test-run, import, history-sim
    tool_version      TEXT NOT NULL DEFAULT '',
    verdict           TEXT NOT NULL CHECK (verdict IN ('SERVICEABLE', 'UNSERVICEABLE', 'INCONCLUSIVE', 'NO_TEST')),
    verdict_note      TEXT NOT NULL DEFAULT '',
    limits_json       TEXT NOT NULL DEFAULT '{}',
    limits_sha256     TEXT NOT NULL DEFAULT '', -- of limits_json's bytes
    amends_session_id INTEGER REFERENCES test_sessions(session_id),  -- a correction points to the entry it amends
    correction_reason TEXT NOT NULL DEFAULT '',
    prev_sha256       TEXT,                     -- the tail's previous session's content_sha256 ('' for the first)
    content_sha256    TEXT,                     -- SHA-256 over prev_sha256 and everything stored (docs/record-format.md)
    CHECK ((amends_session_id IS NULL) = (correction_reason = ''))
);
INSERT INTO test_sessions_v3(session_id, tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note,
                             limits_json, work_performed, source)
    SELECT session_id, tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, limits_json,
           'ground test run (recorded before schema version 3)', 'test-run'
    FROM test_sessions;
DROP TABLE test_sessions;
ALTER TABLE test_sessions_v3 RENAME TO test_sessions;
CREATE INDEX test_sessions_by_tail ON test_sessions(tail_number, started_utc);
CREATE INDEX test_sessions_by_serial ON test_sessions(actuator_serial, started_utc);
CREATE UNIQUE INDEX test_sessions_amended_once ON test_sessions(amends_session_id) WHERE amends_session_id IS NOT NULL;

-- The model files and limits a session used, each with its SHA-256.
CREATE TABLE session_artifacts (
    session_id        INTEGER NOT NULL REFERENCES test_sessions(session_id),
    role              TEXT NOT NULL CHECK (role IN ('model', 'limits', 'positions')),
    name              TEXT NOT NULL,            -- file name as given, or 'built-in'
    sha256            TEXT NOT NULL CHECK (length(sha256) = 64),
    PRIMARY KEY (session_id, role, name)
) WITHOUT ROWID;

-- An installation change: a position shows a new actuator serial.
CREATE TABLE installations (
    installation_id   INTEGER PRIMARY KEY AUTOINCREMENT,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    position          TEXT NOT NULL REFERENCES positions(position),
    from_serial       TEXT NOT NULL,            -- '' for the first serial seen at the position
    to_serial         TEXT NOT NULL CHECK (length(to_serial) > 0),
    detected_utc      TEXT NOT NULL,            -- the session that first showed to_serial
    cycles            INTEGER,
    hours_h           REAL,
    session_id        INTEGER NOT NULL REFERENCES test_sessions(session_id)
);
CREATE INDEX installations_by_tail ON installations(tail_number, position, installation_id);
CREATE INDEX installations_by_serial ON installations(to_serial);

-- Findings of `emadiag discover`: an effect the model lacks, traced in a run of this actuator.
CREATE TABLE discovery_findings (
    finding_id        INTEGER PRIMARY KEY AUTOINCREMENT,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    position          TEXT REFERENCES positions(position),
    actuator_serial   TEXT NOT NULL DEFAULT '',
    found_utc         TEXT NOT NULL,
    summary           TEXT NOT NULL CHECK (length(summary) > 0),
    model_json        TEXT NOT NULL DEFAULT '{}',  -- the augmented model
    status            TEXT NOT NULL CHECK (status IN ('open', 'closed')),
    amends_finding_id INTEGER REFERENCES discovery_findings(finding_id),  -- e.g. the later entry that closes one
    tool_version      TEXT NOT NULL DEFAULT '',
    content_sha256    TEXT NOT NULL CHECK (length(content_sha256) = 64)
);
CREATE INDEX discovery_findings_by_tail ON discovery_findings(tail_number, found_utc);
CREATE UNIQUE INDEX discovery_findings_amended_once ON discovery_findings(amends_finding_id) WHERE amends_finding_id IS NOT NULL;

-- The newest session of each tail's hash chain (a deleted last session shows here).
CREATE TABLE chain_heads (
    tail_number       TEXT PRIMARY KEY NOT NULL REFERENCES aircraft(tail_number),
    session_id        INTEGER NOT NULL,
    sessions          INTEGER NOT NULL,
    content_sha256    TEXT NOT NULL
) WITHOUT ROWID;

-- Summary tables, maintained in the transaction that stores a session (derived data, rebuilt from
-- the sessions by the migration; the fleet view reads them instead of every session).
-- Per tail, position (''  when none), serial and parameter: the weighted sums of a linear least-
-- squares fit of the session measurements (inverse-variance mean of the physics findings, weight
-- w = 1/se^2) against days and against flight cycles since the series' first session.
CREATE TABLE series_stats (
    tail_number       TEXT NOT NULL,
    position          TEXT NOT NULL,
    actuator_serial   TEXT NOT NULL,
    parameter         TEXT NOT NULL,
    n                 INTEGER NOT NULL,
    first_days        REAL NOT NULL,  -- days since 1970 of the series' first session (t = 0)
    last_days         REAL NOT NULL,
    s_w REAL NOT NULL, s_wt REAL NOT NULL, s_wtt REAL NOT NULL, s_wy REAL NOT NULL, s_wty REAL NOT NULL, s_wyy REAL NOT NULL,
    n_cycles          INTEGER NOT NULL,  -- sessions of the series that carry cycles
    first_cycles      REAL,
    last_cycles       REAL,
    c_w REAL NOT NULL, c_wt REAL NOT NULL, c_wtt REAL NOT NULL, c_wy REAL NOT NULL, c_wty REAL NOT NULL, c_wyy REAL NOT NULL,
    last_session_id   INTEGER NOT NULL,
    last_value        REAL NOT NULL,
    last_std_error    REAL NOT NULL,
    limit_kind        TEXT NOT NULL DEFAULT 'none',
    limit_value       REAL,
    PRIMARY KEY (tail_number, position, actuator_serial, parameter)
) WITHOUT ROWID;
-- Per tail and position: the serial installed now and the last session.
CREATE TABLE position_status (
    tail_number       TEXT NOT NULL,
    position          TEXT NOT NULL,
    actuator_serial   TEXT NOT NULL,
    sessions          INTEGER NOT NULL,
    last_session_id   INTEGER NOT NULL,
    last_utc          TEXT NOT NULL,
    last_verdict      TEXT NOT NULL,
    last_cycles       INTEGER,
    PRIMARY KEY (tail_number, position)
) WITHOUT ROWID;
