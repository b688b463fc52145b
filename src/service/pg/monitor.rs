//! The server's side of worker-run sweeps: follows the variants the workers commit (in
//! commit order) and turns them into the same live events the scheduler sends for a
//! sweep it runs itself (one per variant, then the status), passes cancel requests on to
//! the queue (the workers see them at their next heartbeat), and when a sweep is done
//! draws its figures and stores its `run` section, as the scheduler does.

use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use serde_json::{json, Value};
use tokio::sync::watch;

use super::error::PgError;
use super::queue::PgQueue;
use crate::service::{Scheduler, SweepEvent, SweepStatus};
use crate::sweep::job::Figures;
use crate::sweep::progress::ProgressSnapshot;
use crate::sweep::spec::parse_spec;

/// Time between looks at the database (events reach readers within about this).
const POLL: Duration = Duration::from_millis(200);
/// Most variant events read per sweep and look.
const EVENTS_PER_POLL: i64 = 10_000;
/// Variants read per query when drawing figures.
const PAGE: u64 = 1000;

/// What the monitor knows of one open sweep.
struct Watched {
    /// Commit order of the last variant turned into an event.
    last_seq: i64,
    /// Variants and not-ok variants counted so far.
    done: u64,
    failed: u64,
    /// Last status sent (`None`: none yet).
    status: Option<String>,
}

/// The `run` section of a worker-run sweep's result: the store, workers, leases, backend
/// and rates (what `run` records about its one process).
pub async fn run_section(queue: &PgQueue, id: &str) -> Result<Value, PgError> {
    let row = queue
        .sweep(id)
        .await?
        .ok_or_else(|| PgError::NotFound(id.to_string()))?;
    let stats = queue.batch_stats(id).await?;
    let wall = match (row.started_unix_s, row.finished_unix_s) {
        (Some(a), Some(b)) => b - a,
        _ => 0.0,
    };
    Ok(json!({
        "store": "postgres",
        "workers": stats.workers,
        "leases": stats.leases,
        "batch_claims": stats.claims,
        "work_batches": stats.done,
        "backend": row.backend_resolved,
        "wall_s": wall,
        "simulation_wall_s": wall,
        "variants_per_s": if wall > 0.0 { row.done as f64 / wall } else { 0.0 },
    }))
}

/// Draws the spec's figures from the stored variants and stores them with the `run`
/// section (once, when the sweep is done).
async fn finish(queue: &PgQueue, id: &str) -> Result<(), PgError> {
    let job = queue.job(id).await?;
    if let Ok(spec) = parse_spec(&job.spec, None) {
        let mut figures = Figures::new(&spec);
        if figures.wanted() {
            let mut next = 0;
            loop {
                let page = queue.variants(id, next, PAGE).await?;
                let Some(last) = page.last().map(|r| r.id) else {
                    break;
                };
                for r in page {
                    figures.add_line(&r.line);
                }
                next = last + 1;
            }
            let c = queue.connection("storing figures").await?;
            for (name, svg) in figures.draw() {
                if let Ok(svg) = svg {
                    c.execute(
                        "INSERT INTO plots (sweep_id, name, svg) VALUES ($1, $2, $3)
                         ON CONFLICT (sweep_id, name) DO UPDATE SET svg = EXCLUDED.svg",
                        &[&id, &name, &svg],
                    )
                    .await
                    .map_err(|e| queue.db_error("storing figures", e))?;
                }
            }
        }
    }
    let run = run_section(queue, id).await?.to_string();
    let c = queue.connection("storing the run section").await?;
    c.execute(
        "UPDATE sweeps SET run = $2 WHERE id = $1 AND run IS NULL",
        &[&id, &run],
    )
    .await
    .map_err(|e| queue.db_error("storing the run section", e))?;
    Ok(())
}

