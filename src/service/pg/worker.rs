//! `bearing-sweep worker`: a process that pulls work batches from the PostgreSQL queue,
//! runs them through the same simulators and variant lines as `run`, heartbeats its lease
//! while it computes, and commits each batch's results with the lease's completion.
//!
//! The simulation runs on one compute thread (it owns the simulators, which are not
//! `Send`); the database work runs on tokio. Connection loss is retried with exponential
//! backoff (never a panic); a lease whose sweep was cancelled or that another worker took
//! over is dropped at the next heartbeat.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::Value;
use tokio::sync::{oneshot, watch};

use super::error::PgError;
use super::queue::{Completion, Lease, LeaseState, PgQueue, SweepJob, SweepOptions, VariantRow};
use crate::backend::{create_backend, BackendKind};
use crate::bearing::Accuracy;
use crate::sweep::expand::Expansion;
use crate::sweep::rotor_sim::{AUTO_BATCH_CPU, AUTO_BATCH_GPU};
use crate::sweep::runner::BatchSimulator;
use crate::sweep::simulator::prepare_simulator;
use crate::sweep::spec::{parse_spec, SweepSpec};

/// First retry delay after a transient database error.
const BACKOFF_START: Duration = Duration::from_millis(100);
/// Longest retry delay (the backoff doubles up to this).
const BACKOFF_MAX: Duration = Duration::from_secs(5);
/// Simulators kept ready (one per recent sweep).
const SIM_CACHE: usize = 4;

/// How a worker runs.
#[derive(Clone, Debug)]
pub struct WorkerOptions {
    /// Backend of the film loads: `cpu` or `gpu` (`auto`: the GPU if there is a usable
    /// adapter, as `run --backend auto`). The worker claims only sweeps that allow it.
    pub backend: BackendKind,
    /// Variants per claim (one lockstep batch); default 256 on the CPU, 4096 on a GPU.
    pub batch: Option<usize>,
    /// Lease time to live without a heartbeat, default 30 s.
    pub lease_ttl: Duration,
    /// Heartbeat period, default a third of the lease (cancel reaches the worker within
    /// one period).
    pub heartbeat: Duration,
    /// Wait between claims when the queue has no work for this worker, default 0.5 s.
    pub idle_poll: Duration,
    /// Exit after this long without work (`None`: run until stopped).
    pub exit_when_idle: Option<Duration>,
    /// Worker id in leases and results (default `host/pid/nonce`).
    pub id: Option<String>,
    /// Memory budget each claimed sweep is parsed and run within (`worker --max-memory`;
    /// default 2 GiB, as `run`): a queued sweep does not carry one, the worker that runs
    /// it brings its own.
    pub max_memory: crate::budget::MemoryBudget,
}

impl Default for WorkerOptions {
    fn default() -> Self {
        let ttl = Duration::from_secs(30);
        WorkerOptions {
            backend: BackendKind::Cpu,
            batch: None,
            lease_ttl: ttl,
            heartbeat: ttl / 3,
            idle_poll: Duration::from_millis(500),
            exit_when_idle: None,
            id: None,
            max_memory: crate::budget::MemoryBudget::default(),
        }
    }
}

/// What a worker did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct WorkerSummary {
    /// Worker id.
    pub id: String,
    /// `cpu` or `gpu`.
    pub backend: String,
    /// Leases completed (results stored).
    pub batches: u64,
    /// Variants stored.
    pub variants: u64,
    /// Leases dropped because another worker had taken them over.
    pub lost: u64,
    /// Leases dropped because their sweep stopped (cancelled, failed, deleted).
    pub stopped: u64,
    /// Transient database errors retried.
    pub retries: u64,
}

/// The default worker id: `host/pid/nonce`.
pub fn default_worker_id() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "host".into());
    let nonce = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    format!("{host}/{}/{nonce:08x}", std::process::id())
}

/// A sweep's simulator and the settings it computes with, built as `run` builds them
/// (`worker --backend` decides the film backend; the sweep's options the rest).
pub fn build_simulator(
    spec: &SweepSpec,
    options: &SweepOptions,
    backend: BackendKind,
) -> Result<(Box<dyn BatchSimulator>, Value), String> {
    let choice = SweepOptions {
        backend,
        ..*options
    };
    let prepared = prepare_simulator(spec, &choice, &mut |_| {}).map_err(|e| e.to_string())?;
    Ok((prepared.sim, prepared.settings))
}

