//! A bounded soak of the service (issue 22, "keep it from coming back"): for about half a
//! minute, clients submit sweeps, evaluate states, cancel, delete and follow event
//! streams, and halfway the server is killed with SIGKILL and started again on the same
//! store. Asserted: no answer is a 5xx; every event stream ends (a final status, a
//! `deleted` event, a 404, or the connection cut by the kill); the server's resident
//! memory stays under [`RSS_BOUND`]; every sweep that finished `done` has `run`'s
//! result bit for bit (but for the `run` section).

mod service_support;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use service_support::*;

/// The server's resident memory never exceeds this during the soak: the eval bodies,
/// sweeps and streams in flight here need a few tens of MB; 300 MiB leaves room for the
/// allocator's slack and still catches any per-request leak or an unbounded buffer.
const RSS_BOUND: u64 = 300 << 20;
/// Load phase before and after the restart.
const PHASE: Duration = Duration::from_secs(12);

/// Two sweep specs (the soak's results are checked against `run` on each).
fn specs() -> [Value; 2] {
    [synthetic_spec(6, 20), synthetic_spec(10, 5)]
}

fn eval_body(k: usize) -> String {
    let states: Vec<Value> = (0..40)
        .map(|j| {
            json!({"xi": 1e-4, "yi": 5e-5 + 1e-7 * ((k + j) % 50) as f64, "xj": 1e-4, "yj": 5e-5,
                   "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100})
        })
        .collect();
    json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
           "states": states})
    .to_string()
}

/// What the clients saw.
#[derive(Default)]
struct Seen {
    /// Answers of 500 and above: (what, status, body).
    server_errors: Vec<(String, u16, String)>,
    /// Sweeps submitted: (id, spec index).
    sweeps: Vec<(String, usize)>,
    /// Deleted sweeps.
    deleted: Vec<String>,
    /// Event streams that did not end in time: (id, text).
    open_streams: Vec<(String, String)>,
    /// Requests answered.
    answered: u64,
}

fn agent(timeout: Duration) -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(timeout))
        .build()
        .into()
}

/// One exchange; `None` when the connection failed (the server being restarted).
fn call(method: &str, url: &str, body: Option<&str>) -> Option<(u16, String)> {
    let a = agent(Duration::from_secs(30));
    let r = match (method, body) {
        ("POST", Some(b)) => a
            .post(url)
            .header("Content-Type", "application/json")
            .send(b.as_bytes()),
        ("POST", None) => a.post(url).send_empty(),
        ("DELETE", _) => a.delete(url).call(),
        _ => a.get(url).call(),
    };
    let mut r = r.ok()?;
    let status = r.status().as_u16();
    let text = r
        .body_mut()
        .with_config()
        .limit(1 << 28)
        .read_to_string()
        .ok()?;
    Some((status, text))
}

fn record(seen: &Mutex<Seen>, what: &str, answer: &Option<(u16, String)>) {
    let mut s = seen.lock().unwrap();
    if let Some((status, text)) = answer {
        s.answered += 1;
        if *status >= 500 {
            s.server_errors
                .push((what.to_string(), *status, text.chars().take(300).collect()));
        }
    }
}

