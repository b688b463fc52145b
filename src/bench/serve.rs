//! `bench serve`: a load generator for the service. Concurrent clients post eval requests
//! of a fixed number of states for a fixed time (states/s, p50/p99 latency), beside the
//! same number of states through one `eval` call; and one sweep over HTTP against the
//! same sweep through `run`'s code path. Blocking clients (ureq), one thread each.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Barrier};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::app::{eval_json, run_command, EvalOptions, SweepRunOptions};
use crate::service::{router, start, ServeError, ServiceConfig, SqliteStore, Store};

/// Options of `bench serve`.
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// A running service to load; `None` starts one in this process (CPU eval backend).
    pub server: Option<String>,
    /// Concurrent clients per row.
    pub clients: Vec<usize>,
    /// States per request per row.
    pub states: Vec<usize>,
    /// Time per row, s.
    pub duration_s: f64,
    /// Coalescing window of the in-process server, ms.
    pub window_ms: f64,
    /// A sweep spec to time over HTTP and through `run` (none: skipped).
    pub sweep: Option<PathBuf>,
    /// Timings of the sweep each way (alternating; the fastest of each counts).
    pub sweep_repeats: usize,
}

/// One row of the eval table.
#[derive(Clone, Debug)]
pub struct LoadRow {
    /// Concurrent clients.
    pub clients: usize,
    /// States per request.
    pub states: usize,
    /// Requests answered.
    pub requests: u64,
    /// States evaluated per second over HTTP.
    pub states_per_s: f64,
    /// Median request latency, ms.
    pub p50_ms: f64,
    /// 99th-percentile request latency, ms.
    pub p99_ms: f64,
    /// The same number of states through one `eval` call, states/s.
    pub single_call_states_per_s: f64,
    /// Failed requests (non-200).
    pub errors: u64,
}

/// A started in-process server: its URL (the runtime lives on a background thread).
pub fn spawn_background(config: ServiceConfig) -> Result<String, ServeError> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let runtime = match tokio::runtime::Builder::new_multi_thread()
            .enable_all()
            .build()
        {
            Ok(r) => r,
            Err(source) => {
                let _ = tx.send(Err(ServeError::Io {
                    what: "starting the runtime".into(),
                    source,
                }));
                return;
            }
        };
        runtime.block_on(async move {
            let setup = async {
                let store: Arc<dyn Store> = Arc::new(SqliteStore::open(&config.data)?);
                let bind = config.bind;
                let running = start(config, store)?;
                let listener = tokio::net::TcpListener::bind(bind)
                    .await
                    .map_err(|source| ServeError::Io {
                        what: format!("binding {bind}"),
                        source,
                    })?;
                let addr = listener.local_addr().map_err(|source| ServeError::Io {
                    what: "reading the bound address".into(),
                    source,
                })?;
                Ok::<_, ServeError>((listener, addr, running))
            };
            match setup.await {
                Ok((listener, addr, running)) => {
                    let _ = tx.send(Ok(format!("http://{addr}")));
                    let _ = axum::serve(listener, router(running.state)).await;
                }
                Err(e) => {
                    let _ = tx.send(Err(e));
                }
            }
        });
    });
    rx.recv()
        .unwrap_or_else(|_| Err(ServeError::Config("the server thread stopped".into())))
}

/// A bearing state, distinct per `k` (so no two requests share a state to deduplicate).
fn state(k: u64) -> Value {
    let f = (k % 10_000) as f64 / 10_000.0;
    json!({"xi": 1e-4 * (0.2 + f), "yi": -5e-5 * f, "xj": 1.2e-4, "yj": 2e-5 * (1.0 - f),
           "vxi": 1e-3 * f, "vyi": 0.0, "vxj": -2e-3, "vyj": 1e-3, "omega": 100.0 + f})
}

fn eval_doc(first: u64, n: usize) -> Value {
    json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
           "states": (0..n as u64).map(|k| state(first + k)).collect::<Vec<_>>()})
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// One row: `clients` threads post `states`-state requests for `duration`.
fn load_row(url: &str, clients: usize, states: usize, duration: Duration) -> LoadRow {
    let stop = Arc::new(AtomicBool::new(false));
    let barrier = Arc::new(Barrier::new(clients + 1));
    let handles: Vec<_> = (0..clients)
        .map(|c| {
            let (stop, barrier, url) = (stop.clone(), barrier.clone(), format!("{url}/api/eval"));
            std::thread::spawn(move || {
                let agent: ureq::Agent = ureq::Agent::config_builder()
                    .http_status_as_error(false)
                    .build()
                    .into();
                let mut lat = Vec::new();
                let mut errors = 0u64;
                let mut k = (c as u64) << 32;
                barrier.wait();
                while !stop.load(Ordering::Relaxed) {
                    let body = eval_doc(k, states).to_string();
                    k += states as u64;
                    let t = Instant::now();
                    let r = agent
                        .post(&url)
                        .content_type("application/json")
                        .send(body.as_bytes());
                    let ok = match r {
                        Ok(mut resp) => {
                            let status = resp.status().as_u16();
                            let _ = resp.body_mut().read_to_vec();
                            status == 200
                        }
                        Err(_) => false,
                    };
                    if ok {
                        lat.push(t.elapsed().as_secs_f64() * 1e3);
                    } else {
                        errors += 1;
                    }
                }
                (lat, errors)
            })
        })
        .collect();
    barrier.wait();
    let t = Instant::now();
    std::thread::sleep(duration);
    stop.store(true, Ordering::Relaxed);
    let mut lat = Vec::new();
    let mut errors = 0;
    for h in handles {
        if let Ok((l, e)) = h.join() {
            lat.extend(l);
            errors += e;
        }
    }
    let wall = t.elapsed().as_secs_f64();
    lat.sort_by(f64::total_cmp);
    let requests = lat.len() as u64;
    let served = requests * states as u64;
    // The same number of states through one `eval` call (at most 10^6).
    let n = served.clamp(1, 1_000_000) as usize;
    let doc = eval_doc(1 << 40, n).to_string();
    let t1 = Instant::now();
    let single =
        eval_json(&doc, EvalOptions::default()).map(|_| n as f64 / t1.elapsed().as_secs_f64());
    LoadRow {
        clients,
        states,
        requests,
        states_per_s: served as f64 / wall,
        p50_ms: percentile(&lat, 0.5),
        p99_ms: percentile(&lat, 0.99),
        single_call_states_per_s: single.unwrap_or(f64::NAN),
        errors,
    }
}