/// Runs `ids` of a parsed sweep on `sim`: one lockstep batch, one line per variant
/// exactly as `run` streams it (a variant the simulator does not report becomes
/// `internal_error`). Once `cancel` is set the simulator stops early; the caller then
/// drops the rows.
pub fn run_variants(
    spec: &SweepSpec,
    exp: &Expansion,
    sim: &mut dyn BatchSimulator,
    ids: &[u64],
    cancel: &AtomicBool,
) -> Vec<VariantRow> {
    let mut rows = Vec::with_capacity(ids.len());
    crate::sweep::job::run_batch(spec, exp, sim, ids, cancel, &mut |v, outcome| {
        let (ok, line) = crate::sweep::job::finished_line(spec, v, outcome);
        rows.push(VariantRow { id: v.id, ok, line });
    });
    // In the order of `ids`, as the lease lists them.
    let order: HashMap<u64, usize> = ids.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    rows.sort_by_key(|r: &VariantRow| order.get(&r.id).copied().unwrap_or(usize::MAX));
    rows
}

/// A sweep made ready to run on the compute thread.
struct Prepared {
    spec: SweepSpec,
    exp: Expansion,
    sim: Box<dyn BatchSimulator>,
    settings: Value,
}

/// One batch for the compute thread.
struct ComputeRequest {
    job: Arc<SweepJob>,
    ids: Vec<u64>,
    /// Set when the lease is lost or its sweep stopped: the simulation stops early.
    cancel: Arc<AtomicBool>,
    reply: oneshot::Sender<Result<(Vec<VariantRow>, Value), String>>,
}

/// The compute thread: owns the simulators (most recent sweeps), answers each request.
fn compute_thread(
    backend: BackendKind,
    max_memory: crate::budget::MemoryBudget,
    rx: std::sync::mpsc::Receiver<ComputeRequest>,
) {
    let mut cache: HashMap<String, (u64, Prepared)> = HashMap::new();
    for (tick, req) in rx.into_iter().enumerate() {
        let tick = tick as u64 + 1;
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            if !cache.contains_key(&req.job.id) {
                let spec = parse_spec(&req.job.spec, None)
                    .map_err(|e| format!("the stored spec does not parse: {e}"))?;
                // The worker's budget, not the default the stored options deserialise to.
                let options = SweepOptions {
                    max_memory,
                    ..req.job.options
                };
                let (sim, settings) = build_simulator(&spec, &options, backend)?;
                if cache.len() >= SIM_CACHE {
                    if let Some(old) = cache
                        .iter()
                        .min_by_key(|(_, (t, _))| *t)
                        .map(|(k, _)| k.clone())
                    {
                        cache.remove(&old);
                    }
                }
                let exp = Expansion::new(&spec);
                cache.insert(
                    req.job.id.clone(),
                    (
                        tick,
                        Prepared {
                            spec,
                            exp,
                            sim,
                            settings,
                        },
                    ),
                );
            }
            let (t, p) = cache.get_mut(&req.job.id).expect("inserted above");
            *t = tick;
            let rows = run_variants(&p.spec, &p.exp, p.sim.as_mut(), &req.ids, &req.cancel);
            Ok((rows, p.settings.clone()))
        }));
        let result = result.unwrap_or_else(|panic| {
            // A simulator panicked: forget its state, report the sweep failed.
            cache.remove(&req.job.id);
            let msg = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(format!("the simulator panicked: {msg}"))
        });
        let _ = req.reply.send(result);
    }
}

/// The backend a worker runs on: `auto` becomes `gpu` when a usable adapter exists.
pub fn resolve_backend(kind: BackendKind) -> Result<(BackendKind, Option<String>), PgError> {
    match kind {
        BackendKind::Cpu => Ok((BackendKind::Cpu, None)),
        _ => {
            let accuracy = Accuracy::new(1e-6).expect("1e-6 is a valid accuracy");
            let (b, notice) = create_backend(kind, accuracy).map_err(|e| PgError::Sweep {
                id: "-".into(),
                reason: format!("--backend: {e}"),
            })?;
            let name = b.info().name;
            Ok((
                if name == "gpu" {
                    BackendKind::Gpu
                } else {
                    BackendKind::Cpu
                },
                notice,
            ))
        }
    }
}

