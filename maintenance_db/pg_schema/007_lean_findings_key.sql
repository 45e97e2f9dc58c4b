-- emadiag fleet server, schema version 7: the findings' key without the report's columns.
-- Version 3 made the findings' key, the unique index (tail_number, session_id, parameter, estimator),
-- also hold every other column a report reads (INCLUDE), so that a report read a tail's findings as
-- an index-only scan. Since version 5 a report reads a tail's findings from session_findings; the
-- included columns cost 686 bytes a session of the 4,337 the database took (50 x 730 fleet: the key
-- with them, 172 bytes a finding), and every finding a sync inserts writes them into the index.
-- The key stays (same name, same columns); the sessions of a serial seen on other tails, and a
-- client whose encoding differs from the server's, read the findings' other columns from the table.
CREATE UNIQUE INDEX findings_key ON findings(tail_number, session_id, parameter, estimator);
DROP INDEX findings_by_tail;
ALTER INDEX findings_key RENAME TO findings_by_tail;
