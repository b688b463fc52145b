//! `bench queue`: figures of the PostgreSQL queue (BENCHMARKS.md "Workers and
//! PostgreSQL"): variants/s of a rotor sweep with 1, 2, 4 worker processes against `run`
//! (and whether their result equals `run`'s), the claim-and-commit overhead of one batch,
//! and a claim storm (many workers claiming and completing one-variant batches that need
//! no computing) giving the claims per second the queue sustains.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::service::pg::{
    new_sweep_id, parse_queued, result_document, submit_spec, PgError, PgQueue, QueuedSweep,
    SweepOptions, VariantRow,
};
use crate::sweep::merge::deterministic_part;

/// Options of `bench queue`.
#[derive(Clone, Debug)]
pub struct QueueBenchOptions {
    /// The database (a scratch one: the bench adds and deletes sweeps).
    pub database: String,
    /// The `bearing-sweep` binary the worker processes run.
    pub exe: PathBuf,
    /// Worker process counts for the variants/s rows.
    pub workers: Vec<usize>,
    /// Variants per claim of those workers.
    pub batch: usize,
    /// Grid points per axis of the rotor sweep (clearance x viscosity; n² variants).
    pub grid: usize,
    /// Batches claimed and committed one after another for the overhead row.
    pub overhead_batches: usize,
    /// Concurrent claimers in the storm.
    pub storm_workers: usize,
    /// Length of the storm, s.
    pub storm_s: f64,
    /// Scratch folder (the `run` reference).
    pub scratch: PathBuf,
}

/// The paper rotor over clearance x viscosity (sweeps/clearance-viscosity.json) on an
/// `n` x `n` grid.
fn rotor_spec(n: usize) -> Value {
    json!({
        "kind": "rotor",
        "name": "queue bench: paper rotor, clearance x viscosity",
        "base": {
            "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
            "bearings": [
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}
            ],
            "gravity": [0.0, 0.0, 0.0],
            "spin": "free",
            "initial": {"spin": 100.0},
            "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.5, "sample_interval": 5e-4},
            "film": {"threshold": 1e-6}
        },
        "axes": [
            {"path": "bearings[*].clearance", "logspace": [0.0001, 0.0006, n]},
            {"path": "bearings[*].viscosity", "logspace": [0.005, 0.1, n]}
        ],
        "reductions": {"window": {"revolutions": 3}, "keep": ["orbit"], "points": 100}
    })
}

fn bench_error(reason: String) -> PgError {
    PgError::Sweep {
        id: "bench".into(),
        reason,
    }
}