#[test]
fn soak_submits_evals_cancels_deletes_streams_and_a_sigkill() {
    let dir = scratch("soak");
    let data = dir.join("data");
    let server = Arc::new(Mutex::new(Some(Server::start(
        &data,
        &["--eval-backend", "cpu"],
    ))));
    let base = Arc::new(RwLock::new(
        server.lock().unwrap().as_ref().unwrap().url.clone(),
    ));
    let seen = Arc::new(Mutex::new(Seen::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let max_rss = Arc::new(Mutex::new(0u64));
    let specs = specs();
    let mut clients = Vec::new();
    // Submitter: a sweep every ~250 ms, each followed by an event reader.
    {
        let (base, seen, stop) = (base.clone(), seen.clone(), stop.clone());
        let specs = specs.clone();
        clients.push(std::thread::spawn(move || {
            let mut readers = Vec::new();
            let mut k = 0usize;
            while !stop.load(Ordering::Relaxed) {
                let b = base.read().unwrap().clone();
                let which = k % 2;
                let a = call(
                    "POST",
                    &format!("{b}/api/sweeps"),
                    Some(&specs[which].to_string()),
                );
                record(&seen, "submit", &a);
                if let Some((201, text)) = &a {
                    let id = serde_json::from_str::<Value>(text).unwrap()["id"]
                        .as_str()
                        .unwrap()
                        .to_string();
                    seen.lock().unwrap().sweeps.push((id.clone(), which));
                    let seen = seen.clone();
                    let url = format!("{b}/api/sweeps/{id}/events");
                    readers.push(std::thread::spawn(move || {
                        let a = agent(Duration::from_secs(90));
                        let out = a.get(&url).call().map(|mut r| {
                            (
                                r.status().as_u16(),
                                r.body_mut().read_to_string().unwrap_or_default(),
                            )
                        });
                        match out {
                            Ok((status, text)) => {
                                if status >= 500 {
                                    seen.lock().unwrap().server_errors.push((
                                        "events".into(),
                                        status,
                                        text.clone(),
                                    ));
                                }
                                // Ended: the read returned. A 200 stream ends with a final
                                // status or `deleted`, or was cut by the kill.
                                let ended = status == 404
                                    || text.contains("\"done\"")
                                    || text.contains("\"cancelled\"")
                                    || text.contains("\"failed\"")
                                    || text.contains("deleted")
                                    || status == 200;
                                if !ended {
                                    seen.lock().unwrap().open_streams.push((id, text));
                                }
                            }
                            Err(ureq::Error::Timeout(_)) => {
                                seen.lock()
                                    .unwrap()
                                    .open_streams
                                    .push((id, "timed out".into()));
                            }
                            // Connection cut by the SIGKILL: ended.
                            Err(_) => {}
                        }
                    }));
                }
                k += 1;
                std::thread::sleep(Duration::from_millis(250));
            }
            for r in readers {
                r.join().unwrap();
            }
        }));
    }
    // Evaluator.
    {
        let (base, seen, stop) = (base.clone(), seen.clone(), stop.clone());
        clients.push(std::thread::spawn(move || {
            let mut k = 0;
            while !stop.load(Ordering::Relaxed) {
                let b = base.read().unwrap().clone();
                let a = call("POST", &format!("{b}/api/eval"), Some(&eval_body(k)));
                record(&seen, "eval", &a);
                if let Some((status, text)) = &a {
                    assert!(
                        *status == 200 || *status >= 500,
                        "eval answered {status}: {text}"
                    );
                }
                k += 1;
                std::thread::sleep(Duration::from_millis(30));
            }
        }));
    }
    // Canceller and deleter: every third sweep cancelled, every fifth deleted.
    {
        let (base, seen, stop) = (base.clone(), seen.clone(), stop.clone());
        clients.push(std::thread::spawn(move || {
            let mut handled = 0;
            while !stop.load(Ordering::Relaxed) {
                let next = seen.lock().unwrap().sweeps.get(handled).cloned();
                let Some((id, _)) = next else {
                    std::thread::sleep(Duration::from_millis(100));
                    continue;
                };
                let b = base.read().unwrap().clone();
                if handled % 3 == 1 {
                    let a = call("POST", &format!("{b}/api/sweeps/{id}/cancel"), None);
                    record(&seen, "cancel", &a);
                }
                if handled % 5 == 2 {
                    let a = call("DELETE", &format!("{b}/api/sweeps/{id}"), None);
                    record(&seen, "delete", &a);
                    if matches!(a, Some((204, _))) {
                        seen.lock().unwrap().deleted.push(id.clone());
                    }
                }
                let a = call("GET", &format!("{b}/api/sweeps"), None);
                record(&seen, "list", &a);
                let a = call("GET", &format!("{b}/metrics"), None);
                record(&seen, "metrics", &a);
                handled += 1;
                std::thread::sleep(Duration::from_millis(150));
            }
        }));
    }
    // Memory watcher.
    {
        let (server, stop, max_rss) = (server.clone(), stop.clone(), max_rss.clone());
        clients.push(std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if let Some(s) = server.lock().unwrap().as_ref() {
                    let r = rss_bytes(s.pid());
                    let mut m = max_rss.lock().unwrap();
                    *m = (*m).max(r);
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        }));
    }
    std::thread::sleep(PHASE);
    // SIGKILL and restart on the same store.
    let old = server.lock().unwrap().take().unwrap();
    old.kill9();
    let restarted = Server::start(&data, &["--eval-backend", "cpu"]);
    *base.write().unwrap() = restarted.url.clone();
    *server.lock().unwrap() = Some(restarted);
    std::thread::sleep(PHASE);
    stop.store(true, Ordering::Relaxed);
    for c in clients {
        c.join().unwrap();
    }
    let seen = Arc::try_unwrap(seen).ok().unwrap().into_inner().unwrap();
    let b = base.read().unwrap().clone();
    assert!(
        seen.server_errors.is_empty(),
        "5xx answers: {:?}",
        seen.server_errors
    );
    assert!(
        seen.open_streams.is_empty(),
        "event streams that did not end: {:?}",
        seen.open_streams
    );
    let rss = *max_rss.lock().unwrap();
    assert!(
        rss < RSS_BOUND,
        "server RSS peaked at {} MiB (bound {} MiB)",
        rss >> 20,
        RSS_BOUND >> 20
    );
    assert!(seen.sweeps.len() >= 20, "only {} sweeps", seen.sweeps.len());
    assert!(seen.answered >= 100, "only {} answers", seen.answered);
    // Every remaining sweep reaches a final status; the done ones equal `run`'s result.
    let reference: Vec<String> = specs
        .iter()
        .enumerate()
        .map(|(k, spec)| {
            let f = dir.join(format!("soak{k}.json"));
            std::fs::write(&f, spec.to_string()).unwrap();
            deterministic_text(&run_cli(&f, &dir.join(format!("out{k}"))))
        })
        .collect();
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut checked = 0;
    for (id, which) in &seen.sweeps {
        if seen.deleted.contains(id) {
            continue;
        }
        let v = loop {
            let a = get(&format!("{b}/api/sweeps/{id}"), None);
            if a.status == 404 {
                // Deleted by a request whose answer the kill cut off.
                break None;
            }
            assert_eq!(a.status, 200, "{id}: {}", a.text);
            let v = a.json();
            if v["status"] != "queued" && v["status"] != "running" {
                break Some(v);
            }
            assert!(Instant::now() < deadline, "{id} did not finish: {v}");
            std::thread::sleep(Duration::from_millis(100));
        };
        let Some(v) = v else { continue };
        assert!(
            v["status"] == "done" || v["status"] == "cancelled",
            "{id}: {v}"
        );
        if v["status"] == "done" {
            let r = get(&format!("{b}/api/sweeps/{id}/result"), None);
            assert_eq!(r.status, 200, "{}", r.text);
            assert!(
                deterministic_text(&r.text) == reference[*which],
                "sweep {id} (spec {which}): the service's result differs from run's"
            );
            checked += 1;
        }
    }
    assert!(checked >= 5, "only {checked} done sweeps compared with run");
}
