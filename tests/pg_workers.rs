//! `bearing-sweep worker` processes on a throwaway PostgreSQL cluster: three workers share
//! a 500-variant sweep and their result equals `run`'s; a worker killed with SIGKILL in
//! the middle of a batch loses its lease and the batch runs elsewhere, no variant missing
//! or doubled; PostgreSQL restarted in the middle of a sweep: the workers reconnect and
//! finish. Skipped with a notice without PostgreSQL (unless
//! BEARING_SWEEP_REQUIRE_POSTGRES=1).

mod cli_support;
mod pg_support;

use std::collections::BTreeMap;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use bearing_sweep::service::pg::{
    parse_queued, result_document, submit_spec, PgQueue, SweepOptions,
};
use bearing_sweep::sweep::merge::deterministic_part;
use bearing_sweep::sweep::SweepSpec;
use cli_support::{bin, read, scratch, write};
use pg_support::PgCluster;
use serde_json::{json, Value};

/// A synthetic sweep of `a * b` variants, each sleeping `cost_ms` (to be caught mid-batch).
fn spec(a: usize, b: usize, cost_ms: u64) -> Value {
    json!({"kind": "synthetic", "name": "workers test",
           "base": {"spin": 100.0, "duration": 0.2, "samples": 201, "cost_ms": cost_ms,
                    "bearings": [{"whirl": 1e-6, "whirl_ratio": 0.45}]},
           "axes": [{"path": "bearings[*].whirl_ratio", "linspace": [0.35, 0.55, a]},
                    {"path": "spin", "linspace": [80.0, 120.0, b]}],
           "reductions": {"window": {"revolutions": 2}}})
}

