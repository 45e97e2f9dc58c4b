-- emadiag maintenance database, schema version 3 -> 4: the record is append-only.
-- Stored sessions, their runs, samples, raw logs, estimates, findings, artifacts, installations and
-- discovery findings are never updated or deleted; a correction is a new entry pointing to the one
-- it amends (test_sessions.amends_session_id, discovery_findings.amends_finding_id). The migration
-- code has sealed every earlier session into the hash chain before these triggers exist.
CREATE TRIGGER test_sessions_sealed BEFORE INSERT ON test_sessions
    WHEN NEW.content_sha256 IS NULL OR length(NEW.content_sha256) != 64 OR NEW.prev_sha256 IS NULL
    BEGIN SELECT RAISE(ABORT, 'append-only record: a test session is stored with its hash chain (content_sha256, prev_sha256)'); END;
CREATE TRIGGER test_sessions_no_update BEFORE UPDATE ON test_sessions
    BEGIN SELECT RAISE(ABORT, 'append-only record: test_sessions rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER test_sessions_no_delete BEFORE DELETE ON test_sessions
    BEGIN SELECT RAISE(ABORT, 'append-only record: test_sessions rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER runs_no_update BEFORE UPDATE ON runs
    BEGIN SELECT RAISE(ABORT, 'append-only record: runs rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER runs_no_delete BEFORE DELETE ON runs
    BEGIN SELECT RAISE(ABORT, 'append-only record: runs rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER samples_no_update BEFORE UPDATE ON samples
    BEGIN SELECT RAISE(ABORT, 'append-only record: samples rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER samples_no_delete BEFORE DELETE ON samples
    BEGIN SELECT RAISE(ABORT, 'append-only record: samples rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER raw_logs_no_update BEFORE UPDATE ON raw_logs
    BEGIN SELECT RAISE(ABORT, 'append-only record: raw_logs rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER raw_logs_no_delete BEFORE DELETE ON raw_logs
    BEGIN SELECT RAISE(ABORT, 'append-only record: raw_logs rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER estimates_no_update BEFORE UPDATE ON estimates
    BEGIN SELECT RAISE(ABORT, 'append-only record: estimates rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER estimates_no_delete BEFORE DELETE ON estimates
    BEGIN SELECT RAISE(ABORT, 'append-only record: estimates rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER findings_no_update BEFORE UPDATE ON findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: findings rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER findings_no_delete BEFORE DELETE ON findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: findings rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER session_artifacts_no_update BEFORE UPDATE ON session_artifacts
    BEGIN SELECT RAISE(ABORT, 'append-only record: session_artifacts rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER session_artifacts_no_delete BEFORE DELETE ON session_artifacts
    BEGIN SELECT RAISE(ABORT, 'append-only record: session_artifacts rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER installations_no_update BEFORE UPDATE ON installations
    BEGIN SELECT RAISE(ABORT, 'append-only record: installations rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER installations_no_delete BEFORE DELETE ON installations
    BEGIN SELECT RAISE(ABORT, 'append-only record: installations rows are never deleted; store a correction that amends the entry'); END;
CREATE TRIGGER discovery_findings_no_update BEFORE UPDATE ON discovery_findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: discovery_findings rows are never updated; store a correction that amends the entry'); END;
CREATE TRIGGER discovery_findings_no_delete BEFORE DELETE ON discovery_findings
    BEGIN SELECT RAISE(ABORT, 'append-only record: discovery_findings rows are never deleted; store a correction that amends the entry'); END;
