//! The work queue on PostgreSQL: sweeps split into work batches, claimed under leases
//! with `SELECT … FOR UPDATE SKIP LOCKED`, kept alive by heartbeats, and completed in the
//! same transaction that stores their variants' results.
//!
//! Exactly once: a completion first locks its batches and checks that they are still
//! held by its lease (a lease that expired and was claimed again has lost them: the
//! transaction rolls back and the results are dropped); the result rows' primary key
//! (sweep, variant) makes any second result of a variant a key violation, which rolls the
//! transaction back too. A claim skips rows that a completion holds locked, and a
//! completion waits for a claim holding them, then sees the new lease and rolls back.

use std::str::FromStr;
use std::time::Duration;

use deadpool_postgres::{Manager, ManagerConfig, Pool, RecyclingMethod, Runtime};
use serde::Serialize;
use serde_json::Value;
use tokio_postgres::NoTls;

use super::error::PgError;
use super::migrations::migrate;

/// Default variants per work batch row (a lease takes as many rows as fit the worker's
/// `--batch`): small enough that a CPU worker's batch is a few rows, large enough that a
/// sweep of 10^6 variants is ~3·10^4 rows.
pub const DEFAULT_BATCH_VARIANTS: i32 = 32;
/// Most rows one claim takes (a GPU worker's 4096-variant batch is 128 rows of 32).
const MAX_ROWS_PER_CLAIM: i64 = 4096;
/// Open sweeps a claim tries, oldest first, before it reports no work (the older ones
/// may be fully leased).
const CLAIM_CANDIDATES: i64 = 16;

/// Options of a sweep that change how (and on what) it runs: the one options type of
/// every sweep. Its `backend` says which workers may run it: `cpu`, `gpu` or `auto` (any;
/// the first claim decides for the whole sweep, so that every variant is computed with
/// the same settings).
pub use crate::sweep::SweepOptions;

/// A sweep to enqueue.
#[derive(Clone, Debug)]
pub struct QueuedSweep {
    /// Opaque id (unique).
    pub id: String,
    /// The spec's name.
    pub name: String,
    /// `rotor` or `synthetic`.
    pub kind: String,
    /// The canonical spec (base inlined), as `SweepSpec::canonical`.
    pub spec: Value,
    /// Run options.
    pub options: SweepOptions,
    /// Variants in the expansion.
    pub total: u64,
    /// Variants per work batch row (> 0).
    pub batch_variants: i32,
    /// The document as posted to the service, if it came that way.
    pub posted: Option<Value>,
    /// Run by the server itself (no work batches; e.g. a friction map).
    pub local: bool,
    /// Submission time, s since the Unix epoch (`None`: now).
    pub created_unix_s: Option<f64>,
}

/// A sweep as stored.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QueueRow {
    /// Opaque id.
    pub id: String,
    /// The spec's name.
    pub name: String,
    /// `rotor` or `synthetic`.
    pub kind: String,
    /// `queued`, `running`, `done`, `failed` or `cancelled`.
    pub status: String,
    /// Variants in the expansion.
    pub total: u64,
    /// Finished variants.
    pub done: u64,
    /// Finished variants whose status is not `ok`.
    pub failed: u64,
    /// Why the sweep failed, if it did.
    pub error: Option<String>,
    /// Submission time, seconds since the Unix epoch.
    pub created_unix_s: f64,
    /// First claim, s since the epoch.
    pub started_unix_s: Option<f64>,
    /// End (done, failed or cancelled), s since the epoch.
    pub finished_unix_s: Option<f64>,
    /// The result-changing settings (JSON), once the first batch completed.
    pub settings: Option<Value>,
    /// Run options.
    pub options: SweepOptions,
    /// `auto` sweeps: the backend the first claim fixed.
    pub backend_resolved: Option<String>,
}

/// What a worker needs to run a sweep's variants.
#[derive(Clone, Debug)]
pub struct SweepJob {
    /// Sweep id.
    pub id: String,
    /// The canonical spec.
    pub spec: Value,
    /// Run options.
    pub options: SweepOptions,
}

/// A claimed set of work batches of one sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Lease {
    /// Lease id.
    pub id: i64,
    /// Its sweep.
    pub sweep_id: String,
    /// The claiming worker.
    pub worker_id: String,
    /// The batches: (batch number, first variant id, end variant id exclusive).
    pub batches: Vec<(i32, i64, i64)>,
}

impl Lease {
    /// The variant ids of the lease, ascending.
    pub fn variant_ids(&self) -> Vec<u64> {
        self.batches
            .iter()
            .flat_map(|&(_, a, b)| (a as u64)..(b as u64))
            .collect()
    }