/// One look at the database: events, cancels, finished sweeps.
async fn look(
    queue: &PgQueue,
    scheduler: &Scheduler,
    watched: &mut HashMap<String, Watched>,
    uptime_s: f64,
) -> Result<(), PgError> {
    const CTX: &str = "following worker-run sweeps";
    let ids: Vec<String> = watched.keys().cloned().collect();
    let rows = {
        let c = queue.connection(CTX).await?;
        c.query(
            "SELECT id, status, total, run IS NULL,
                    extract(epoch FROM (now() - started_at))::float8,
                    (SELECT COALESCE(max(v.seq), 0) FROM variant_results v WHERE v.sweep_id = s.id)
             FROM sweeps s
             WHERE NOT local AND (status IN ('queued', 'running')
                                  OR (status = 'done' AND run IS NULL) OR id = ANY($1))",
            &[&ids],
        )
        .await
        .map_err(|e| queue.db_error(CTX, e))?
    };
    let present: std::collections::HashSet<String> = rows.iter().map(|r| r.get(0)).collect();
    // Deleted sweeps.
    watched.retain(|id, _| present.contains(id));
    for r in rows {
        let id: String = r.get(0);
        let mut status: String = r.get(1);
        let total = r.get::<_, i64>(2) as u64;
        let no_run: bool = r.get(3);
        let running_s: Option<f64> = r.get(4);
        let max_seq: i64 = r.get(5);
        if status == "running" && queue.finalize(&id).await? {
            // Its last worker stopped between its commit and this step.
            status = "done".into();
        }
        let job = scheduler.job(&id);
        let w = watched.entry(id.clone()).or_insert_with(|| Watched {
            // A sweep seen while queued, or started since this server started (workers
            // may claim it between two looks), is followed from its first variant; one
            // that was running before the server started, from now on.
            last_seq: if status == "queued" || running_s.is_some_and(|s| s <= uptime_s) {
                0
            } else {
                max_seq
            },
            done: 0,
            failed: 0,
            status: None,
        });
        // A cancel request of the routes (the scheduler's flag; not a drain).
        if job.cancel.load(Ordering::Relaxed)
            && !job.draining.load(Ordering::Relaxed)
            && (status == "queued" || status == "running")
            && queue.cancel(&id).await?
        {
            status = "cancelled".into();
        }
        if w.last_seq < max_seq {
            let c = queue.connection(CTX).await?;
            let new = c
                .query(
                    "SELECT variant_id, ok, seq FROM variant_results
                     WHERE sweep_id = $1 AND seq > $2 ORDER BY seq LIMIT $3",
                    &[&id, &w.last_seq, &EVENTS_PER_POLL],
                )
                .await
                .map_err(|e| queue.db_error(CTX, e))?;
            if w.done == 0 && w.last_seq > 0 {
                // Counting from the middle: start from the stored counts.
                let c2 = c
                    .query_one(
                        "SELECT count(*), count(*) FILTER (WHERE NOT ok) FROM variant_results
                         WHERE sweep_id = $1 AND seq <= $2",
                        &[&id, &w.last_seq],
                    )
                    .await
                    .map_err(|e| queue.db_error(CTX, e))?;
                w.done = c2.get::<_, i64>(0) as u64;
                w.failed = c2.get::<_, i64>(1) as u64;
            }
            for v in new {
                let ok: bool = v.get(1);
                w.done += 1;
                w.failed += u64::from(!ok);
                w.last_seq = v.get(2);
                let rate = running_s
                    .filter(|s| *s > 0.0)
                    .map_or(0.0, |s| w.done as f64 / s);
                let progress = ProgressSnapshot {
                    done: w.done,
                    failed: w.failed,
                    total,
                    variants_per_s: rate,
                    eta_s: (rate > 0.0).then(|| total.saturating_sub(w.done) as f64 / rate),
                };
                scheduler
                    .counters
                    .variants_done
                    .fetch_add(1, Ordering::Relaxed);
                if !ok {
                    scheduler
                        .counters
                        .variants_failed
                        .fetch_add(1, Ordering::Relaxed);
                }
                let _ = job.events.send(SweepEvent::Variant {
                    id: v.get::<_, i64>(0) as u64,
                    ok,
                    progress,
                });
            }
            if w.last_seq < max_seq {
                // More than one look's worth: the status waits for the next look.
                continue;
            }
        }
        if status == "done" && no_run {
            finish(queue, &id).await?;
        }
        if w.status.as_deref() != Some(status.as_str()) {
            if let Some(s) = SweepStatus::parse(&status) {
                let _ = job.events.send(SweepEvent::Status(s));
            }
            w.status = Some(status.clone());
        }
    }
    watched.retain(|_, w| {
        !matches!(
            w.status.as_deref(),
            Some("done") | Some("failed") | Some("cancelled")
        )
    });
    Ok(())
}

/// Follows the worker-run sweeps of `queue` for `scheduler`'s event streams until `stop`
/// turns true. Database errors are logged and retried at the next look.
pub async fn monitor(queue: PgQueue, scheduler: Arc<Scheduler>, mut stop: watch::Receiver<bool>) {
    let mut watched: HashMap<String, Watched> = HashMap::new();
    let mut failing = false;
    let started = std::time::Instant::now();
    while !*stop.borrow() {
        let uptime_s = started.elapsed().as_secs_f64();
        match look(&queue, &scheduler, &mut watched, uptime_s).await {
            Ok(()) => failing = false,
            Err(e) => {
                if !failing {
                    tracing::warn!("PostgreSQL monitor: {e}; retrying");
                }
                failing = true;
            }
        }
        tokio::select! {
            _ = tokio::time::sleep(POLL) => {}
            _ = stop.changed() => {}
        }
    }
}

/// Starts [`monitor`] on the current runtime with its own small pool to `url`.
pub fn spawn_monitor(
    url: &str,
    scheduler: Arc<Scheduler>,
    stop: watch::Receiver<bool>,
) -> Result<(), PgError> {
    let queue = PgQueue::new(url, 2)?;
    tokio::spawn(monitor(queue, scheduler, stop));
    Ok(())
}
