//! The PostgreSQL work queue against a throwaway cluster: migrations, claims, leases,
//! heartbeats, exactly-once completion under expired leases and racing workers, cancel.
//! Skipped with a notice without PostgreSQL (unless BEARING_SWEEP_REQUIRE_POSTGRES=1).

mod pg_support;

use std::collections::BTreeMap;
use std::time::Duration;

use bearing_sweep::service::pg::{
    parse_queued, result_document, submit_spec, Completion, Lease, LeaseState, PgError, PgQueue,
    SweepOptions, VariantRow, MIGRATIONS, RESULTS_LOCK_CLASS,
};
use bearing_sweep::sweep::SweepSpec;
use pg_support::PgCluster;
use serde_json::{json, Value};

/// A synthetic sweep of `n` variants (no dynamics: milliseconds), parsed once as the
/// queue's callers parse it.
fn spec(n: usize) -> SweepSpec {
    parse_queued(&json!({"kind": "synthetic", "name": "queue test",
           "base": {"spin": 100.0, "duration": 0.1, "samples": 101, "bearings": [{"whirl": 1e-6}]},
           "axes": [{"path": "spin", "linspace": [80.0, 120.0, n]}],
           "reductions": {"window": {"revolutions": 2}}}))
    .unwrap()
}

fn rows(lease: &Lease) -> Vec<VariantRow> {
    lease
        .variant_ids()
        .into_iter()
        .map(|id| VariantRow {
            id,
            ok: id % 7 != 3,
            line: format!("{{\"id\":{id}}}"),
        })
        .collect()
}

const LONG: Duration = Duration::from_secs(60);

fn settings() -> Value {
    json!({"simulator": "synthetic"})
}

async fn queue(pg: &PgCluster) -> PgQueue {
    let q = PgQueue::new(&pg.url(), 8).unwrap();
    q.migrate().await.unwrap();
    q
}

