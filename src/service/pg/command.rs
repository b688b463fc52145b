//! `bearing-sweep worker`: pulls work batches from a PostgreSQL queue until stopped
//! (SIGTERM or Ctrl-C: the batch in hand is finished and committed first).

use std::sync::Arc;
use std::time::Duration;

use super::{run_worker, PgQueue, WorkerOptions};
use crate::app::AppError;
use crate::backend::BackendKind;

/// Options of `worker`.
#[derive(Clone, Debug)]
pub struct WorkerCommandOptions {
    /// `postgres://user[:password]@host:port/database`.
    pub database: String,
    /// Film-load backend: cpu, gpu or auto.
    pub backend: BackendKind,
    /// Variants per claimed batch (default 256 on the CPU, 4096 on a GPU).
    pub batch: Option<usize>,
    /// Lease time to live, s (default 30).
    pub lease_ttl_s: f64,
    /// Heartbeat period, s (default a third of the lease).
    pub heartbeat_s: Option<f64>,
    /// Exit after this many seconds without work (default: run until stopped).
    pub exit_when_idle_s: Option<f64>,
    /// Worker id (default host/pid/nonce).
    pub id: Option<String>,
    /// Memory budget each claimed sweep runs within (`--max-memory`; default 2 GiB).
    pub max_memory: crate::budget::MemoryBudget,
}

fn seconds(field: &str, v: f64) -> Result<Duration, AppError> {
    if v.is_finite() && v > 0.0 && v < 1e9 {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(AppError::input(
            field,
            format!("{v} is not a positive number of seconds"),
        ))
    }
}

/// Runs a worker; returns the summary lines.
pub fn worker_command(o: &WorkerCommandOptions) -> Result<Vec<String>, AppError> {
    let lease_ttl = seconds("--lease-ttl", o.lease_ttl_s)?;
    let heartbeat = match o.heartbeat_s {
        Some(h) => seconds("--heartbeat", h)?,
        None => lease_ttl / 3,
    };
    if heartbeat >= lease_ttl {
        return Err(AppError::input(
            "--heartbeat",
            format!(
                "{} s is not shorter than the lease ({} s): the lease would expire between heartbeats",
                heartbeat.as_secs_f64(),
                lease_ttl.as_secs_f64()
            ),
        ));
    }
    if o.batch == Some(0) {
        return Err(AppError::input("--batch", "must be at least 1"));
    }
    let exit_when_idle = o
        .exit_when_idle_s
        .map(|s| seconds("--exit-when-idle", s))
        .transpose()?;
    let queue =
        PgQueue::new(&o.database, 4).map_err(|e| AppError::input("--database", e.to_string()))?;
    let opts = WorkerOptions {
        backend: o.backend,
        batch: o.batch,
        lease_ttl,
        heartbeat,
        exit_when_idle,
        id: o.id.clone(),
        max_memory: o.max_memory,
        ..WorkerOptions::default()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| AppError::Io {
            path: "tokio runtime".into(),
            source: e,
        })?;
    let summary = rt.block_on(async move {
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        tokio::spawn(async move {
            stop_signal().await;
            eprintln!("worker: stopping after the batch in hand");
            let _ = stop_tx.send(true);
        });
        let log: Arc<dyn Fn(String) + Send + Sync> = Arc::new(|m| eprintln!("worker: {m}"));
        eprintln!("worker: pulling work from {}", queue.target());
        run_worker(queue, opts, stop_rx, log).await
    });
    let s = summary.map_err(|e| AppError::input("--database", e.to_string()))?;
    Ok(vec![format!(
        "worker {} ({}): {} batches, {} variants stored; {} leases lost to other workers, {} dropped for stopped sweeps; {} database retries",
        s.id, s.backend, s.batches, s.variants, s.lost, s.stopped, s.retries
    )])
}

/// SIGTERM or Ctrl-C.
async fn stop_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        if let Ok(mut term) = signal(SignalKind::terminate()) {
            tokio::select! {
                _ = term.recv() => {}
                _ = tokio::signal::ctrl_c() => {}
            }
            return;
        }
    }
    let _ = tokio::signal::ctrl_c().await;
}
