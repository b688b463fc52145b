//! The service's [`Store`] on PostgreSQL: the same sweeps, variant lines and figures as
//! the embedded SQLite store, kept in the queue's tables, so that `serve --database
//! postgres://…` answers every route as the embedded store does while worker processes
//! compute.
//!
//! Who runs what: a rotor or synthetic sweep is split into work batches at submission
//! and run by `bearing-sweep worker` processes ([`Store::runs_elsewhere`]); the workers
//! own its `queued → running → done` status. A friction map (no dynamics, one document)
//! is run by the server's scheduler as on the embedded store.
//!
//! The trait is blocking; the store owns a small tokio runtime for its pool and runs each
//! call there (so it can be called from the server's blocking threads and from its
//! start-up code alike). Transient errors (server restarting, connection lost) are
//! retried with backoff for up to [`RETRY_FOR`] before a call fails.

use std::time::{Duration, Instant};

use serde_json::Value;

use super::error::PgError;
use super::queue::{PgQueue, QueuedSweep, SweepOptions, DEFAULT_BATCH_VARIANTS};
use crate::service::{NewSweep, Store, StoreError, SweepRow, SweepStatus, SweepUpdate};
use crate::sweep::sink::Committed;
use crate::sweep::SweepKind;

/// How long opening the store retries transient errors before it fails (a restart of the
/// database server takes a few seconds).
pub const RETRY_FOR: Duration = Duration::from_secs(30);
/// How long one call of a running server (a request, the scheduler) retries transient
/// errors, and waits at most in all, before it fails as [`StoreError::Unavailable`]
/// (HTTP 503 with `Retry-After`): a client is better told to come back than kept
/// waiting through an outage.
pub const CALL_RETRY_FOR: Duration = Duration::from_secs(3);
/// First retry delay; doubles up to [`RETRY_MAX`].
const RETRY_START: Duration = Duration::from_millis(100);
/// Longest retry delay.
const RETRY_MAX: Duration = Duration::from_secs(2);
/// Connections of the server's pool.
const POOL_SIZE: usize = 8;

/// The PostgreSQL store.
pub struct PgStore {
    queue: PgQueue,
    rt: Option<tokio::runtime::Runtime>,
    batch_variants: i32,
}

fn backend(e: PgError) -> StoreError {
    match e {
        PgError::NotFound(id) => StoreError::NotFound(id),
        other if other.is_transient() => StoreError::Unavailable(other.to_string()),
        other => StoreError::Backend(other.to_string()),
    }
}