/// Every stored variant id of a sweep with how many times it is stored.
async fn stored(q: &PgQueue, id: &str) -> BTreeMap<u64, usize> {
    let mut m = BTreeMap::new();
    for r in q.variants(id, 0, u64::MAX).await.unwrap() {
        *m.entry(r.id).or_insert(0) += 1;
    }
    m
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn migrations_run_once_even_when_started_together() {
    let Some(pg) = PgCluster::start_or_skip("migrations") else {
        return;
    };
    let q = PgQueue::new(&pg.url(), 8).unwrap();
    let tasks: Vec<_> = (0..4)
        .map(|_| {
            let q = q.clone();
            tokio::spawn(async move { q.migrate().await })
        })
        .collect();
    let mut applied = Vec::new();
    for t in tasks {
        applied.extend(t.await.unwrap().unwrap());
    }
    let all: Vec<i32> = MIGRATIONS.iter().map(|m| m.version).collect();
    assert_eq!(
        applied, all,
        "four concurrent starts applied {applied:?}, expected each of {all:?} once"
    );
    assert_eq!(
        q.migrate().await.unwrap(),
        Vec::<i32>::new(),
        "a second start applies nothing"
    );

    // A schema from a newer program is refused, naming both versions.
    let (client, conn) = tokio_postgres::connect(&pg.url(), tokio_postgres::NoTls)
        .await
        .unwrap();
    tokio::spawn(conn);
    client
        .execute(
            "INSERT INTO schema_migrations (version, name) VALUES (99, 'future')",
            &[],
        )
        .await
        .unwrap();
    match q.migrate().await {
        Err(e @ PgError::SchemaTooNew { .. }) => {
            let msg = e.to_string();
            assert!(
                msg.contains("99") && msg.contains(&all.len().to_string()),
                "{msg}"
            );
        }
        other => panic!("expected SchemaTooNew, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn claims_cover_every_variant_once_in_backend_sized_batches() {
    let Some(pg) = PgCluster::start_or_skip("claims") else {
        return;
    };
    let q = queue(&pg).await;
    let (id, total) = submit_spec(&q, &spec(50), SweepOptions::default(), 4)
        .await
        .unwrap();
    assert_eq!(total, 50);
    // 50 variants in batches of 4: 13 rows, the last of 2.
    let s = q.batch_stats(&id).await.unwrap();
    assert_eq!((s.queued, s.leased, s.done), (13, 0, 0), "{s:?}");
    // A "GPU" worker asking for 16 takes 4 rows, a "CPU" one asking for 6 takes 1 (whole
    // rows, at least one).
    let big = q.claim("gpu-1", "cpu", 16, LONG).await.unwrap().unwrap();
    assert_eq!(big.variant_ids(), (0..16).collect::<Vec<_>>());
    let small = q.claim("cpu-1", "cpu", 6, LONG).await.unwrap().unwrap();
    assert_eq!(small.variant_ids(), (16..20).collect::<Vec<_>>());
    // A gpu worker may claim an `auto` sweep only if the first claim did not fix it to cpu.
    assert!(
        q.claim("gpu-2", "gpu", 16, LONG).await.unwrap().is_none(),
        "an auto sweep fixed to cpu was claimed by a gpu worker"
    );
    let mut done = false;
    for lease in [big, small] {
        let c = q
            .complete(&lease, &settings(), &rows(&lease))
            .await
            .unwrap();
        assert_eq!(c, Completion::Committed { sweep_done: false });
    }
    while let Some(lease) = q.claim("cpu-2", "cpu", 1000, LONG).await.unwrap() {
        let c = q
            .complete(&lease, &settings(), &rows(&lease))
            .await
            .unwrap();
        done = c == Completion::Committed { sweep_done: true };
    }
    assert!(done, "the last completion did not finish the sweep");
    let row = q.sweep(&id).await.unwrap().unwrap();
    assert_eq!(row.status, "done");
    assert_eq!(row.done, 50);
    let failed = (0..50u64).filter(|i| i % 7 == 3).count() as u64;
    assert_eq!(
        row.failed, failed,
        "not-ok count: actual {}, expected {failed}",
        row.failed
    );
    assert_eq!(row.settings, Some(settings()));
    let m = stored(&q, &id).await;
    assert_eq!(m.len(), 50);
    assert!(m.values().all(|&k| k == 1));
    // Pages by rank: offset 45, limit 10 -> ids 45..50.
    let page: Vec<u64> = q
        .variants_page(&id, 45, 10)
        .await
        .unwrap()
        .iter()
        .map(|r| r.id)
        .collect();
    assert_eq!(page, (45..50).collect::<Vec<_>>());
}

/// Claims racing on one sweep: every batch is claimed exactly once while all leases are
/// live. A batch leased by another worker between a claim's snapshot and its row lock used
/// to look free to the lease subquery of the old snapshot and was claimed twice (CI saw
/// 67 claims for 63 batches with three workers; this test saw 409-416 claims for 400).
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn racing_claimers_never_claim_a_live_batch_twice() {
    let Some(pg) = PgCluster::start_or_skip("racing claims") else {
        return;
    };
    let q = queue(&pg).await;
    // 400 one-variant batches, so that claims (not work) dominate.
    let n: u64 = 400;
    let (id, total) = submit_spec(&q, &spec(n as usize), SweepOptions::default(), 1)
        .await
        .unwrap();
    assert_eq!(total, n);
    const CLAIMERS: usize = 8;
    let tasks: Vec<_> = (0..CLAIMERS)
        .map(|k| {
            let url = pg.url();
            tokio::spawn(async move {
                let q = PgQueue::new(&url, 1).unwrap();
                let mut n = 0u64;
                // A pool of one connection, as a small worker might have: a completion
                // must not need a second one (it used to wait out the pool's 10 s).
                while let Some(lease) = q.claim(&format!("w{k}"), "cpu", 1, LONG).await.unwrap() {
                    q.complete(&lease, &settings(), &rows(&lease))
                        .await
                        .unwrap();
                    n += lease.variant_ids().len() as u64;
                }
                n
            })
        })
        .collect();
    let mut claimed = 0;
    for t in tasks {
        claimed += t.await.unwrap();
    }
    let s = q.batch_stats(&id).await.unwrap();
    assert_eq!(s.done, n, "{s:?}");
    assert_eq!(
        (s.claims, claimed),
        (n, n),
        "batch claims (attempts summed) and variants claimed, expected {n} each: {s:?}"
    );
    let m = stored(&q, &id).await;
    assert_eq!(m.len() as u64, n);
    assert!(m.values().all(|&k| k == 1));
}

/// Issue 21: the result document is assembled from the spec its caller parsed once (it
/// is not parsed again per call), checked to be the stored one: the sweep's own spec gives
/// the stored lines in id order, another spec is refused by name.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_result_document_takes_the_parsed_spec_and_checks_it() {
    let Some(pg) = PgCluster::start_or_skip("result document") else {
        return;
    };
    let q = queue(&pg).await;
    let (own, other) = (spec(6), spec(7));
    let (id, total) = submit_spec(&q, &own, SweepOptions::default(), 4)
        .await
        .unwrap();
    assert_eq!(total, 6);
    // Not done yet: refused, saying so.
    match result_document(&q, &id, &own).await {
        Err(PgError::Sweep { reason, .. }) => {
            assert!(reason.contains("only when the sweep is done"), "{reason}")
        }
        other => panic!("expected the not-done refusal, got {other:?}"),
    }
    while let Some(lease) = q.claim("A", "cpu", 4, LONG).await.unwrap() {
        q.complete(&lease, &settings(), &rows(&lease))
            .await
            .unwrap();
    }
    let doc = result_document(&q, &id, &own).await.unwrap();
    let ids: Vec<u64> = doc["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, (0..6).collect::<Vec<u64>>());
    assert_eq!(doc["settings"], settings());
    match result_document(&q, &id, &other).await {
        Err(PgError::Sweep { reason, .. }) => {
            assert!(reason.contains("not the one stored"), "{reason}")
        }
        other => panic!("expected the spec mismatch refusal, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_expired_lease_goes_back_and_its_late_results_are_dropped() {
    let Some(pg) = PgCluster::start_or_skip("expiry") else {
        return;
    };
    let q = queue(&pg).await;
    let (id, _) = submit_spec(&q, &spec(8), SweepOptions::default(), 8)
        .await
        .unwrap();
    // Worker A's lease lives 50 ms and is never renewed (A "died").
    let a = q
        .claim("A", "cpu", 8, Duration::from_millis(50))
        .await
        .unwrap()
        .unwrap();
    assert!(
        q.claim("B", "cpu", 8, LONG).await.unwrap().is_none(),
        "a live lease was claimed twice"
    );
    tokio::time::sleep(Duration::from_millis(120)).await;
    let b = q
        .claim("B", "cpu", 8, LONG)
        .await
        .unwrap()
        .expect("the expired batch is claimable");
    assert_eq!(b.variant_ids(), a.variant_ids());
    // A comes back: its heartbeat says lost, its completion stores nothing.
    assert_eq!(q.heartbeat(&a, LONG).await.unwrap(), LeaseState::Lost);
    assert_eq!(
        q.complete(&a, &settings(), &rows(&a)).await.unwrap(),
        Completion::LeaseLost
    );
    assert!(stored(&q, &id).await.is_empty());
    assert_eq!(q.heartbeat(&b, LONG).await.unwrap(), LeaseState::Held);
    assert_eq!(
        q.complete(&b, &settings(), &rows(&b)).await.unwrap(),
        Completion::Committed { sweep_done: true }
    );
    // A retried completion (the reply of the commit was lost) is recognised.
    assert_eq!(
        q.complete(&b, &settings(), &rows(&b)).await.unwrap(),
        Completion::AlreadyCommitted
    );
    let m = stored(&q, &id).await;
    assert_eq!(
        m.keys().copied().collect::<Vec<_>>(),
        (0..8).collect::<Vec<_>>()
    );
    assert!(m.values().all(|&k| k == 1));
    let s = q.batch_stats(&id).await.unwrap();
    assert_eq!((s.claims, s.leases, s.workers), (2, 2, 1), "{s:?}");
}

/// A late completion of an expired lease races a new claim of the same batch, many times:
/// whichever wins, every variant is stored exactly once and the loser stores nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_late_completion_racing_a_new_claim_stores_each_variant_once() {
    let Some(pg) = PgCluster::start_or_skip("race") else {
        return;
    };
    let q = queue(&pg).await;
    const ROUNDS: usize = 40;
    let (id, _) = submit_spec(&q, &spec(ROUNDS * 2), SweepOptions::default(), 2)
        .await
        .unwrap();
    let mut a_won = 0;
    for round in 0..ROUNDS {
        let a = q
            .claim("A", "cpu", 2, Duration::from_millis(1))
            .await
            .unwrap()
            .unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
        let (qa, qb, la) = (q.clone(), q.clone(), a.clone());
        let late = tokio::spawn(async move { qa.complete(&la, &settings(), &rows(&la)).await });
        let claim = tokio::spawn(async move { qb.claim("B", "cpu", 2, LONG).await });
        let late = late.await.unwrap().unwrap();
        let b = claim.await.unwrap().unwrap();
        match late {
            Completion::Committed { .. } => {
                a_won += 1;
                // B got nothing or a later batch, never A's.
                if let Some(b) = &b {
                    assert_ne!(
                        b.batches[0].0, a.batches[0].0,
                        "round {round}: a completed batch was claimed"
                    );
                    q.release(b).await.unwrap();
                }
            }
            Completion::LeaseLost => {
                let b = b
                    .unwrap_or_else(|| panic!("round {round}: A lost its lease but B got nothing"));
                assert_eq!(b.batches, a.batches, "round {round}");
                let c = q.complete(&b, &settings(), &rows(&b)).await.unwrap();
                assert!(
                    matches!(c, Completion::Committed { .. }),
                    "round {round}: {c:?}"
                );
            }
            other => panic!("round {round}: late completion {other:?}"),
        }
    }
    let m = stored(&q, &id).await;
    assert_eq!(
        m.len(),
        ROUNDS * 2,
        "variants stored: actual {}, expected {}",
        m.len(),
        ROUNDS * 2
    );
    assert!(m.values().all(|&k| k == 1), "a variant was stored twice");
    eprintln!("race: the late completion won {a_won} of {ROUNDS} rounds");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancel_stops_claims_heartbeats_and_completions() {
    let Some(pg) = PgCluster::start_or_skip("cancel") else {
        return;
    };
    let q = queue(&pg).await;
    let (id, _) = submit_spec(&q, &spec(20), SweepOptions::default(), 5)
        .await
        .unwrap();
    let first = q.claim("A", "cpu", 5, LONG).await.unwrap().unwrap();
    q.complete(&first, &settings(), &rows(&first))
        .await
        .unwrap();
    let second = q.claim("A", "cpu", 5, LONG).await.unwrap().unwrap();
    assert!(q.cancel(&id).await.unwrap());
    assert!(
        !q.cancel(&id).await.unwrap(),
        "a second cancel reports nothing to do"
    );
    assert_eq!(
        q.heartbeat(&second, LONG).await.unwrap(),
        LeaseState::Stopped("cancelled".into())
    );
    assert_eq!(
        q.complete(&second, &settings(), &rows(&second))
            .await
            .unwrap(),
        Completion::Stopped("cancelled".into())
    );
    assert!(q.claim("B", "cpu", 100, LONG).await.unwrap().is_none());
    // Finished variants stay readable.
    assert_eq!(stored(&q, &id).await.len(), 5);
    assert!(matches!(q.cancel("nope").await, Err(PgError::NotFound(_))));
    // Settings that differ from the sweep's are refused, nothing stored.
    let (id2, _) = submit_spec(&q, &spec(4), SweepOptions::default(), 2)
        .await
        .unwrap();
    let a = q.claim("A", "cpu", 2, LONG).await.unwrap().unwrap();
    q.complete(&a, &settings(), &rows(&a)).await.unwrap();
    let b = q.claim("B", "cpu", 2, LONG).await.unwrap().unwrap();
    let e = q
        .complete(&b, &json!({"simulator": "other"}), &rows(&b))
        .await;
    assert!(matches!(e, Err(PgError::Sweep { .. })), "{e:?}");
    assert_eq!(stored(&q, &id2).await.len(), 2);
    // Delete removes everything; a heartbeat of its lease reports it.
    assert!(q.delete(&id2).await.unwrap());
    assert_eq!(
        q.heartbeat(&b, LONG).await.unwrap(),
        LeaseState::Stopped("deleted".into())
    );
    assert!(q.sweep(&id2).await.unwrap().is_none());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_urls_and_unreachable_servers_are_errors_not_panics() {
    // No server needed.
    let e = PgQueue::new("postgres://u:s3cret@host:notaport/db", 2)
        .err()
        .expect("bad port refused");
    let msg = e.to_string();
    assert!(msg.starts_with("--database"), "{msg}");
    assert!(!msg.contains("s3cret"), "the password leaked: {msg}");
    // A closed port: a transient pool error (the worker retries with backoff).
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let q = PgQueue::new(&format!("postgres://u:s3cret@127.0.0.1:{port}/db"), 2).unwrap();
    let e = q.migrate().await.expect_err("nothing listens there");
    assert!(e.is_transient(), "{e}");
    assert!(
        !e.to_string().contains("s3cret"),
        "the password leaked: {e}"
    );
    assert!(
        e.to_string().contains(&format!("127.0.0.1:{port}/db")),
        "{e}"
    );
}

/// Issue 22 item 4, deterministically: while one transaction holds a sweep's results lock
/// (as a completion does between drawing its sequence numbers and its commit), another
/// worker's completion of the same sweep waits for it instead of committing later
/// sequence numbers first, which a reader following `seq > last seen` would then pass
/// over. Without the lock in `complete` the second completion returns at once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_completion_waits_for_an_earlier_one_of_the_same_sweep() {
    let Some(pg) = PgCluster::start_or_skip("ordered completions") else {
        return;
    };
    let q = queue(&pg).await;
    let (id, _) = submit_spec(&q, &spec(4), SweepOptions::default(), 2)
        .await
        .unwrap();
    let lease = q.claim("B", "cpu", 2, LONG).await.unwrap().unwrap();
    // "Worker A": a transaction in the middle of storing its results.
    let (mut client, conn) = tokio_postgres::connect(&pg.url(), tokio_postgres::NoTls)
        .await
        .unwrap();
    tokio::spawn(conn);
    let tx = client.transaction().await.unwrap();
    tx.execute(
        "SELECT pg_advisory_xact_lock($1, hashtext($2))",
        &[&RESULTS_LOCK_CLASS, &id],
    )
    .await
    .unwrap();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let b = {
        let (q, lease, done) = (q.clone(), lease.clone(), done.clone());
        tokio::spawn(async move {
            let r = q.complete(&lease, &settings(), &rows(&lease)).await;
            done.store(true, std::sync::atomic::Ordering::SeqCst);
            r
        })
    };
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert!(
        !done.load(std::sync::atomic::Ordering::SeqCst),
        "worker B committed while worker A still held the sweep's results open"
    );
    tx.commit().await.unwrap();
    let r = tokio::time::timeout(Duration::from_secs(30), b)
        .await
        .expect("B completes once A has committed")
        .unwrap();
    r.unwrap();
    assert_eq!(stored(&q, &id).await.len(), lease.variant_ids().len());
}
