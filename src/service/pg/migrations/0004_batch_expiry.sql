-- A batch carries its lease's expiry itself: a claim's row re-check (after waiting for a
-- concurrent claim's lock) then sees the new lease on the row. A test of the lease table
-- in a subquery used the statement's older snapshot, where a lease created a moment ago
-- did not exist yet, so a just-claimed batch could be claimed twice.
ALTER TABLE work_batches ADD COLUMN lease_expires_at TIMESTAMPTZ;
UPDATE work_batches b SET lease_expires_at = l.expires_at
FROM leases l WHERE l.id = b.lease_id AND b.state = 'leased';