/// Progress: the server's own count (variants it committed) plus its leases' counts.
const ROW_COLUMNS: &str = "id, seq, name, status, spec, posted_spec, options, total,
    (s.done + COALESCE((SELECT sum(l.stored) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS done,
    (s.failed + COALESCE((SELECT sum(l.not_ok) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS failed,
    (s.computed + COALESCE((SELECT sum(l.stored) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS computed,
    error, run, header, settings,
    extract(epoch FROM created_at)::float8 AS created_s,
    extract(epoch FROM started_at)::float8 AS started_s,
    extract(epoch FROM finished_at)::float8 AS finished_s";

/// [`ROW_COLUMNS`] without the large documents (spec, posted spec, header, settings):
/// what listing and status read.
const SUMMARY_COLUMNS: &str = "id, seq, name, status, NULL::text AS spec,
    NULL::text AS posted_spec, options, total,
    (s.done + COALESCE((SELECT sum(l.stored) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS done,
    (s.failed + COALESCE((SELECT sum(l.not_ok) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS failed,
    (s.computed + COALESCE((SELECT sum(l.stored) FROM leases l WHERE l.sweep_id = s.id), 0))::bigint
        AS computed,
    error, run, NULL::text AS header, NULL::text AS settings,
    extract(epoch FROM created_at)::float8 AS created_s,
    extract(epoch FROM started_at)::float8 AS started_s,
    extract(epoch FROM finished_at)::float8 AS finished_s";

fn json_col(r: &tokio_postgres::Row, col: &str) -> Option<Value> {
    r.get::<_, Option<String>>(col)
        .and_then(|t| serde_json::from_str(&t).ok())
}

fn to_row(r: &tokio_postgres::Row) -> SweepRow {
    let settings = json_col(r, "settings");
    // A worker-run sweep has no stream header; the routes read its settings from one.
    let header =
        json_col(r, "header").or_else(|| settings.map(|s| serde_json::json!({"settings": s})));
    SweepRow {
        id: r.get("id"),
        seq: r.get("seq"),
        name: r.get("name"),
        status: SweepStatus::parse(&r.get::<_, String>("status")).unwrap_or(SweepStatus::Failed),
        spec: json_col(r, "posted_spec")
            .or_else(|| json_col(r, "spec"))
            .unwrap_or(Value::Null),
        options: json_col(r, "options").unwrap_or(Value::Null),
        total: r.get::<_, i64>("total") as u64,
        done: r.get::<_, i64>("done") as u64,
        failed: r.get::<_, i64>("failed") as u64,
        computed: r.get::<_, i64>("computed") as u64,
        message: r.get("error"),
        run: json_col(r, "run"),
        header,
        created_unix_s: r.get("created_s"),
        started_unix_s: r.get("started_s"),
        finished_unix_s: r.get("finished_s"),
    }
}

impl PgStore {
    /// Connects to `url`, running the migrations (retried while the server is
    /// unreachable, up to [`RETRY_FOR`]). Work batches of submitted sweeps hold
    /// [`DEFAULT_BATCH_VARIANTS`] variants.
    pub fn open(url: &str) -> Result<PgStore, StoreError> {
        let queue = PgQueue::new(url, POOL_SIZE).map_err(backend)?;
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("bearing-sweep-pg")
            .enable_all()
            .build()
            .map_err(|e| StoreError::Backend(format!("PostgreSQL store runtime: {e}")))?;
        let store = PgStore {
            queue,
            rt: Some(rt),
            batch_variants: DEFAULT_BATCH_VARIANTS,
        };
        store.call_for(RETRY_FOR, |q| async move { q.migrate().await.map(|_| ()) })?;
        Ok(store)
    }

    /// The queue under the store (workers in the same process, the event monitor).
    pub fn queue(&self) -> &PgQueue {
        &self.queue
    }

    /// Runs `f(queue)` on the store's runtime, retrying transient errors with backoff
    /// for up to [`CALL_RETRY_FOR`].
    fn call<T, F, Fut>(&self, f: F) -> Result<T, StoreError>
    where
        T: Send + 'static,
        F: Fn(PgQueue) -> Fut + Send + 'static,
        Fut: std::future::Future<Output = Result<T, PgError>> + Send,
    {
        self.call_for(CALL_RETRY_FOR, f)
    }

    /// [`PgStore::call`] retrying for up to `window` in all (each attempt is cut at the
    /// end of the window too: an unreachable host does not hold the caller longer).
    fn call_for<T, F, Fut>(&self, window: Duration, f: F) -> Result<T, StoreError>
    where
        T: Send + 'static,
        F: Fn(PgQueue) -> Fut + Send + 'static,
        Fut: std::future::Future<Output = Result<T, PgError>> + Send,
    {
        let queue = self.queue.clone();
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let rt = self
            .rt
            .as_ref()
            .ok_or_else(|| StoreError::Backend("the PostgreSQL store is closed".into()))?;
        rt.spawn(async move {
            let started = Instant::now();
            let mut delay = RETRY_START;
            let result = loop {
                let left = window.saturating_sub(started.elapsed());
                let attempt = match tokio::time::timeout(left, f(queue.clone())).await {
                    Ok(r) => r.map_err(backend),
                    Err(_) => Err(StoreError::Unavailable(format!(
                        "PostgreSQL at {}: no answer within {window:?}",
                        queue.target()
                    ))),
                };
                match attempt {
                    Err(StoreError::Unavailable(e)) if started.elapsed() + delay < window => {
                        tracing::warn!("{e}; retrying in {delay:?}");
                        tokio::time::sleep(delay).await;
                        delay = (delay * 2).min(RETRY_MAX);
                    }
                    other => break other,
                }
            };
            let _ = tx.send(result);
        });
        rx.recv()
            .map_err(|_| StoreError::Backend("the PostgreSQL store's runtime stopped".into()))?
    }

    fn summary(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.row_by_id(id, SUMMARY_COLUMNS, "reading a sweep's status")
    }

    fn row(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.row_by_id(id, ROW_COLUMNS, "reading a sweep")
    }

    /// One sweep's row by id, reading `columns` ([`ROW_COLUMNS`] or [`SUMMARY_COLUMNS`]);
    /// `ctx` names the operation in a database error.
    fn row_by_id(
        &self,
        id: &str,
        columns: &'static str,
        ctx: &'static str,
    ) -> Result<Option<SweepRow>, StoreError> {
        let id = id.to_string();
        self.call(move |q| {
            let id = id.clone();
            async move {
                let c = q.connection(ctx).await?;
                let sql = format!("SELECT {columns} FROM sweeps s WHERE s.id = $1");
                let r = c
                    .query_opt(&sql, &[&id])
                    .await
                    .map_err(|e| q.db_error(ctx, e))?;
                Ok(r.as_ref().map(to_row))
            }
        })
    }
}

impl Drop for PgStore {
    fn drop(&mut self) {
        // Dropping a runtime inside another runtime's task would panic; this does not.
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

impl Store for PgStore {
    fn insert_sweep(&self, new: &NewSweep) -> Result<SweepRow, StoreError> {
        self.insert_sweep_limited(new, u64::MAX)
    }

    fn insert_sweep_limited(&self, new: &NewSweep, max_open: u64) -> Result<SweepRow, StoreError> {
        // The submission was parsed once by the route: its kind and canonical form come
        // with it.
        let options: SweepOptions = serde_json::from_value(new.options.clone()).unwrap_or_default();
        let sweep = match new.kind {
            SweepKind::Rotor | SweepKind::Synthetic | SweepKind::Stability => QueuedSweep {
                id: new.id.clone(),
                name: new.name.clone(),
                kind: new.kind.name().to_string(),
                spec: new.canonical.clone(),
                options,
                total: new.total,
                batch_variants: self.batch_variants,
                posted: Some(new.spec.clone()),
                local: false,
                created_unix_s: Some(new.created_unix_s),
            },
            SweepKind::FrictionMap => QueuedSweep {
                id: new.id.clone(),
                name: new.name.clone(),
                kind: new.kind.name().into(),
                spec: new.canonical.clone(),
                options,
                total: new.total,
                batch_variants: 1,
                posted: Some(new.spec.clone()),
                local: true,
                created_unix_s: Some(new.created_unix_s),
            },
        };
        let limit = (max_open < u64::MAX).then_some(max_open);
        let full = self.call(move |q| {
            let sweep = sweep.clone();
            async move { q.submit_limited(&sweep, limit).await }
        })?;
        if let Some(open) = full {
            return Err(StoreError::QueueFull {
                open,
                limit: max_open,
            });
        }
        self.summary(&new.id)?
            .ok_or_else(|| StoreError::NotFound(new.id.clone()))
    }

    fn sweep_summary(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.summary(id)
    }

    fn result_doc_text(&self, id: &str) -> Result<Option<String>, StoreError> {
        let id = id.to_string();
        self.call(move |q| {
            let id = id.clone();
            async move {
                const CTX: &str = "reading a result document";
                let c = q.connection(CTX).await?;
                let r = c
                    .query_opt("SELECT result_doc FROM sweeps WHERE id = $1", &[&id])
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                Ok(r.and_then(|r| r.get::<_, Option<String>>(0)))
            }
        })
    }

    fn next_queued(&self) -> Result<Option<SweepRow>, StoreError> {
        // Only local sweeps (friction maps) run on the server; workers run the rest.
        self.call(|q| async move {
            const CTX: &str = "looking for a local sweep";
            let c = q.connection(CTX).await?;
            let sql = format!(
                "SELECT {ROW_COLUMNS} FROM sweeps s WHERE status = 'queued' AND local
                 ORDER BY seq LIMIT 1"
            );
            let r = c
                .query_opt(&sql, &[])
                .await
                .map_err(|e| q.db_error(CTX, e))?;
            Ok(r.as_ref().map(to_row))
        })
    }

    fn list_sweeps(&self) -> Result<Vec<SweepRow>, StoreError> {
        self.call(|q| async move {
            const CTX: &str = "listing sweeps";
            let c = q.connection(CTX).await?;
            let sql = format!("SELECT {SUMMARY_COLUMNS} FROM sweeps s ORDER BY seq");
            let rows = c.query(&sql, &[]).await.map_err(|e| q.db_error(CTX, e))?;
            Ok(rows.iter().map(to_row).collect())
        })
    }

    fn sweep(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
        self.row(id)
    }

    fn count_queued(&self) -> Result<u64, StoreError> {
        self.call(|q| async move {
            const CTX: &str = "counting queued sweeps";
            let c = q.connection(CTX).await?;
            let r = c
                .query_one("SELECT count(*) FROM sweeps WHERE status = 'queued'", &[])
                .await
                .map_err(|e| q.db_error(CTX, e))?;
            Ok(r.get::<_, i64>(0) as u64)
        })
    }

    fn update_sweep(&self, id: &str, change: &SweepUpdate) -> Result<(), StoreError> {
        let id = id.to_string();
        let status = change.status.map(|s| s.name().to_string());
        let set_message = change.message.is_some();
        let message = change.message.clone().flatten();
        let run = change.run.as_ref().map(Value::to_string);
        let doc = change.result_doc.clone();
        let (started, finished) = (change.started_unix_s, change.finished_unix_s);
        let done = change.done.map(|d| d as i64);
        self.call(move |q| {
            let (id, status, message, run, doc) = (
                id.clone(),
                status.clone(),
                message.clone(),
                run.clone(),
                doc.clone(),
            );
            async move {
                const CTX: &str = "updating a sweep";
                let c = q.connection(CTX).await?;
                // The workers own the queued/running/done life of a worker-run sweep: the
                // server may only end it (cancel, fail), and only while it is open.
                c.execute(
                    "UPDATE sweeps SET
                        status = CASE
                            WHEN $2::text IS NULL THEN status
                            WHEN local THEN $2::text
                            WHEN $2::text IN ('cancelled', 'failed')
                                 AND status IN ('queued', 'running') THEN $2::text
                            ELSE status END,
                        error = CASE WHEN $3 THEN $4 ELSE error END,
                        run = COALESCE($5, run),
                        result_doc = COALESCE($6, result_doc),
                        started_at = COALESCE(to_timestamp($7::float8), started_at),
                        finished_at = COALESCE(to_timestamp($8::float8), finished_at),
                        done = COALESCE($9::bigint, done)
                     WHERE id = $1",
                    &[
                        &id,
                        &status,
                        &set_message,
                        &message,
                        &run,
                        &doc,
                        &started,
                        &finished,
                        &done,
                    ],
                )
                .await
                .map_err(|e| q.db_error(CTX, e))?;
                Ok(())
            }
        })
    }

    fn delete_sweep(&self, id: &str) -> Result<bool, StoreError> {
        let id = id.to_string();
        self.call(move |q| {
            let id = id.clone();
            async move { q.delete(&id).await }
        })
    }

    fn open_stream(&self, id: &str, header: &Value) -> Result<Committed, StoreError> {
        let sweep_id = id.to_string();
        let id = id.to_string();
        let header_text = header.to_string();
        let header = header.clone();
        let (stored, committed) = self.call(move |q| {
            let (id, header_text) = (id.clone(), header_text.clone());
            async move {
                const CTX: &str = "opening a sweep's stream";
                let c = q.connection(CTX).await?;
                let h = c
                    .query_opt(
                        "UPDATE sweeps SET header = COALESCE(header, $2) WHERE id = $1
                         RETURNING header",
                        &[&id, &header_text],
                    )
                    .await
                    .map_err(|e| q.db_error(CTX, e))?
                    .ok_or_else(|| PgError::NotFound(id.clone()))?;
                let rows = c
                    .query(
                        "SELECT variant_id, ok FROM variant_results WHERE sweep_id = $1",
                        &[&id],
                    )
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                let committed: Committed = rows
                    .iter()
                    .map(|r| (r.get::<_, i64>(0) as u64, r.get::<_, bool>(1)))
                    .collect();
                Ok((h.get::<_, Option<String>>(0), committed))
            }
        })?;
        let stored: Value = stored
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or(Value::Null);
        if stored != header {
            return Err(StoreError::Mismatch {
                id: sweep_id,
                reason: format!("stored {stored}, this run {header}"),
            });
        }
        Ok(committed)
    }

    fn commit_variant(
        &self,
        id: &str,
        variant: u64,
        ok: bool,
        line: &str,
    ) -> Result<(), StoreError> {
        let id = id.to_string();
        let line = line.to_string();
        self.call(move |q| {
            let (id, line) = (id.clone(), line.clone());
            async move {
                const CTX: &str = "committing a variant";
                let mut c = q.connection(CTX).await?;
                let tx = c.transaction().await.map_err(|e| q.db_error(CTX, e))?;
                // Commit order = `seq` order within a sweep (see `PgQueue::complete`).
                super::queue::lock_results(&tx, &id)
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                let n = tx
                    .execute(
                        "INSERT INTO variant_results (sweep_id, variant_id, ok, line, worker_id)
                         VALUES ($1, $2, $3, $4, 'server') ON CONFLICT DO NOTHING",
                        &[&id, &(variant as i64), &ok, &line],
                    )
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                // A retried commit whose first attempt had committed adds nothing.
                let (d, f) = (n as i64, if ok { 0i64 } else { n as i64 });
                tx.execute(
                    "UPDATE sweeps SET done = done + $2, failed = failed + $3,
                            computed = computed + 1 WHERE id = $1",
                    &[&id, &d, &f],
                )
                .await
                .map_err(|e| q.db_error(CTX, e))?;
                tx.commit().await.map_err(|e| q.db_error(CTX, e))?;
                Ok(())
            }
        })
    }

    fn variant_lines(
        &self,
        id: &str,
        offset: u64,
        limit: u64,
    ) -> Result<Vec<(u64, String)>, StoreError> {
        let id = id.to_string();
        self.call(move |q| {
            let id = id.clone();
            async move {
                Ok(q.variants_page(&id, offset, limit)
                    .await?
                    .into_iter()
                    .map(|r| (r.id, r.line))
                    .collect())
            }
        })
    }

    fn put_plot(&self, id: &str, name: &str, svg: &str) -> Result<(), StoreError> {
        let (id, name, svg) = (id.to_string(), name.to_string(), svg.to_string());
        self.call(move |q| {
            let (id, name, svg) = (id.clone(), name.clone(), svg.clone());
            async move {
                const CTX: &str = "storing a figure";
                let c = q.connection(CTX).await?;
                c.execute(
                    "INSERT INTO plots (sweep_id, name, svg) VALUES ($1, $2, $3)
                     ON CONFLICT (sweep_id, name) DO UPDATE SET svg = EXCLUDED.svg",
                    &[&id, &name, &svg],
                )
                .await
                .map_err(|e| q.db_error(CTX, e))?;
                Ok(())
            }
        })
    }

    fn plot(&self, id: &str, name: &str) -> Result<Option<String>, StoreError> {
        let (id, name) = (id.to_string(), name.to_string());
        self.call(move |q| {
            let (id, name) = (id.clone(), name.clone());
            async move {
                const CTX: &str = "reading a figure";
                let c = q.connection(CTX).await?;
                let r = c
                    .query_opt(
                        "SELECT svg FROM plots WHERE sweep_id = $1 AND name = $2",
                        &[&id, &name],
                    )
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                Ok(r.map(|r| r.get(0)))
            }
        })
    }

    fn plot_names(&self, id: &str) -> Result<Vec<String>, StoreError> {
        let id = id.to_string();
        self.call(move |q| {
            let id = id.clone();
            async move {
                const CTX: &str = "listing figures";
                let c = q.connection(CTX).await?;
                let rows = c
                    .query(
                        "SELECT name FROM plots WHERE sweep_id = $1 ORDER BY name",
                        &[&id],
                    )
                    .await
                    .map_err(|e| q.db_error(CTX, e))?;
                Ok(rows.iter().map(|r| r.get(0)).collect())
            }
        })
    }

    fn runs_elsewhere(&self, row: &SweepRow) -> bool {
        // Everything but friction maps goes to the workers (the stored spec was parsed
        // at its submission: its kind is enough here).
        SweepKind::of(&row.spec) != Some(SweepKind::FrictionMap)
    }
}
