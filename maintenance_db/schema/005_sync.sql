-- emadiag maintenance database, schema version 4 -> 5: what this station has synced to a fleet
-- server (PostgreSQL, `emadiag sync`, docs/fleet-server.md). Additive: no earlier table changes.
-- The station's identity: one random UUID, made once by this migration. With a session's id it
-- gives the session's global identity on the fleet server (station_uuid, session_id), next to the
-- content hash that already seals the session.
CREATE TABLE station_identity (
    station_uuid      TEXT PRIMARY KEY NOT NULL CHECK (length(station_uuid) = 36)
);
INSERT INTO station_identity(station_uuid)
    SELECT lower(substr(h, 1, 8) || '-' || substr(h, 9, 4) || '-4' || substr(h, 14, 3) || '-' ||
                 substr('89ab', 1 + (abs(random()) % 4), 1) || substr(h, 18, 3) || '-' || substr(h, 21, 12))
    FROM (SELECT hex(randomblob(16)) AS h);
-- One row per session the fleet server has (written after the server committed it; a sync killed in
-- between finds the session on the server and records it here on the next run).
CREATE TABLE synced_sessions (
    server            TEXT NOT NULL,            -- the fleet server as given to sync (never holds a password)
    session_id        INTEGER NOT NULL REFERENCES test_sessions(session_id),
    fleet_session_id  INTEGER NOT NULL,         -- the session's id on the fleet server
    synced_utc        TEXT NOT NULL,
    PRIMARY KEY (server, session_id)
) WITHOUT ROWID;
CREATE TABLE synced_discovery_findings (
    server            TEXT NOT NULL,
    finding_id        INTEGER NOT NULL REFERENCES discovery_findings(finding_id),
    fleet_finding_id  INTEGER NOT NULL,
    synced_utc        TEXT NOT NULL,
    PRIMARY KEY (server, finding_id)
) WITHOUT ROWID;
CREATE TRIGGER synced_sessions_no_update BEFORE UPDATE ON synced_sessions
    BEGIN SELECT RAISE(ABORT, 'synced_sessions rows are never updated'); END;
CREATE TRIGGER synced_discovery_findings_no_update BEFORE UPDATE ON synced_discovery_findings
    BEGIN SELECT RAISE(ABORT, 'synced_discovery_findings rows are never updated'); END;
