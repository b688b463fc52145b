-- Completions no longer touch the sweep row (which serialized every completion of a
-- sweep behind one row lock held through each commit): a lease records how many results
-- it stored, and a sweep's progress is its own count (variants the server committed
-- itself) plus the sum over its leases.
ALTER TABLE leases ADD COLUMN stored BIGINT NOT NULL DEFAULT 0;
ALTER TABLE leases ADD COLUMN not_ok BIGINT NOT NULL DEFAULT 0;
CREATE INDEX leases_sweep ON leases (sweep_id);
