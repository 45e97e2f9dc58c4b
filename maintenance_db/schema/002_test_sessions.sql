-- emadiag maintenance database, schema version 1 -> 2: test sessions and their findings.
-- A test session is one `emadiag test-run` on the ramp: one or more runs (test sequences) and a verdict.
CREATE TABLE test_sessions (
    session_id        INTEGER PRIMARY KEY AUTOINCREMENT,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    actuator_serial   TEXT NOT NULL DEFAULT '',
    phase             TEXT NOT NULL CHECK (phase IN ('pre-flight', 'post-flight')),
    started_utc       TEXT NOT NULL,            -- ISO 8601
    tool_version      TEXT NOT NULL DEFAULT '',
    verdict           TEXT NOT NULL CHECK (verdict IN ('SERVICEABLE', 'UNSERVICEABLE', 'INCONCLUSIVE', 'NO_TEST')),
    verdict_note      TEXT NOT NULL DEFAULT '',
    limits_json       TEXT NOT NULL DEFAULT '{}'  -- the limits the verdict was judged against
);
CREATE INDEX test_sessions_by_tail ON test_sessions(tail_number, started_utc);

-- NULL for runs stored on their own (store_run) and for every run stored before version 2.
ALTER TABLE runs ADD COLUMN session_id INTEGER REFERENCES test_sessions(session_id);
CREATE INDEX runs_by_session ON runs(session_id);

-- The per-parameter verdict lines of a session. value, std_error and limit_value are in the unit
-- named by the parameter (FDJ_Nm, FSJ_Nm: N m; eta_O, eta_A: dimensionless).
CREATE TABLE findings (
    session_id        INTEGER NOT NULL REFERENCES test_sessions(session_id) ON DELETE CASCADE,
    parameter         TEXT NOT NULL,            -- FDJ_Nm, FSJ_Nm, eta_O, eta_A
    estimator         TEXT NOT NULL,            -- "physics", "network"
    value             REAL,                     -- NULL: not identifiable or not estimated
    std_error         REAL,                     -- NULL: no uncertainty (value NULL, or none computed)
    limit_value       REAL,                     -- NULL exactly when limit_kind is 'none'
    limit_kind        TEXT NOT NULL CHECK (limit_kind IN ('max', 'min', 'none')),
    status            TEXT NOT NULL,            -- e.g. WITHIN, BEYOND, STRADDLES, NOT_IDENTIFIABLE
    note              TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (session_id, parameter, estimator),
    CHECK ((limit_kind = 'none') = (limit_value IS NULL))
);
