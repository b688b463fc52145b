-- What the HTTP service keeps beside the queue (issue 10's Store trait on PostgreSQL).

-- The spec document exactly as posted (NULL: enqueued from the library).
ALTER TABLE sweeps ADD COLUMN posted_spec TEXT;
-- The run identity of a sweep the server runs itself (friction maps; JSON text).
ALTER TABLE sweeps ADD COLUMN header TEXT;
-- The result's `run` section once done (JSON text).
ALTER TABLE sweeps ADD COLUMN run TEXT;
-- A whole result document stored as is (friction maps: no variant lines).
ALTER TABLE sweeps ADD COLUMN result_doc TEXT;
-- Run by the server's own scheduler (no work batches) instead of worker processes.
ALTER TABLE sweeps ADD COLUMN local BOOLEAN NOT NULL DEFAULT false;
-- Variants computed and stored over the sweep's life (equals `done`: stored once).
ALTER TABLE sweeps ADD COLUMN computed BIGINT NOT NULL DEFAULT 0;

-- Results the server commits itself carry no lease.
ALTER TABLE variant_results ALTER COLUMN lease_id DROP NOT NULL;
-- Commit order: the server's event streams follow it.
ALTER TABLE variant_results ADD COLUMN seq BIGSERIAL;
CREATE INDEX variant_results_seq ON variant_results (sweep_id, seq);

CREATE TABLE plots (
    sweep_id TEXT NOT NULL REFERENCES sweeps (id) ON DELETE CASCADE,
    name     TEXT NOT NULL,
    svg      TEXT NOT NULL,
    PRIMARY KEY (sweep_id, name)
);