/// Runs the load generator; returns the Markdown report.
pub fn bench_serve(opts: &LoadOptions) -> Result<String, ServeError> {
    let scratch =
        std::env::temp_dir().join(format!("bearing-sweep-bench-serve-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let url = match &opts.server {
        Some(u) => u.trim_end_matches('/').to_string(),
        None => spawn_background(ServiceConfig {
            bind: std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
            data: scratch.join("data"),
            eval_window: Duration::from_secs_f64(opts.window_ms.clamp(0.0, 1e3) / 1e3),
            ..ServiceConfig::default()
        })?,
    };
    let mut md = format!(
        "Eval over HTTP ({url}), {} s per row; single call = the same number of states through one `eval` call (CPU backend, accuracy 1e-6).\n\n| clients | states/request | requests | states/s (HTTP) | p50 (ms) | p99 (ms) | states/s (one eval call) | errors |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
        opts.duration_s
    );
    for &states in opts.states.iter().filter(|&&n| n > 0) {
        for &clients in &opts.clients {
            let r = load_row(
                &url,
                clients.max(1),
                states.max(1),
                Duration::from_secs_f64(opts.duration_s.max(0.1)),
            );
            md.push_str(&format!(
                "| {} | {} | {} | {:.0} | {:.2} | {:.2} | {:.0} | {} |\n",
                r.clients,
                r.states,
                r.requests,
                r.states_per_s,
                r.p50_ms,
                r.p99_ms,
                r.single_call_states_per_s,
                r.errors
            ));
        }
    }
    if let Some(spec) = &opts.sweep {
        md.push_str(&sweep_row(&url, spec, &scratch, opts.sweep_repeats.max(1))?);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    Ok(md)
}

/// One sweep over HTTP (submit to done) against `run`'s code path in this process,
/// `repeats` times each, alternating; the fastest of each counts.
fn sweep_row(
    url: &str,
    spec: &std::path::Path,
    scratch: &std::path::Path,
    repeats: usize,
) -> Result<String, ServeError> {
    let io = |what: &str, e: String| ServeError::Config(format!("{what}: {e}"));
    let text = std::fs::read_to_string(spec)
        .map_err(|e| io(&spec.display().to_string(), e.to_string()))?;
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into();
    let (mut run_s, mut http_s) = (f64::INFINITY, f64::INFINITY);
    for rep in 0..repeats {
        let t = Instant::now();
        run_command(
            &spec.display().to_string(),
            &text,
            &SweepRunOptions {
                out: scratch.join(format!("run-{rep}")),
                quiet: true,
                runner: Default::default(),
                // The default accuracy (1e-6) and budget (2 GiB), on the CPU.
                sweep: crate::sweep::SweepOptions {
                    backend: crate::backend::BackendKind::Cpu,
                    ..Default::default()
                },
            },
            &mut |_| {},
        )
        .map_err(|e| io("run", e.to_string()))?;
        run_s = run_s.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let mut resp = agent
            .post(format!("{url}/api/sweeps"))
            .content_type("application/json")
            .send(text.as_bytes())
            .map_err(|e| io("submit", e.to_string()))?;
        let created: Value =
            serde_json::from_str(&resp.body_mut().read_to_string().unwrap_or_default())
                .unwrap_or(Value::Null);
        let id = created["id"].as_str().unwrap_or_default().to_string();
        loop {
            let mut r = agent
                .get(format!("{url}/api/sweeps/{id}"))
                .call()
                .map_err(|e| io("status", e.to_string()))?;
            let v: Value = serde_json::from_str(&r.body_mut().read_to_string().unwrap_or_default())
                .unwrap_or(Value::Null);
            match v["status"].as_str() {
                Some("done") => break,
                Some("failed" | "cancelled") | None => {
                    return Err(io("sweep over HTTP", v.to_string()))
                }
                _ => std::thread::sleep(Duration::from_millis(20)),
            }
        }
        http_s = http_s.min(t.elapsed().as_secs_f64());
    }
    Ok(format!(
        "\nSweep `{}` (fastest of {repeats}, alternating): `run` {run_s:.2} s, over HTTP (submit to done, polled every 20 ms) {http_s:.2} s, ratio {:.3}.\n",
        spec.display(),
        http_s / run_s
    ))
}
