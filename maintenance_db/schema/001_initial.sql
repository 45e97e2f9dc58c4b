-- emadiag maintenance database, schema version 1.
-- Units are in column names. Every test run keeps its raw bus log next to its samples.
CREATE TABLE aircraft (
    tail_number TEXT PRIMARY KEY NOT NULL CHECK (length(tail_number) > 0)
);

CREATE TABLE runs (
    run_id            INTEGER PRIMARY KEY AUTOINCREMENT,
    tail_number       TEXT NOT NULL REFERENCES aircraft(tail_number),
    actuator_serial   TEXT NOT NULL DEFAULT '',
    started_utc       TEXT NOT NULL,            -- ISO 8601
    source            TEXT NOT NULL,            -- e.g. "record socketcan:vcan0", "import run.csv"
    load_case         TEXT NOT NULL,
    sequence          TEXT NOT NULL,
    k_t_nm_per_a      REAL NOT NULL,
    j_kgm2            REAL NOT NULL,
    tau               REAL NOT NULL,
    sample_period_s   REAL NOT NULL,
    valid             INTEGER NOT NULL DEFAULT 1,  -- 0: e.g. frame loss above the limit, aborted
    status_note       TEXT NOT NULL DEFAULT '',
    meta_json         TEXT NOT NULL DEFAULT '{}'
);
CREATE INDEX runs_by_tail ON runs(tail_number, started_utc);

CREATE TABLE samples (
    run_id            INTEGER NOT NULL REFERENCES runs(run_id) ON DELETE CASCADE,
    sample_index      INTEGER NOT NULL,
    t_s               REAL NOT NULL,
    current_a         REAL NOT NULL,
    speed_rad_s       REAL NOT NULL,
    theta_m_rad       REAL NOT NULL,
    hinge_moment_nm   REAL NOT NULL,
    command_deg       REAL NOT NULL,
    PRIMARY KEY (run_id, sample_index)
) WITHOUT ROWID;

CREATE TABLE raw_logs (
    run_id            INTEGER PRIMARY KEY REFERENCES runs(run_id) ON DELETE CASCADE,
    format            TEXT NOT NULL,            -- "candump" or "csv"
    content           BLOB NOT NULL
);

CREATE TABLE estimates (
    run_id            INTEGER NOT NULL REFERENCES runs(run_id) ON DELETE CASCADE,
    estimator         TEXT NOT NULL,            -- "physics", "network"
    parameter         TEXT NOT NULL,            -- FDJ_Nm, FSJ_Nm, eta_O, eta_A
    value             REAL,                     -- NULL: not identifiable or not estimated
    std_error         REAL NOT NULL,
    identifiable      INTEGER NOT NULL,
    method            TEXT NOT NULL,
    note              TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (run_id, estimator, parameter)
);