/// `run`'s result of `spec` and its variants/s.
fn run_reference(exe: &Path, dir: &Path, spec: &Value) -> Result<(Value, f64), PgError> {
    std::fs::create_dir_all(dir).map_err(|e| bench_error(format!("{}: {e}", dir.display())))?;
    let file = dir.join("queue-bench.json");
    std::fs::write(&file, spec.to_string())
        .map_err(|e| bench_error(format!("{}: {e}", file.display())))?;
    let out = dir.join("out");
    // A fresh run (an earlier result of another grid would be refused, not resumed).
    let _ = std::fs::remove_dir_all(&out);
    let st = Command::new(exe)
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .args(["--quiet", "--batch-size", "32"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map_err(|e| bench_error(format!("{}: {e}", exe.display())))?;
    if !st.success() {
        return Err(bench_error(format!("run of the reference exited {st}")));
    }
    let path = out.join("queue-bench/result.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| bench_error(format!("{}: {e}", path.display())))?;
    let doc: Value =
        serde_json::from_str(&text).map_err(|e| bench_error(format!("result.json: {e}")))?;
    let rate = doc["run"]["variants_per_s"].as_f64().unwrap_or(0.0);
    Ok((doc, rate))
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let k = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[k.min(sorted.len() - 1)]
}

/// Runs the queue benchmark; returns a Markdown report.
pub fn bench_queue(o: &QueueBenchOptions) -> Result<String, PgError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| bench_error(format!("tokio runtime: {e}")))?;
    rt.block_on(bench_async(o))
}

async fn bench_async(o: &QueueBenchOptions) -> Result<String, PgError> {
    let q = PgQueue::new(&o.database, o.storm_workers.max(4) + 2)?;
    q.migrate().await?;
    let mut md = String::new();
    md.push_str(&format!(
        "Queue at {} (`bench queue`), {} cores.\n\n",
        q.target(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    ));

    // 1. Worker processes on a rotor sweep, against `run`.
    let spec = rotor_spec(o.grid);
    let (reference, run_rate) = run_reference(&o.exe, &o.scratch, &spec)?;
    // Parsed once for every submission and result below.
    let parsed = parse_queued(&spec)?;
    md.push_str(&format!(
        "| worker processes | variants | batch | wall (s) | variants/s | vs `run` ({run_rate:.1} variants/s) | result vs `run` |\n| --- | --- | --- | --- | --- | --- | --- |\n"
    ));
    for &n in &o.workers {
        let opts = SweepOptions {
            backend: crate::backend::BackendKind::Cpu,
            ..SweepOptions::default()
        };
        let batch_rows = i32::try_from(o.batch.clamp(1, 32)).unwrap_or(32);
        let (id, total) = submit_spec(&q, &parsed, opts, batch_rows).await?;
        let mut children = Vec::new();
        for k in 0..n {
            let child = Command::new(&o.exe)
                .args(["worker", "--database", &o.database, "--backend", "cpu"])
                .args(["--batch", &o.batch.to_string(), "--exit-when-idle", "1"])
                .args(["--id", &format!("bench-{n}-{k}")])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .map_err(|e| bench_error(format!("{}: {e}", o.exe.display())))?;
            children.push(child);
        }
        for mut c in children {
            let _ = tokio::task::spawn_blocking(move || c.wait()).await;
        }
        let row = q
            .sweep(&id)
            .await?
            .ok_or_else(|| PgError::NotFound(id.clone()))?;
        if row.status != "done" {
            return Err(bench_error(format!(
                "{n} workers left the sweep {}",
                row.status
            )));
        }
        let wall = row.finished_unix_s.unwrap_or(0.0) - row.started_unix_s.unwrap_or(0.0);
        let doc = result_document(&q, &id, &parsed).await?;
        let same = deterministic_part(&doc) == deterministic_part(&reference);
        md.push_str(&format!(
            "| {n} | {total} | {} | {wall:.2} | {:.1} | {:.2}x | {} |\n",
            o.batch,
            total as f64 / wall,
            total as f64 / wall / run_rate,
            if same { "identical" } else { "DIFFERS" }
        ));
        q.delete(&id).await?;
    }

    // 2. Claim-and-commit overhead of one batch (32 variants of ~1 KB lines each).
    let per = 32u64;
    let line = format!("{{\"pad\":\"{}\"}}", "x".repeat(1000));
    let sweep = |total: u64, rows: i32| QueuedSweep {
        id: new_sweep_id(),
        name: "queue bench".into(),
        kind: "synthetic".into(),
        spec: json!({"kind": "synthetic", "base": {}, "axes": []}),
        options: SweepOptions {
            backend: crate::backend::BackendKind::Cpu,
            ..SweepOptions::default()
        },
        total,
        batch_variants: rows,
        posted: None,
        local: false,
        created_unix_s: None,
    };
    let s = sweep(per * o.overhead_batches as u64, per as i32);
    q.submit(&s).await?;
    let settings = json!({"simulator": "synthetic"});
    let (mut claims, mut commits) = (Vec::new(), Vec::new());
    let ttl = Duration::from_secs(60);
    loop {
        let t = Instant::now();
        let Some(lease) = q.claim("overhead", "cpu", per, ttl).await? else {
            break;
        };
        claims.push(t.elapsed().as_secs_f64() * 1e3);
        let rows: Vec<VariantRow> = lease
            .variant_ids()
            .into_iter()
            .map(|id| VariantRow {
                id,
                ok: true,
                line: line.clone(),
            })
            .collect();
        let t = Instant::now();
        q.complete(&lease, &settings, &rows).await?;
        commits.push(t.elapsed().as_secs_f64() * 1e3);
    }
    q.delete(&s.id).await?;
    let total_ms: Vec<f64> = {
        let mut v: Vec<f64> = claims.iter().zip(&commits).map(|(a, b)| a + b).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    claims.sort_by(f64::total_cmp);
    commits.sort_by(f64::total_cmp);
    md.push_str(&format!(
        "\nClaim and commit, one worker, {} batches of {per} variants (1 KB lines), ms per batch:\n\n| step | p50 | p99 | mean |\n| --- | --- | --- | --- |\n",
        total_ms.len()
    ));
    for (name, v) in [
        ("claim", &claims),
        ("commit (results + lease)", &commits),
        ("both", &total_ms),
    ] {
        md.push_str(&format!(
            "| {name} | {:.2} | {:.2} | {:.2} |\n",
            percentile(v, 0.5),
            percentile(v, 0.99),
            v.iter().sum::<f64>() / v.len().max(1) as f64
        ));
    }

    // 3. Claim storm: one-variant batches, tiny lines, no computing.
    // More one-variant batches than the storm can take (tens of thousands per second at most).
    let storm = sweep(200_000, 1);
    q.submit(&storm).await?;
    let count = Arc::new(AtomicU64::new(0));
    let deadline = Instant::now() + Duration::from_secs_f64(o.storm_s);
    let started = Instant::now();
    let tasks: Vec<_> = (0..o.storm_workers)
        .map(|k| {
            let (q, count, settings) = (q.clone(), count.clone(), settings.clone());
            tokio::spawn(async move {
                let me = format!("storm-{k}");
                while Instant::now() < deadline {
                    let Ok(Some(lease)) = q.claim(&me, "cpu", 1, ttl).await else {
                        continue;
                    };
                    let rows: Vec<VariantRow> = lease
                        .variant_ids()
                        .into_iter()
                        .map(|id| VariantRow {
                            id,
                            ok: true,
                            line: "{}".into(),
                        })
                        .collect();
                    match q.complete(&lease, &settings, &rows).await {
                        Ok(crate::service::pg::Completion::Committed { .. }) => {
                            count.fetch_add(1, Ordering::Relaxed);
                        }
                        other => eprintln!("storm: lease {} of {me}: {other:?}", lease.id),
                    }
                }
            })
        })
        .collect();
    for t in tasks {
        let _ = t.await;
    }
    let secs = started.elapsed().as_secs_f64();
    let n = count.load(Ordering::Relaxed);
    let stats = q.batch_stats(&storm.id).await?;
    q.delete(&storm.id).await?;
    md.push_str(&format!(
        "\nClaim storm: {} workers (one connection each) claiming and completing one-variant batches for {secs:.1} s: {n} claims completed ({} batches done in the table), **{:.0} claims/s**.\n",
        o.storm_workers,
        stats.done,
        n as f64 / secs,
    ));
    Ok(md)
}
