-- emadiag maintenance database, schema version 6 -> 7: the discovery findings of a tail are
-- chained as its sessions are (docs/record-format.md, "Discovery findings"). Until version 6 each
-- discovery finding carried its own content_sha256, but nothing linked them and `verify` did not
-- read them: an edited summary or status, a removed finding, passed. Each tail's chain head now
-- also records how many discovery findings it has and the last link of their chain (SHA-256 over
-- the previous link and the finding's content_sha256, finding_id order). No stored row changes:
-- every finding keeps its content_sha256 (format emadiag-discovery-v1), so the findings stored
-- before this version verify as they did; the migration code (database.cpp) chains them right
-- after this text. A tail with discovery findings and no session gets a chain head with 0 sessions.
ALTER TABLE chain_heads ADD COLUMN discovery_findings INTEGER NOT NULL DEFAULT 0;
ALTER TABLE chain_heads ADD COLUMN discovery_head_sha256 TEXT NOT NULL DEFAULT '';