/// Retries `f` on transient errors with exponential backoff until it succeeds, fails
/// permanently, or `stop` is set (then the last error).
async fn retry<T, F, Fut>(
    what: &str,
    stop: &watch::Receiver<bool>,
    log: &(dyn Fn(String) + Send + Sync),
    retries: &mut u64,
    mut f: F,
) -> Result<T, PgError>
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Result<T, PgError>>,
{
    let mut delay = BACKOFF_START;
    loop {
        match f().await {
            Ok(v) => return Ok(v),
            Err(e) if e.is_transient() && !*stop.borrow() => {
                *retries += 1;
                log(format!("{what}: {e}; retrying in {delay:?}"));
                tokio::time::sleep(delay).await;
                delay = (delay * 2).min(BACKOFF_MAX);
            }
            Err(e) => return Err(e),
        }
    }
}

/// Runs a worker on `queue` until `stop` turns true (finishing the batch in hand first)
/// or, with [`WorkerOptions::exit_when_idle`], until the queue stays empty that long.
/// Runs the migrations first. Only worker-wide failures (schema too new, no backend)
/// end it with an error; a sweep's own failure marks that sweep failed.
pub async fn run_worker(
    queue: PgQueue,
    opts: WorkerOptions,
    stop: watch::Receiver<bool>,
    log: Arc<dyn Fn(String) + Send + Sync>,
) -> Result<WorkerSummary, PgError> {
    let (backend, notice) = resolve_backend(opts.backend)?;
    let max_memory = opts.max_memory;
    if let Some(n) = notice {
        log(n);
    }
    let backend_name = if backend == BackendKind::Gpu {
        "gpu"
    } else {
        "cpu"
    };
    let batch = opts.batch.unwrap_or(if backend == BackendKind::Gpu {
        AUTO_BATCH_GPU
    } else {
        AUTO_BATCH_CPU
    });
    let mut summary = WorkerSummary {
        id: opts.id.clone().unwrap_or_else(default_worker_id),
        backend: backend_name.into(),
        ..Default::default()
    };
    let mut retries = 0u64;
    retry("migrating the schema", &stop, &*log, &mut retries, || {
        queue.migrate()
    })
    .await?;
    let (tx, rx) = std::sync::mpsc::channel::<ComputeRequest>();
    let compute = std::thread::Builder::new()
        .name("bearing-sweep-compute".into())
        .spawn(move || compute_thread(backend, max_memory, rx))
        .map_err(|e| PgError::Sweep {
            id: "-".into(),
            reason: format!("cannot start the compute thread: {e}"),
        })?;
    let mut jobs: HashMap<String, Arc<SweepJob>> = HashMap::new();
    let mut idle_since: Option<Instant> = None;
    let mut stop_rx = stop.clone();
    while !*stop.borrow() {
        let claimed = retry("claiming work", &stop, &*log, &mut retries, || {
            queue.claim(&summary.id, backend_name, batch as u64, opts.lease_ttl)
        })
        .await;
        let lease = match claimed {
            Ok(Some(l)) => l,
            Ok(None) => {
                let since = *idle_since.get_or_insert_with(Instant::now);
                if opts.exit_when_idle.is_some_and(|d| since.elapsed() >= d) {
                    break;
                }
                tokio::select! {
                    _ = tokio::time::sleep(opts.idle_poll) => {}
                    _ = stop_rx.changed() => {}
                }
                continue;
            }
            Err(e) if *stop.borrow() => {
                log(format!("stopping: {e}"));
                break;
            }
            Err(e) => {
                // A permanent error of the claim itself (not a connection problem): report
                // and keep serving after a pause rather than spinning.
                log(format!("claiming work: {e}"));
                tokio::time::sleep(BACKOFF_MAX).await;
                continue;
            }
        };
        idle_since = None;
        let job = match jobs.get(&lease.sweep_id) {
            Some(j) => j.clone(),
            None => match retry("reading a sweep", &stop, &*log, &mut retries, || {
                queue.job(&lease.sweep_id)
            })
            .await
            {
                Ok(j) => {
                    let j = Arc::new(j);
                    if jobs.len() >= SIM_CACHE * 4 {
                        jobs.clear();
                    }
                    jobs.insert(lease.sweep_id.clone(), j.clone());
                    j
                }
                Err(e) => {
                    log(format!("sweep {}: {e}", lease.sweep_id));
                    let _ = queue.fail_sweep(&lease.sweep_id, &e.to_string()).await;
                    continue;
                }
            },
        };
        process_lease(
            &queue,
            &opts,
            &lease,
            job,
            &tx,
            &stop,
            &*log,
            &mut summary,
            &mut retries,
        )
        .await;
    }
    drop(tx);
    let _ = tokio::task::spawn_blocking(move || compute.join()).await;
    summary.retries = retries;
    Ok(summary)
}