    fn batch_nos(&self) -> Vec<i32> {
        self.batches.iter().map(|b| b.0).collect()
    }
}

/// One finished variant to store.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantRow {
    /// Variant id.
    pub id: u64,
    /// Its status is `ok`.
    pub ok: bool,
    /// Its result.jsonl line (compact JSON).
    pub line: String,
}

/// What a heartbeat found.
#[derive(Clone, Debug, PartialEq)]
pub enum LeaseState {
    /// Still ours; extended.
    Held,
    /// The sweep is no longer running (cancelled, failed, deleted): stop.
    Stopped(String),
    /// The lease expired and another worker claimed its batches: stop, drop the results.
    Lost,
}

/// What a completion did.
#[derive(Clone, Debug, PartialEq)]
pub enum Completion {
    /// Results stored and the batches done; `sweep_done`: this was the last of the sweep.
    Committed {
        /// The sweep is now complete.
        sweep_done: bool,
    },
    /// A retried completion whose first attempt had committed (the connection broke
    /// during the commit's reply).
    AlreadyCommitted,
    /// The batches belong to another lease now: nothing stored.
    LeaseLost,
    /// The sweep is no longer running (its status): nothing stored.
    Stopped(String),
}

/// The PostgreSQL store: a connection pool and the queue's statements.
#[derive(Clone)]
pub struct PgQueue {
    pool: Pool,
    target: String,
}

/// `host:port/db` of a URL's config, for messages (never the password).
fn describe(cfg: &tokio_postgres::Config) -> String {
    let host = cfg
        .get_hosts()
        .first()
        .map(|h| match h {
            tokio_postgres::config::Host::Tcp(s) => s.clone(),
            tokio_postgres::config::Host::Unix(p) => p.display().to_string(),
        })
        .unwrap_or_else(|| "localhost".into());
    let port = cfg.get_ports().first().copied().unwrap_or(5432);
    format!("{host}:{port}/{}", cfg.get_dbname().unwrap_or("-"))
}

/// First key of the per-sweep advisory lock taken by every transaction that stores
/// variant results (`pg_advisory_xact_lock(RESULTS_LOCK_CLASS, hashtext(sweep_id))`).
pub const RESULTS_LOCK_CLASS: i32 = 0x6273;

/// Takes the per-sweep results lock for the rest of `tx` (see [`PgQueue::complete`]).
pub(crate) async fn lock_results(
    tx: &tokio_postgres::Transaction<'_>,
    sweep_id: &str,
) -> Result<(), tokio_postgres::Error> {
    tx.execute(
        "SELECT pg_advisory_xact_lock($1, hashtext($2))",
        &[&RESULTS_LOCK_CLASS, &sweep_id],
    )
    .await
    .map(|_| ())
}

/// Advisory lock key serialising limited submissions (`pg_advisory_xact_lock`): any
/// constant other users of the database do not take ("bsweepq" in ASCII).
const SUBMIT_LOCK_KEY: i64 = 0x0062_7377_6565_7071;

