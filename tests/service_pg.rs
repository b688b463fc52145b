//! The sweep service on PostgreSQL (`serve --database`) with `worker` processes doing the
//! computing: the same API suite as on the embedded SQLite store (tests/service_support),
//! and a restart of PostgreSQL in the middle of a sweep that the server and the workers
//! ride out. Skipped with a notice without PostgreSQL (unless
//! BEARING_SWEEP_REQUIRE_POSTGRES=1).

mod pg_support;
mod service_support;

use std::time::Duration;

use pg_support::{PgCluster, Workers};
use service_support::*;

#[test]
fn api_suite_on_the_postgres_store() {
    let Some(pg) = PgCluster::start_or_skip("api suite on postgres") else {
        return;
    };
    let dir = scratch("pg-suite");
    let url = pg.url();
    let server = Server::start(
        &dir.join("data"),
        &["--database", &url, "--eval-window-ms", "20"],
    );
    let _workers = Workers::start(&url, 2, 4, 3, &dir);
    let base = server.url.clone();
    assert_eq!(get(&format!("{base}/healthz"), None).status, 200);
    suite::bad_input_is_refused_naming_the_field(&base);
    suite::sweep_events_result_and_csv(&base, &dir);
    suite::cancel_stops_within_a_second(&base);
    suite::eval_requests_are_coalesced(&base);
    suite::friction_map_reads_done(&base);
    // Nothing went to the SQLite store.
    assert!(
        !dir.join("data").join("sweeps.db").exists(),
        "serve --database wrote an SQLite store"
    );
    // Variants the workers stored are counted in the server's metrics. The server learns
    // of them by polling the queue (every 200 ms), so the count may trail the stored
    // results for a few looks: wait for it, bounded.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let mut done = metric(&base, "bearing_sweep_variants_done_total");
    while done < 12.0 && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(100));
        done = metric(&base, "bearing_sweep_variants_done_total");
    }
    assert!(done >= 12.0, "variants_done_total {done}, expected >= 12");
}

#[test]
fn server_and_workers_ride_out_a_postgres_restart_mid_sweep() {
    let Some(pg) = PgCluster::start_or_skip("restart under the service") else {
        return;
    };
    let dir = scratch("pg-restart");
    let url = pg.url();
    let server = Server::start(&dir.join("data"), &["--database", &url]);
    let _workers = Workers::start(&url, 2, 4, 3, &dir);
    let base = server.url.clone();
    // 60 variants x 50 ms in leases of 4: about 1.5 s with two workers.
    let spec = synthetic_spec(60, 50);
    let id = submit(&base, &spec, "");
    wait_for(&base, &id, Duration::from_secs(60), |v| {
        v["progress"]["done"].as_u64().unwrap_or(0) >= 8
    });
    pg.restart(Duration::from_secs(2));
    let v = wait_for(&base, &id, Duration::from_secs(90), |v| {
        v["status"] == "done"
    });
    assert_eq!(v["progress"]["done"], 60, "{v}");
    let result = get(&format!("{base}/api/sweeps/{id}/result"), None);
    assert_eq!(result.status, 200, "{}", result.text);
    let spec_file = dir.join("restart.json");
    std::fs::write(&spec_file, spec.to_string()).unwrap();
    let cli = run_cli(&spec_file, &dir.join("out"));
    let (s, c) = (deterministic_text(&result.text), deterministic_text(&cli));
    assert!(
        s == c,
        "result after the restart differs from run's:\nservice {s}\nrun     {c}"
    );
    // Each variant computed and stored once (no lease was lost: the restart was shorter
    // than the leases).
    assert_eq!(v["variants_computed"], 60, "{v}");
}