/// Runs one lease: compute with heartbeats, then complete (or drop it).
#[allow(clippy::too_many_arguments)]
async fn process_lease(
    queue: &PgQueue,
    opts: &WorkerOptions,
    lease: &Lease,
    job: Arc<SweepJob>,
    tx: &std::sync::mpsc::Sender<ComputeRequest>,
    stop: &watch::Receiver<bool>,
    log: &(dyn Fn(String) + Send + Sync),
    summary: &mut WorkerSummary,
    retries: &mut u64,
) {
    let (reply, mut answer) = oneshot::channel();
    let ids = lease.variant_ids();
    let cancel = Arc::new(AtomicBool::new(false));
    let request = ComputeRequest {
        job,
        ids,
        cancel: cancel.clone(),
        reply,
    };
    if tx.send(request).is_err() {
        log("the compute thread is gone; giving the lease back".into());
        let _ = queue.release(lease).await;
        return;
    }
    let mut why: Option<LeaseState> = None;
    let mut beat = tokio::time::interval(opts.heartbeat);
    beat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    beat.tick().await; // the first tick is immediate
    let computed = loop {
        tokio::select! {
            r = &mut answer => break r,
            _ = beat.tick() => {
                if why.is_some() {
                    continue;
                }
                match queue.heartbeat(lease, opts.lease_ttl).await {
                    Ok(LeaseState::Held) => {}
                    // Stop the simulation; whatever it returns is dropped.
                    Ok(state) => {
                        cancel.store(true, Ordering::Relaxed);
                        why = Some(state);
                    }
                    Err(e) => {
                        *retries += 1;
                        log(format!("heartbeat of lease {}: {e}", lease.id));
                    }
                }
            }
        }
    };
    if why.is_some() {
        // Whatever it still holds goes back to the queue now.
        let _ = queue.release(lease).await;
    }
    match why {
        Some(LeaseState::Lost) => {
            summary.lost += 1;
            log(format!(
                "lease {} was taken over by another worker; its results are dropped",
                lease.id
            ));
            return;
        }
        Some(LeaseState::Stopped(s)) => {
            summary.stopped += 1;
            log(format!(
                "sweep {} is {s}; lease {} dropped",
                lease.sweep_id, lease.id
            ));
            return;
        }
        _ => {}
    }
    let (rows, settings) = match computed {
        Ok(Ok(r)) => r,
        Ok(Err(msg)) => {
            log(format!("sweep {}: {msg}", lease.sweep_id));
            let _ = queue.fail_sweep(&lease.sweep_id, &msg).await;
            return;
        }
        Err(_) => {
            log("the compute thread ended; giving the lease back".into());
            let _ = queue.release(lease).await;
            return;
        }
    };
    let done = retry("completing a lease", stop, log, retries, || {
        queue.complete(lease, &settings, &rows)
    })
    .await;
    match done {
        Ok(Completion::Committed { .. }) | Ok(Completion::AlreadyCommitted) => {
            summary.batches += 1;
            summary.variants += rows.len() as u64;
        }
        Ok(Completion::LeaseLost) => {
            summary.lost += 1;
            log(format!(
                "lease {} was taken over before it completed; its results are dropped",
                lease.id
            ));
        }
        Ok(Completion::Stopped(s)) => {
            summary.stopped += 1;
            log(format!(
                "sweep {} is {s}; lease {} dropped",
                lease.sweep_id, lease.id
            ));
        }
        Err(e) => {
            log(format!("completing lease {}: {e}", lease.id));
            // Settings that differ from the sweep's, or a connection still down after
            // the retries were stopped: give the batches back for another worker.
            let _ = queue.release(lease).await;
        }
    }
}