fn millis(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

impl PgQueue {
    /// A pool of at most `max_connections` to `url` (`postgres://user[:pw]@host:port/db`
    /// or a key=value string). Connects lazily: nothing is contacted here.
    pub fn new(url: &str, max_connections: usize) -> Result<PgQueue, PgError> {
        let cfg = tokio_postgres::Config::from_str(url).map_err(|e| {
            // The parser's messages name the bad part, never the password's value.
            PgError::Url(format!("not a PostgreSQL URL: {e}"))
        })?;
        let target = describe(&cfg);
        let mut cfg = cfg;
        if cfg.get_connect_timeout().is_none() {
            // A server that does not answer is retried with backoff, not waited on.
            cfg.connect_timeout(Duration::from_secs(5));
        }
        if cfg.get_application_name().is_none() {
            cfg.application_name("bearing-sweep");
        }
        // The queue's statements are short index walks; the planner's cost estimates on
        // large batch tables would switch the JIT compiler on, which alone costs ~0.4 s
        // per statement (measured: claims/s of the storm went from 5 to thousands).
        let opts = cfg.get_options().map(|o| format!("{o} -c jit=off"));
        cfg.options(opts.as_deref().unwrap_or("-c jit=off"));
        let mgr = Manager::from_config(
            cfg,
            NoTls,
            ManagerConfig {
                // A connection the server closed (restart) reports is_closed and is
                // dropped at once; a half-open one fails its next statement (transient).
                recycling_method: RecyclingMethod::Fast,
            },
        );
        let pool = Pool::builder(mgr)
            .max_size(max_connections.max(1))
            .runtime(Runtime::Tokio1)
            .wait_timeout(Some(Duration::from_secs(10)))
            .create_timeout(Some(Duration::from_secs(5)))
            .recycle_timeout(Some(Duration::from_secs(5)))
            .build()
            .map_err(|e| PgError::Url(format!("connection pool: {e}")))?;
        Ok(PgQueue { pool, target })
    }

    /// A pooled connection (for the store's own statements).
    pub async fn connection(
        &self,
        context: &'static str,
    ) -> Result<deadpool_postgres::Object, PgError> {
        self.client(context).await
    }

    /// The error of a failed statement while doing `context`.
    pub fn db_error(&self, context: &'static str, source: tokio_postgres::Error) -> PgError {
        PgError::Db {
            target: self.target.clone(),
            context,
            source,
        }
    }

    /// `host:port/db` (no credentials), for messages.
    pub fn target(&self) -> &str {
        &self.target
    }

    async fn client(&self, context: &'static str) -> Result<deadpool_postgres::Object, PgError> {
        self.pool.get().await.map_err(|e| PgError::Pool {
            target: self.target.clone(),
            context,
            reason: e.to_string(),
        })
    }

    fn db(&self, context: &'static str) -> impl Fn(tokio_postgres::Error) -> PgError + '_ {
        move |source| PgError::Db {
            target: self.target.clone(),
            context,
            source,
        }
    }

    /// Runs the migrations; returns the versions applied now.
    pub async fn migrate(&self) -> Result<Vec<i32>, PgError> {
        let mut c = self.client("migrating the schema").await?;
        let client: &mut tokio_postgres::Client = &mut c;
        migrate(client, &self.target).await
    }

    /// Enqueues a sweep and its work batches in one transaction.
    pub async fn submit(&self, s: &QueuedSweep) -> Result<(), PgError> {
        self.submit_limited(s, None).await.map(|_| ())
    }

    /// [`PgQueue::submit`] unless `max_open` sweeps are queued or running already: then
    /// nothing is stored and the count is returned (`Ok(Some(open))`). The count and the
    /// insert are one transaction serialised by an advisory lock, so simultaneous
    /// submissions (from any number of servers) never pass the limit.
    pub async fn submit_limited(
        &self,
        s: &QueuedSweep,
        max_open: Option<u64>,
    ) -> Result<Option<u64>, PgError> {
        if s.batch_variants <= 0 {
            return Err(PgError::Sweep {
                id: s.id.clone(),
                reason: format!("batch_variants {} is not positive", s.batch_variants),
            });
        }
        let options = serde_json::to_string(&s.options).unwrap_or_default();
        let spec = serde_json::to_string(&s.spec).unwrap_or_default();
        let total = s.total as i64;
        let done_at_once = total == 0 && !s.local;
        let posted = s.posted.as_ref().map(Value::to_string);
        let mut c = self.client("submitting a sweep").await?;
        let tx = c
            .transaction()
            .await
            .map_err(self.db("submitting a sweep"))?;
        if let Some(limit) = max_open {
            // Held to the end of the transaction: one counting submitter at a time.
            tx.execute("SELECT pg_advisory_xact_lock($1)", &[&SUBMIT_LOCK_KEY])
                .await
                .map_err(self.db("locking the sweep count"))?;
            let open: i64 = tx
                .query_one(
                    "SELECT count(*) FROM sweeps WHERE status IN ('queued', 'running')",
                    &[],
                )
                .await
                .map_err(self.db("counting open sweeps"))?
                .get(0);
            if open as u64 >= limit {
                return Ok(Some(open as u64));
            }
        }
        tx.execute(
            "INSERT INTO sweeps (id, name, kind, spec, options, backend, batch_variants, total,
                                 status, finished_at, posted_spec, local, created_at)
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8,
                     CASE WHEN $9 THEN 'done' ELSE 'queued' END,
                     CASE WHEN $9 THEN now() END, $10, $11,
                     COALESCE(to_timestamp($12::float8), now()))",
            &[
                &s.id,
                &s.name,
                &s.kind,
                &spec,
                &options,
                &s.options.backend_name(),
                &s.batch_variants,
                &total,
                &done_at_once,
                &posted,
                &s.local,
                &s.created_unix_s,
            ],
        )
        .await
        .map_err(self.db("inserting a sweep"))?;
        if s.local {
            tx.commit().await.map_err(self.db("submitting a sweep"))?;
            return Ok(None);
        }
        tx.execute(
            "INSERT INTO work_batches (sweep_id, batch_no, first_id, end_id)
             SELECT $1, g, g::bigint * $2::bigint, LEAST((g::bigint + 1) * $2::bigint, $3::bigint)
             FROM generate_series(0, (($3::bigint + $2::bigint - 1) / $2::bigint)::int - 1) AS g",
            &[&s.id, &(s.batch_variants as i64), &total],
        )
        .await
        .map_err(self.db("inserting work batches"))?;
        tx.commit().await.map_err(self.db("submitting a sweep"))?;
        Ok(None)
    }

    /// Claims up to `max_variants` variants (whole batches, at least one) of the oldest
    /// running or queued sweep that a `backend` (`cpu` or `gpu`) worker may run, under a
    /// new lease valid for `ttl`. `None` when there is no work for this worker.
    pub async fn claim(
        &self,
        worker_id: &str,
        backend: &str,
        max_variants: u64,
        ttl: Duration,
    ) -> Result<Option<Lease>, PgError> {
        const CTX: &str = "claiming work";
        let mut c = self.client(CTX).await?;
        let candidates = c
            .query(
                "SELECT s.id, s.batch_variants FROM sweeps s
                 WHERE s.status IN ('queued', 'running')
                   AND (s.backend = 'auto' OR s.backend = $1)
                   AND (s.backend_resolved IS NULL OR s.backend_resolved = $1)
                 ORDER BY s.seq LIMIT $2",
                &[&backend, &CLAIM_CANDIDATES],
            )
            .await
            .map_err(self.db(CTX))?;
        for cand in candidates {
            let sweep_id: String = cand.get(0);
            let per_row: i32 = cand.get(1);
            let rows = (max_variants as i64)
                .div_euclid(per_row.max(1) as i64)
                .clamp(1, MAX_ROWS_PER_CLAIM);
            let tx = c.transaction().await.map_err(self.db(CTX))?;
            let picked = tx
                .query(
                    // Walks the open-batch index in order and stops at the limit (a join
                    // with the leases would make the planner read every batch of the
                    // sweep on each claim).
                    "SELECT b.batch_no, b.first_id, b.end_id
                     FROM work_batches b
                     WHERE b.sweep_id = $1 AND b.state <> 'done'
                       AND (b.state = 'queued' OR NOT EXISTS (
                           SELECT 1 FROM leases l
                           WHERE l.id = b.lease_id AND l.expires_at >= now()))
                     ORDER BY b.batch_no LIMIT $2
                     FOR UPDATE SKIP LOCKED",
                    &[&sweep_id, &rows],
                )
                .await
                .map_err(self.db(CTX))?;
            // Re-check the rows just locked in a new statement (a new snapshot under READ
            // COMMITTED). A batch that another worker leased and committed while this
            // SELECT ran is re-evaluated by PostgreSQL on its new row version, but the
            // `NOT EXISTS` subquery still reads the statement's old snapshot, where that
            // worker's lease row does not exist yet: the batch looks claimable and would
            // be claimed twice (seen in CI: 67 claims for 63 batches). The rows are locked
            // by this transaction now, so what this check sees cannot change before commit.
            let nos: Vec<i32> = picked.iter().map(|r| r.get(0)).collect();
            let picked = if picked.is_empty() {
                picked
            } else {
                tx.query(
                    "SELECT b.batch_no, b.first_id, b.end_id
                     FROM work_batches b
                     WHERE b.sweep_id = $1 AND b.batch_no = ANY($2) AND b.state <> 'done'
                       AND (b.state = 'queued' OR NOT EXISTS (
                           SELECT 1 FROM leases l
                           WHERE l.id = b.lease_id AND l.expires_at >= now()))
                     ORDER BY b.batch_no",
                    &[&sweep_id, &nos],
                )
                .await
                .map_err(self.db(CTX))?
            };
            if picked.is_empty() {
                // Others hold them all (or took them since): try the next sweep.
                tx.rollback().await.map_err(self.db(CTX))?;
                continue;
            }
            let batches: Vec<(i32, i64, i64)> = picked
                .iter()
                .map(|r| (r.get(0), r.get(1), r.get(2)))
                .collect();
            let n: i64 = batches.iter().map(|b| b.2 - b.1).sum();
            // Fix the backend of an `auto` sweep and mark it running, only when needed
            // (so that claims do not queue on the sweep row).
            tx.execute(
                "UPDATE sweeps SET status = 'running',
                        started_at = COALESCE(started_at, now()),
                        backend_resolved = COALESCE(backend_resolved, $2)
                 WHERE id = $1 AND (status = 'queued' OR backend_resolved IS NULL)",
                &[&sweep_id, &backend],
            )
            .await
            .map_err(self.db(CTX))?;
            let check = tx
                .query_opt(
                    "SELECT status, backend_resolved FROM sweeps WHERE id = $1",
                    &[&sweep_id],
                )
                .await
                .map_err(self.db(CTX))?;
            let runnable = check.is_some_and(|r| {
                r.get::<_, String>(0) == "running"
                    && r.get::<_, Option<String>>(1).as_deref() == Some(backend)
            });
            if !runnable {
                // Cancelled meanwhile, or an `auto` sweep another backend fixed first.
                tx.rollback().await.map_err(self.db(CTX))?;
                continue;
            }
            let lease_id: i64 = tx
                .query_one(
                    "INSERT INTO leases (sweep_id, worker_id, variants, expires_at)
                     VALUES ($1, $2, $3, now() + $4::float8 * interval '1 millisecond')
                     RETURNING id",
                    &[&sweep_id, &worker_id, &n, &millis(ttl)],
                )
                .await
                .map_err(self.db(CTX))?
                .get(0);
            let nos: Vec<i32> = batches.iter().map(|b| b.0).collect();
            tx.execute(
                "UPDATE work_batches SET state = 'leased', lease_id = $1, attempts = attempts + 1
                 WHERE sweep_id = $2 AND batch_no = ANY($3)",
                &[&lease_id, &sweep_id, &nos],
            )
            .await
            .map_err(self.db(CTX))?;
            tx.commit().await.map_err(self.db(CTX))?;
            return Ok(Some(Lease {
                id: lease_id,
                sweep_id,
                worker_id: worker_id.to_string(),
                batches,
            }));
        }
        Ok(None)
    }

    /// Extends `lease` by `ttl` and reports whether it is still worth running.
    pub async fn heartbeat(&self, lease: &Lease, ttl: Duration) -> Result<LeaseState, PgError> {
        const CTX: &str = "renewing a lease";
        let c = self.client(CTX).await?;
        let row = c
            .query_opt(
                "UPDATE leases l SET heartbeat_at = now(),
                        expires_at = now() + $3::float8 * interval '1 millisecond'
                 WHERE l.id = $1 AND l.worker_id = $2
                 RETURNING (SELECT s.status FROM sweeps s WHERE s.id = l.sweep_id),
                           (SELECT count(*) FROM work_batches b
                            WHERE b.lease_id = l.id AND b.state = 'leased')",
                &[&lease.id, &lease.worker_id, &millis(ttl)],
            )
            .await
            .map_err(self.db(CTX))?;
        let Some(row) = row else {
            // The lease row is gone: its sweep was deleted.
            return Ok(LeaseState::Stopped("deleted".into()));
        };
        let status: Option<String> = row.get(0);
        let held: i64 = row.get(1);
        match status.as_deref() {
            Some("running") if held == lease.batches.len() as i64 => Ok(LeaseState::Held),
            Some("running") => Ok(LeaseState::Lost),
            Some(s) => Ok(LeaseState::Stopped(s.to_string())),
            None => Ok(LeaseState::Stopped("deleted".into())),
        }
    }

    /// Stores `rows` (the lease's variants) and marks the lease's batches done, in one
    /// transaction, if the lease still holds them and the sweep is running. `settings`:
    /// the worker's result-changing settings; the first completion records them, a
    /// later one that differs fails (nothing stored).
    pub async fn complete(
        &self,
        lease: &Lease,
        settings: &Value,
        rows: &[VariantRow],
    ) -> Result<Completion, PgError> {
        const CTX: &str = "completing a lease";
        let mut c = self.client(CTX).await?;
        // The first completion of a sweep records its settings, in a statement of its own
        // (inside the transaction, the row lock would be held through the commit and the
        // first completions of a busy sweep would queue behind each other).
        c.execute(
            "UPDATE sweeps SET settings = $2 WHERE id = $1 AND settings IS NULL",
            &[&lease.sweep_id, &settings.to_string()],
        )
        .await
        .map_err(self.db(CTX))?;
        let tx = c.transaction().await.map_err(self.db(CTX))?;
        let held = tx
            .query(
                "SELECT state, lease_id FROM work_batches
                 WHERE sweep_id = $1 AND batch_no = ANY($2)
                 ORDER BY batch_no FOR UPDATE",
                &[&lease.sweep_id, &lease.batch_nos()],
            )
            .await
            .map_err(self.db(CTX))?;
        let mine = |r: &tokio_postgres::Row| r.get::<_, Option<i64>>(1) == Some(lease.id);
        let all = held.len() == lease.batches.len();
        if all
            && held
                .iter()
                .all(|r| mine(r) && r.get::<_, String>(0) == "done")
        {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Ok(Completion::AlreadyCommitted);
        }
        if !all
            || !held
                .iter()
                .all(|r| mine(r) && r.get::<_, String>(0) == "leased")
        {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Ok(Completion::LeaseLost);
        }
        // The sweep row is read, not locked: completions of one sweep do not queue behind
        // each other (their counts go to their own lease rows).
        let sweep = tx
            .query_opt(
                "SELECT status, settings FROM sweeps WHERE id = $1",
                &[&lease.sweep_id],
            )
            .await
            .map_err(self.db(CTX))?;
        let Some(sweep) = sweep else {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Ok(Completion::Stopped("deleted".into()));
        };
        let status: String = sweep.get(0);
        if status != "running" {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Ok(Completion::Stopped(status));
        }
        let stored_settings = sweep.get::<_, Option<String>>(1);
        let stored: Value = stored_settings
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or(Value::Null);
        if &stored != settings {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Err(PgError::Sweep {
                id: lease.sweep_id.clone(),
                reason: format!(
                    "this worker's settings {settings} differ from the sweep's {stored} (workers of one sweep must compute alike)"
                ),
            });
        }
        let expected = lease.variant_ids();
        let mut got: Vec<u64> = rows.iter().map(|r| r.id).collect();
        got.sort_unstable();
        if got != expected {
            tx.rollback().await.map_err(self.db(CTX))?;
            return Err(PgError::Sweep {
                id: lease.sweep_id.clone(),
                reason: format!(
                    "lease {} holds {} variants but {} results were given (internal error)",
                    lease.id,
                    expected.len(),
                    got.len()
                ),
            });
        }
        let ids: Vec<i64> = rows.iter().map(|r| r.id as i64).collect();
        let oks: Vec<bool> = rows.iter().map(|r| r.ok).collect();
        let lines: Vec<&str> = rows.iter().map(|r| r.line.as_str()).collect();
        // Result rows of one sweep commit in the order of their `seq`: the lock (held to
        // the commit) makes the sequence numbers drawn below and the commit one step, so
        // a reader following `seq > last seen` never passes over a late commit of lower
        // numbers (the server's event stream; issue 22 item 4). Only the insert and two
        // small updates are serialised, not the computing.
        lock_results(&tx, &lease.sweep_id)
            .await
            .map_err(self.db(CTX))?;
        tx.execute(
            "INSERT INTO variant_results (sweep_id, variant_id, ok, line, lease_id, worker_id)
             SELECT $1, v.id, v.ok, v.line, $5, $6
             FROM unnest($2::bigint[], $3::bool[], $4::text[]) AS v(id, ok, line)",
            &[
                &lease.sweep_id,
                &ids,
                &oks,
                &lines,
                &lease.id,
                &lease.worker_id,
            ],
        )
        .await
        .map_err(self.db(CTX))?;
        tx.execute(
            "UPDATE work_batches SET state = 'done' WHERE sweep_id = $1 AND batch_no = ANY($2)",
            &[&lease.sweep_id, &lease.batch_nos()],
        )
        .await
        .map_err(self.db(CTX))?;
        let n = rows.len() as i64;
        let not_ok = rows.iter().filter(|r| !r.ok).count() as i64;
        tx.execute(
            "UPDATE leases SET stored = $2, not_ok = $3, heartbeat_at = now() WHERE id = $1",
            &[&lease.id, &n, &not_ok],
        )
        .await
        .map_err(self.db(CTX))?;
        tx.commit().await.map_err(self.db(CTX))?;
        // On the connection already held: asking the pool for a second one would wait out
        // its 10 s timeout in a pool of one connection (and then fail, leaving the sweep
        // running with every batch done). A failure here is not the completion's: its
        // results are committed, and the next completion or the monitor finalizes.
        let sweep_done = self.finalize_on(&c, &lease.sweep_id).await.unwrap_or(false);
        Ok(Completion::Committed { sweep_done })
    }

    /// Marks a running sweep done once none of its batches is open. Every completion runs
    /// it after its commit, so the last one to commit sees every batch done.
    pub async fn finalize(&self, id: &str) -> Result<bool, PgError> {
        let c = self.client("finishing a sweep").await?;
        self.finalize_on(&c, id).await
    }

    /// [`Self::finalize`] on a connection the caller holds.
    async fn finalize_on(&self, c: &tokio_postgres::Client, id: &str) -> Result<bool, PgError> {
        const CTX: &str = "finishing a sweep";
        let n = c
            .execute(
                "UPDATE sweeps SET status = 'done', finished_at = now()
                 WHERE id = $1 AND status = 'running' AND NOT local
                   AND NOT EXISTS (SELECT 1 FROM work_batches b
                                   WHERE b.sweep_id = $1 AND b.state <> 'done')",
                &[&id],
            )
            .await
            .map_err(self.db(CTX))?;
        Ok(n == 1)
    }

    /// Gives a lease's batches back to the queue at once (a worker shutting down or
    /// unable to run them), if it still holds them.
    pub async fn release(&self, lease: &Lease) -> Result<(), PgError> {
        const CTX: &str = "giving a lease back";
        let c = self.client(CTX).await?;
        c.execute(
            "UPDATE work_batches SET state = 'queued', lease_id = NULL
             WHERE sweep_id = $1 AND lease_id = $2 AND state = 'leased'",
            &[&lease.sweep_id, &lease.id],
        )
        .await
        .map_err(self.db(CTX))?;
        Ok(())
    }

    /// Marks a sweep failed with `message` (e.g. its spec does not parse on a worker).
    pub async fn fail_sweep(&self, id: &str, message: &str) -> Result<(), PgError> {
        const CTX: &str = "marking a sweep failed";
        let c = self.client(CTX).await?;
        c.execute(
            "UPDATE sweeps SET status = 'failed', error = $2, finished_at = now()
             WHERE id = $1 AND status IN ('queued', 'running')",
            &[&id, &message],
        )
        .await
        .map_err(self.db(CTX))?;
        Ok(())
    }

    /// Cancels a queued or running sweep: no batch is claimed any more, running ones stop
    /// at their next heartbeat, finished variants stay. `false` when it had ended already.
    pub async fn cancel(&self, id: &str) -> Result<bool, PgError> {
        const CTX: &str = "cancelling a sweep";
        let c = self.client(CTX).await?;
        let n = c
            .execute(
                "UPDATE sweeps SET status = 'cancelled', finished_at = now()
                 WHERE id = $1 AND status IN ('queued', 'running')",
                &[&id],
            )
            .await
            .map_err(self.db(CTX))?;
        if n == 0 && self.sweep(id).await?.is_none() {
            return Err(PgError::NotFound(id.to_string()));
        }
        Ok(n == 1)
    }

    /// Deletes a sweep with its batches, leases and results. `false` if there was none.
    pub async fn delete(&self, id: &str) -> Result<bool, PgError> {
        const CTX: &str = "deleting a sweep";
        let c = self.client(CTX).await?;
        let n = c
            .execute("DELETE FROM sweeps WHERE id = $1", &[&id])
            .await
            .map_err(self.db(CTX))?;
        Ok(n == 1)
    }

    fn sweep_row(r: &tokio_postgres::Row) -> QueueRow {
        let json = |s: Option<String>| s.and_then(|t| serde_json::from_str::<Value>(&t).ok());
        QueueRow {
            id: r.get("id"),
            name: r.get("name"),
            kind: r.get("kind"),
            status: r.get("status"),
            total: r.get::<_, i64>("total") as u64,
            done: r.get::<_, i64>("done") as u64,
            failed: r.get::<_, i64>("failed") as u64,
            error: r.get("error"),
            created_unix_s: r.get("created_s"),
            started_unix_s: r.get("started_s"),
            finished_unix_s: r.get("finished_s"),
            settings: json(r.get("settings")),
            options: r
                .get::<_, Option<String>>("options")
                .and_then(|t| serde_json::from_str(&t).ok())
                .unwrap_or_default(),
            backend_resolved: r.get("backend_resolved"),
        }
    }

    const SWEEP_COLUMNS: &'static str = "id, name, kind, status, total,
        (s.done + COALESCE((SELECT sum(l.stored) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint AS done,
        (s.failed + COALESCE((SELECT sum(l.not_ok) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint AS failed,
        error,
        extract(epoch FROM created_at)::float8 AS created_s,
        extract(epoch FROM started_at)::float8 AS started_s,
        extract(epoch FROM finished_at)::float8 AS finished_s,
        settings, options, backend_resolved";

    /// One sweep, `None` if there is no such id.
    pub async fn sweep(&self, id: &str) -> Result<Option<QueueRow>, PgError> {
        const CTX: &str = "reading a sweep";
        let c = self.client(CTX).await?;
        let sql = format!(
            "SELECT {} FROM sweeps s WHERE s.id = $1",
            Self::SWEEP_COLUMNS
        );
        let row = c.query_opt(&sql, &[&id]).await.map_err(self.db(CTX))?;
        Ok(row.as_ref().map(Self::sweep_row))
    }

    /// Every sweep, oldest first.
    pub async fn sweeps(&self) -> Result<Vec<QueueRow>, PgError> {
        const CTX: &str = "listing sweeps";
        let c = self.client(CTX).await?;
        let sql = format!("SELECT {} FROM sweeps s ORDER BY seq", Self::SWEEP_COLUMNS);
        let rows = c.query(&sql, &[]).await.map_err(self.db(CTX))?;
        Ok(rows.iter().map(Self::sweep_row).collect())
    }

    /// The spec and options a worker needs to run a sweep.
    pub async fn job(&self, id: &str) -> Result<SweepJob, PgError> {
        const CTX: &str = "reading a sweep's spec";
        let c = self.client(CTX).await?;
        let row = c
            .query_opt("SELECT spec, options FROM sweeps WHERE id = $1", &[&id])
            .await
            .map_err(self.db(CTX))?
            .ok_or_else(|| PgError::NotFound(id.to_string()))?;
        let bad = |what: &str, e: serde_json::Error| PgError::Sweep {
            id: id.to_string(),
            reason: format!("stored {what} is not valid JSON: {e}"),
        };
        let spec: Value =
            serde_json::from_str(&row.get::<_, String>(0)).map_err(|e| bad("spec", e))?;
        let options: SweepOptions =
            serde_json::from_str(&row.get::<_, String>(1)).map_err(|e| bad("options", e))?;
        Ok(SweepJob {
            id: id.to_string(),
            spec,
            options,
        })
    }

    /// Finished variants of a sweep with id >= `from_id`, ascending, at most `limit`:
    /// (id, status is `ok`, line). Readable while the sweep runs.
    pub async fn variants(
        &self,
        id: &str,
        from_id: u64,
        limit: u64,
    ) -> Result<Vec<VariantRow>, PgError> {
        const CTX: &str = "reading variants";
        let c = self.client(CTX).await?;
        let rows = c
            .query(
                "SELECT variant_id, ok, line FROM variant_results
                 WHERE sweep_id = $1 AND variant_id >= $2
                 ORDER BY variant_id LIMIT $3",
                &[&id, &(from_id as i64), &(limit.min(i64::MAX as u64) as i64)],
            )
            .await
            .map_err(self.db(CTX))?;
        Ok(rows
            .iter()
            .map(|r| VariantRow {
                id: r.get::<_, i64>(0) as u64,
                ok: r.get(1),
                line: r.get(2),
            })
            .collect())
    }

    /// Finished variants in pages of `offset`/`limit` (rank in id order), as the
    /// service's `/variants?offset=&limit=`.
    pub async fn variants_page(
        &self,
        id: &str,
        offset: u64,
        limit: u64,
    ) -> Result<Vec<VariantRow>, PgError> {
        const CTX: &str = "reading variants";
        let c = self.client(CTX).await?;
        let rows = c
            .query(
                "SELECT variant_id, ok, line FROM variant_results WHERE sweep_id = $1
                 ORDER BY variant_id OFFSET $2 LIMIT $3",
                &[
                    &id,
                    &(offset.min(i64::MAX as u64) as i64),
                    &(limit.min(i64::MAX as u64) as i64),
                ],
            )
            .await
            .map_err(self.db(CTX))?;
        Ok(rows
            .iter()
            .map(|r| VariantRow {
                id: r.get::<_, i64>(0) as u64,
                ok: r.get(1),
                line: r.get(2),
            })
            .collect())
    }

    /// Queue figures for diagnostics and tests: (batches per state, leases claimed in
    /// all, batch claims in all (attempts summed)).
    pub async fn batch_stats(&self, id: &str) -> Result<BatchStats, PgError> {
        const CTX: &str = "reading queue statistics";
        let c = self.client(CTX).await?;
        let r = c
            .query_one(
                "SELECT count(*) FILTER (WHERE state = 'queued'),
                        count(*) FILTER (WHERE state = 'leased'),
                        count(*) FILTER (WHERE state = 'done'),
                        COALESCE(sum(attempts), 0)::bigint,
                        (SELECT count(*) FROM leases WHERE sweep_id = $1),
                        (SELECT count(DISTINCT worker_id) FROM variant_results WHERE sweep_id = $1)
                 FROM work_batches WHERE sweep_id = $1",
                &[&id],
            )
            .await
            .map_err(self.db(CTX))?;
        Ok(BatchStats {
            queued: r.get::<_, i64>(0) as u64,
            leased: r.get::<_, i64>(1) as u64,
            done: r.get::<_, i64>(2) as u64,
            claims: r.get::<_, i64>(3) as u64,
            leases: r.get::<_, i64>(4) as u64,
            workers: r.get::<_, i64>(5) as u64,
        })
    }
}

/// Work batch counters of one sweep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct BatchStats {
    /// Batches waiting.
    pub queued: u64,
    /// Batches under a lease.
    pub leased: u64,
    /// Batches done.
    pub done: u64,
    /// Batch claims summed (more than the batches: some were claimed again).
    pub claims: u64,
    /// Leases taken.
    pub leases: u64,
    /// Distinct workers that stored results.
    pub workers: u64,
}
