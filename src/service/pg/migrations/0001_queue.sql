-- Work queue of the sweep service on PostgreSQL (issue 12).
--
-- A sweep is split at submission into work batches: contiguous ranges of variant ids
-- [first_id, end_id). A worker claims as many batches of one sweep as fit its batch size
-- (`worker --batch N`) under one lease, runs them as one lockstep batch, and writes their
-- results in the same transaction that completes the lease. A lease whose heartbeat stops
-- expires, and its batches go back to the queue.

CREATE TABLE sweeps (
    id               TEXT PRIMARY KEY,
    -- Submission order: workers take sweeps first come, first served.
    seq              BIGSERIAL NOT NULL UNIQUE,
    name             TEXT NOT NULL,
    kind             TEXT NOT NULL,
    -- The canonical spec (JSON text): what every worker expands.
    spec             TEXT NOT NULL,
    -- Run options as JSON text: {"backend", "accuracy", "full_model"}.
    options          TEXT NOT NULL,
    -- Which workers may claim: 'cpu', 'gpu' or 'auto' (any; the first claim fixes it).
    backend          TEXT NOT NULL CHECK (backend IN ('cpu', 'gpu', 'auto')),
    backend_resolved TEXT CHECK (backend_resolved IN ('cpu', 'gpu')),
    -- The settings that change results (JSON text), written by the first completion;
    -- every later completion must match them.
    settings         TEXT,
    -- Variants per work batch (the unit a claim takes; a lease takes several).
    batch_variants   INTEGER NOT NULL CHECK (batch_variants > 0),
    status           TEXT NOT NULL DEFAULT 'queued'
                     CHECK (status IN ('queued', 'running', 'done', 'failed', 'cancelled')),
    total            BIGINT NOT NULL CHECK (total >= 0),
    done             BIGINT NOT NULL DEFAULT 0,
    -- Finished variants whose status is not "ok".
    failed           BIGINT NOT NULL DEFAULT 0,
    error            TEXT,
    created_at       TIMESTAMPTZ NOT NULL DEFAULT now(),
    started_at       TIMESTAMPTZ,
    finished_at      TIMESTAMPTZ
);

CREATE TABLE leases (
    id           BIGSERIAL PRIMARY KEY,
    sweep_id     TEXT NOT NULL REFERENCES sweeps (id) ON DELETE CASCADE,
    worker_id    TEXT NOT NULL,
    variants     BIGINT NOT NULL,
    claimed_at   TIMESTAMPTZ NOT NULL DEFAULT now(),
    heartbeat_at TIMESTAMPTZ NOT NULL DEFAULT now(),
    expires_at   TIMESTAMPTZ NOT NULL
);

CREATE TABLE work_batches (
    sweep_id  TEXT NOT NULL REFERENCES sweeps (id) ON DELETE CASCADE,
    batch_no  INTEGER NOT NULL,
    first_id  BIGINT NOT NULL,
    end_id    BIGINT NOT NULL CHECK (end_id > first_id),
    state     TEXT NOT NULL DEFAULT 'queued' CHECK (state IN ('queued', 'leased', 'done')),
    -- The lease holding (state 'leased') or that completed (state 'done') the batch.
    lease_id  BIGINT REFERENCES leases (id) ON DELETE SET NULL,
    -- Times it was claimed (> 1: a lease expired or was given back).
    attempts  INTEGER NOT NULL DEFAULT 0,
    PRIMARY KEY (sweep_id, batch_no)
);
CREATE INDEX work_batches_open ON work_batches (sweep_id, batch_no) WHERE state <> 'done';
CREATE INDEX work_batches_lease ON work_batches (lease_id);

CREATE TABLE variant_results (
    sweep_id   TEXT NOT NULL REFERENCES sweeps (id) ON DELETE CASCADE,
    variant_id BIGINT NOT NULL,
    ok         BOOLEAN NOT NULL,
    -- The variant's result.jsonl line (compact JSON), byte for byte.
    line       TEXT NOT NULL,
    lease_id   BIGINT NOT NULL,
    worker_id  TEXT NOT NULL,
    -- Exactly once: a second result for a variant is a key violation (the transaction
    -- that tried it rolls back).
    PRIMARY KEY (sweep_id, variant_id)
);