/// `run`'s result of `spec` (the reference).
fn run_reference(tag: &str, spec: &Value) -> Value {
    let dir = scratch("pg-workers", tag);
    let file = write(&dir, "spec.json", spec);
    let (ok, err) = cli_support::run(&[
        "run",
        file.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "run failed: {err}");
    read(&dir.join("out/spec/result.json"))
}

fn worker(url: &str, id: &str, batch: usize, ttl_s: f64, log: &std::path::Path) -> Child {
    bin()
        .args([
            "worker",
            "--database",
            url,
            "--backend",
            "cpu",
            "--batch",
            &batch.to_string(),
            "--lease-ttl",
            &ttl_s.to_string(),
            "--heartbeat",
            &(ttl_s / 4.0).to_string(),
            "--exit-when-idle",
            "2",
            "--id",
            id,
        ])
        .env("RAYON_NUM_THREADS", "1")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .expect("worker starts")
}

/// Waits for every worker to exit (they exit after 2 s without work); kills them and
/// fails after `limit`.
fn wait_all(children: &mut [(String, Child)], limit: Duration, logs: &std::path::Path) {
    let start = Instant::now();
    for (name, c) in children.iter_mut() {
        loop {
            match c.try_wait().unwrap() {
                Some(st) => {
                    assert!(
                        st.success(),
                        "worker {name} exited with {st}; log:\n{}",
                        std::fs::read_to_string(logs.join(format!("{name}.log")))
                            .unwrap_or_default()
                    );
                    break;
                }
                None if start.elapsed() > limit => {
                    let _ = c.kill();
                    panic!(
                        "worker {name} still running after {limit:?}; log:\n{}",
                        std::fs::read_to_string(logs.join(format!("{name}.log")))
                            .unwrap_or_default()
                    );
                }
                None => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }
}

/// How many times each variant is stored.
async fn stored(q: &PgQueue, id: &str) -> BTreeMap<u64, usize> {
    let mut m = BTreeMap::new();
    for r in q.variants(id, 0, u64::MAX).await.unwrap() {
        *m.entry(r.id).or_insert(0) += 1;
    }
    m
}

/// The stored result equals `run`'s (everything but the `run` section); every variant
/// stored exactly once.
async fn check_against_run(
    q: &PgQueue,
    id: &str,
    spec: &SweepSpec,
    reference: &Value,
    total: usize,
) {
    let m = stored(q, id).await;
    let missing: Vec<u64> = (0..total as u64).filter(|i| !m.contains_key(i)).collect();
    assert!(missing.is_empty(), "variants missing: {missing:?}");
    let doubled: Vec<_> = m.iter().filter(|(_, &k)| k != 1).collect();
    assert!(
        doubled.is_empty(),
        "variants stored more than once: {doubled:?}"
    );
    assert_eq!(
        m.len(),
        total,
        "variants stored: actual {}, expected {total}",
        m.len()
    );
    let doc = result_document(q, id, spec).await.unwrap();
    let (got, want) = (deterministic_part(&doc), deterministic_part(reference));
    if got != want {
        for key in want.as_object().unwrap().keys() {
            if got.get(key) != want.get(key) {
                if key == "variants" {
                    let (g, w) = (got[key].as_array().unwrap(), want[key].as_array().unwrap());
                    for (k, (a, b)) in g.iter().zip(w).enumerate() {
                        assert_eq!(
                            a, b,
                            "variant index {k}: workers' result (left) vs run's (right)"
                        );
                    }
                }
                panic!("`{key}` differs: workers {} vs run {}", got[key], want[key]);
            }
        }
        panic!("results differ");
    }
}

async fn wait_done(q: &PgQueue, id: &str, limit: Duration) {
    let start = Instant::now();
    loop {
        let s = q.sweep(id).await.unwrap().unwrap();
        if s.status == "done" {
            return;
        }
        assert!(
            start.elapsed() < limit,
            "sweep not done after {limit:?}: {s:?}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_workers_on_500_variants_give_runs_result() {
    let Some(pg) = PgCluster::start_or_skip("three workers") else {
        return;
    };
    let s = spec(25, 20, 4);
    let reference = run_reference("three", &s);
    let q = PgQueue::new(&pg.url(), 4).unwrap();
    q.migrate().await.unwrap();
    let parsed = parse_queued(&s).unwrap();
    let opts = SweepOptions {
        backend: bearing_sweep::backend::BackendKind::Cpu,
        ..SweepOptions::default()
    };
    let (id, total) = submit_spec(&q, &parsed, opts, 8).await.unwrap();
    assert_eq!(total, 500);
    let logs = scratch("pg-workers", "three-logs");
    let mut children: Vec<(String, Child)> = (0..3)
        .map(|k| {
            let name = format!("w{k}");
            let c = worker(
                &pg.url(),
                &name,
                16,
                10.0,
                &logs.join(format!("{name}.log")),
            );
            (name, c)
        })
        .collect();
    wait_all(&mut children, Duration::from_secs(120), &logs);
    let row = q.sweep(&id).await.unwrap().unwrap();
    assert_eq!(row.status, "done", "{row:?}");
    check_against_run(&q, &id, &parsed, &reference, 500).await;
    let stats = q.batch_stats(&id).await.unwrap();
    // 4 ms x 500 variants is 2 s of work in batches of 16: every worker gets some.
    assert_eq!(stats.workers, 3, "workers that stored results: {stats:?}");
    assert_eq!(
        stats.claims, stats.done,
        "no batch should have been claimed twice: {stats:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_killed_mid_batch_loses_its_lease_and_the_batch_runs_elsewhere() {
    let Some(pg) = PgCluster::start_or_skip("sigkill") else {
        return;
    };
    // 120 variants x 40 ms; batches of 10 (0.4 s each); leases of 2 s.
    let s = spec(12, 10, 40);
    let reference = run_reference("sigkill", &s);
    let q = PgQueue::new(&pg.url(), 4).unwrap();
    q.migrate().await.unwrap();
    let parsed = parse_queued(&s).unwrap();
    let (id, total) = submit_spec(&q, &parsed, SweepOptions::default(), 10)
        .await
        .unwrap();
    let logs = scratch("pg-workers", "sigkill-logs");
    let mut victim = worker(&pg.url(), "victim", 10, 2.0, &logs.join("victim.log"));
    // The victim alone first, until it has finished a batch and holds the next one.
    let (client, conn) = tokio_postgres::connect(&pg.url(), tokio_postgres::NoTls)
        .await
        .unwrap();
    tokio::spawn(conn);
    let held_batch = {
        let start = Instant::now();
        loop {
            let row = client
                .query_opt(
                    "SELECT b.batch_no FROM work_batches b JOIN leases l ON l.id = b.lease_id
                     WHERE b.state = 'leased' AND l.worker_id = 'victim'
                       AND EXISTS (SELECT 1 FROM work_batches d WHERE d.state = 'done')",
                    &[],
                )
                .await
                .unwrap();
            if let Some(r) = row {
                break r.get::<_, i32>(0);
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "the victim never held a batch"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    };
    // Mid-batch: 0.1 s into its 0.4 s.
    tokio::time::sleep(Duration::from_millis(100)).await;
    victim.kill().expect("SIGKILL");
    let _ = victim.wait();
    let killed_at = Instant::now();
    let mut children: Vec<(String, Child)> = ["w1", "w2"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                worker(&pg.url(), n, 10, 2.0, &logs.join(format!("{n}.log"))),
            )
        })
        .collect();
    wait_all(&mut children, Duration::from_secs(120), &logs);
    wait_done(&q, &id, Duration::from_secs(5)).await;
    check_against_run(&q, &id, &parsed, &reference, total as usize).await;
    // The batch the victim held was claimed again after its lease expired and stored by
    // another worker.
    let r = client
        .query_one(
            "SELECT b.attempts, l.worker_id, extract(epoch FROM (l.claimed_at - now()))::float8
             FROM work_batches b JOIN leases l ON l.id = b.lease_id
             WHERE b.sweep_id = $1 AND b.batch_no = $2",
            &[&id, &held_batch],
        )
        .await
        .unwrap();
    let (attempts, by): (i32, String) = (r.get(0), r.get(1));
    assert!(
        attempts >= 2,
        "batch {held_batch}: claimed {attempts} times, expected >= 2"
    );
    assert_ne!(
        by, "victim",
        "batch {held_batch} completed by the killed worker"
    );
    let reclaimed_after_s = -r.get::<_, f64>(2);
    let since_kill = killed_at.elapsed().as_secs_f64();
    // It was reclaimed no earlier than the lease allowed (2 s after the last heartbeat,
    // itself at most 0.5 s before the kill).
    assert!(
        since_kill - reclaimed_after_s >= 1.4,
        "batch {held_batch} reclaimed {:.2} s after the kill, before its 2 s lease could expire",
        since_kill - reclaimed_after_s
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workers_reconnect_after_postgres_restarts_mid_sweep() {
    let Some(pg) = PgCluster::start_or_skip("restart") else {
        return;
    };
    // 200 variants x 20 ms in batches of 10.
    let s = spec(20, 10, 20);
    let reference = run_reference("restart", &s);
    let q = PgQueue::new(&pg.url(), 4).unwrap();
    q.migrate().await.unwrap();
    let parsed = parse_queued(&s).unwrap();
    let (id, total) = submit_spec(&q, &parsed, SweepOptions::default(), 10)
        .await
        .unwrap();
    let logs = scratch("pg-workers", "restart-logs");
    let mut children: Vec<(String, Child)> = ["w1", "w2"]
        .iter()
        .map(|n| {
            (
                n.to_string(),
                worker(&pg.url(), n, 10, 10.0, &logs.join(format!("{n}.log"))),
            )
        })
        .collect();
    let start = Instant::now();
    loop {
        let done = q.sweep(&id).await.unwrap().unwrap().done;
        if done >= 40 {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no progress before the restart"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let before = q.sweep(&id).await.unwrap().unwrap();
    assert!(
        before.done < total,
        "finished before the restart; make the sweep longer"
    );
    pg.restart(Duration::from_secs(2));
    wait_all(&mut children, Duration::from_secs(120), &logs);
    // This process's pool reconnects as well.
    wait_done(&q, &id, Duration::from_secs(10)).await;
    check_against_run(&q, &id, &parsed, &reference, total as usize).await;
    let retried: usize = ["w1", "w2"]
        .iter()
        .map(|n| {
            std::fs::read_to_string(logs.join(format!("{n}.log")))
                .unwrap_or_default()
                .matches("retrying")
                .count()
        })
        .sum();
    assert!(
        retried > 0,
        "no worker logged a retry: was the server really down?"
    );
}

/// A worker runs each claimed sweep within its own `--max-memory`, not the 2 GiB default
/// (a queued sweep stores no budget): two short rotor variants run at the default budget
/// and are refused under a 1 KiB one (their samples cannot fit), the refusal naming the
/// budget.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_runs_sweeps_within_its_own_memory_budget() {
    let Some(pg) = PgCluster::start_or_skip("worker budget") else {
        return;
    };
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sweeps/clearance-viscosity.json"
    ))
    .unwrap();
    let mut s: Value = serde_json::from_str(&text).unwrap();
    s["axes"] = json!([{"path": "bearings[*].clearance", "values": [0.0003, 0.0004]}]);
    s["base"]["integrator"]["t_end"] = json!(0.002);
    s["base"]["integrator"]["sample_interval"] = json!(0.0005);
    s["plots"] = json!([]);
    let q = PgQueue::new(&pg.url(), 4).unwrap();
    q.migrate().await.unwrap();
    let parsed = parse_queued(&s).unwrap();
    let opts = SweepOptions {
        backend: bearing_sweep::backend::BackendKind::Cpu,
        ..SweepOptions::default()
    };
    let logs = scratch("pg-workers", "budget-logs");
    for (name, budget) in [("tiny", Some("1K")), ("default", None)] {
        let (id, total) = submit_spec(&q, &parsed, opts, 8).await.unwrap();
        assert_eq!(total, 2);
        let mut cmd = bin();
        cmd.args([
            "worker",
            "--database",
            &pg.url(),
            "--backend",
            "cpu",
            "--exit-when-idle",
            "2",
            "--id",
            name,
        ]);
        if let Some(b) = budget {
            cmd.args(["--max-memory", b]);
        }
        let child = cmd
            .env("RAYON_NUM_THREADS", "1")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(logs.join(format!("{name}.log"))).unwrap())
            .spawn()
            .expect("worker starts");
        let mut children = vec![(name.to_string(), child)];
        wait_all(&mut children, Duration::from_secs(120), &logs);
        let row = q.sweep(&id).await.unwrap().unwrap();
        let lines: Vec<(bool, String)> = q
            .variants(&id, 0, u64::MAX)
            .await
            .unwrap()
            .into_iter()
            .map(|r| (r.ok, r.line))
            .collect();
        if budget.is_some() {
            let refused_sweep =
                row.status == "failed" && format!("{row:?}").contains("memory budget");
            let refused_variants = lines.len() == 2
                && lines
                    .iter()
                    .all(|(ok, l)| !ok && l.contains("memory budget"));
            assert!(
                refused_sweep || refused_variants,
                "a 1 KiB worker budget must refuse the sweep, naming the budget: {row:?} {lines:?}"
            );
        } else {
            assert_eq!(row.status, "done", "{row:?}");
            assert!(
                lines.len() == 2 && lines.iter().all(|(ok, _)| *ok),
                "the default budget runs both variants: {lines:?}"
            );
        }
    }
}
