//! The service under attack (issue 22), on the embedded SQLite store: each test is the
//! regression test of one item, attacking a real `serve` process on 127.0.0.1 as the
//! issue did, bounded in count and time. PostgreSQL items are in tests/pg_attack.rs.

mod service_support;

use std::time::{Duration, Instant};

use serde_json::{json, Value};
use service_support::*;

const MIB: u64 = 1 << 20;

fn bearing() -> Value {
    json!({"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242})
}

/// An eval body of `n` states (all the same, valid).
fn eval_body(n: usize) -> Vec<u8> {
    let state =
        r#"{"xi":1e-4,"yi":5e-5,"xj":1e-4,"yj":5e-5,"vxi":0,"vyi":0,"vxj":0,"vyj":0,"omega":100}"#;
    let mut s = format!(r#"{{"bearing":{},"states":["#, bearing());
    for k in 0..n {
        if k > 0 {
            s.push(',');
        }
        s.push_str(state);
    }
    s.push_str("]}");
    s.into_bytes()
}

fn header<'a>(headers: &'a [(String, String)], name: &str) -> Option<&'a str> {
    headers
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(name))
        .map(|(_, v)| v.as_str())
}

/// Item 1: a request whose memory is over the per-request budget is refused with 422
/// naming the field before any work (the issue's 400k speeds went to ~14 GB): the answer
/// comes back while the server stays small.
#[test]
fn requests_over_the_memory_budget_are_refused_before_work() {
    let dir = scratch("attack-budget");
    let server = Server::start(&dir.join("data"), &["--max-body-bytes", "16000000"]);
    let base = server.url.clone();
    // 400 000 speeds: 2.0 MB of body.
    let speeds: Vec<String> = (0..400_000).map(|k| format!("{}", 100 + k % 500)).collect();
    let body = format!(
        r#"{{"bearing":{},"speeds":[{}],"load":[0,-500]}}"#,
        bearing(),
        speeds.join(",")
    );
    let a = post(&format!("{base}/api/coefficients"), body.as_bytes(), None);
    assert_eq!(a.status, 422, "{}", a.text);
    let e = a.json();
    assert_eq!(e["error"]["path"], "speeds", "{e}");
    let msg = e["error"]["message"].as_str().unwrap_or("");
    assert!(
        msg.contains("400000 speeds") && msg.contains("budget"),
        "{msg}"
    );
    // 120 000 states: 11 MB of body.
    let a = post(&format!("{base}/api/eval"), &eval_body(120_000), None);
    assert_eq!(a.status, 422, "{}", a.text);
    assert_eq!(a.json()["error"]["path"], "states", "{}", a.text);
    let rss = rss_bytes(server.pid());
    // Bodies parsed (12 MB of JSON as values) and refused: far below what the work
    // would have taken (GBs).
    assert!(
        rss < 400 * MIB,
        "server RSS {} MiB after refusing (bound 400 MiB)",
        rss / MIB
    );
    // A request within the budget is answered.
    let a = post(&format!("{base}/api/eval"), &eval_body(100), None);
    assert_eq!(a.status, 200, "{}", a.text);
    assert_eq!(a.json()["loads"].as_array().map(Vec::len), Some(100));
}

/// Item 1: states in flight are bounded across requests (503 with Retry-After beyond),
/// and memory is handed back once large requests are answered (the issue's server kept
/// 1.8 GB after eight 4 MiB evals).
#[test]
fn states_in_flight_are_bounded_and_memory_is_given_back() {
    let dir = scratch("attack-inflight");
    let server = Server::start(
        &dir.join("data"),
        &["--max-states-in-flight", "40000", "--eval-backend", "cpu"],
    );
    let base = server.url.clone();
    let warm = post(&format!("{base}/api/eval"), &eval_body(10), None);
    assert_eq!(warm.status, 200, "{}", warm.text);
    let before = rss_bytes(server.pid());
    let body = std::sync::Arc::new(eval_body(15_000));
    let barrier = std::sync::Arc::new(std::sync::Barrier::new(6));
    let handles: Vec<_> = (0..6)
        .map(|_| {
            let (body, barrier, url) = (body.clone(), barrier.clone(), format!("{base}/api/eval"));
            std::thread::spawn(move || {
                barrier.wait();
                let (a, h) = post_with(&url, &body, &[("Content-Type", "application/json")]);
                (
                    a.status,
                    header(&h, "retry-after").map(str::to_string),
                    a.text,
                )
            })
        })
        .collect();
    let answers: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    let ok = answers.iter().filter(|a| a.0 == 200).count();
    let busy = answers.iter().filter(|a| a.0 == 503).count();
    for (k, (status, retry, text)) in answers.iter().enumerate() {
        assert!(
            *status == 200 || *status == 503,
            "request {k}: {status} {text}"
        );
        if *status == 503 {
            assert!(retry.is_some(), "request {k}: 503 without Retry-After");
            assert!(text.contains("\"error\""), "request {k}: {text}");
        }
    }
    // 6 x 15 000 states against 40 000 in flight: at most 2 at once.
    assert!(ok >= 1 && busy >= 1, "200s {ok}, 503s {busy}: {answers:?}");
    // Memory is handed back once the answers are written, which on a loaded machine can
    // come a little after the client has read them: poll (bounded, 10 s) instead of one
    // read after a fixed pause (a single read at 500 ms failed once under load, 165 MiB).
    let mut after = rss_bytes(server.pid());
    for _ in 0..40 {
        if after < before + 150 * MIB {
            break;
        }
        std::thread::sleep(Duration::from_millis(250));
        after = rss_bytes(server.pid());
    }
    assert!(
        after < before + 150 * MIB,
        "RSS {} MiB after the requests, {} MiB before (bound: +150 MiB)",
        after / MIB,
        before / MIB
    );
}

/// Item 2: listing and status read summary columns only: a 60 MB result document stored
/// with a sweep neither enters the idle server's memory nor costs it CPU (the issue's
/// idle server burned 23-32 % of a core re-parsing a 149 MB result every 0.5 s).
#[test]
fn an_idle_server_with_a_large_stored_result_stays_idle() {
    let dir = scratch("attack-summary");
    let data = dir.join("data");
    let server = Server::start(&data, &[]);
    let base = server.url.clone();
    let spec = json!({"kind": "friction_map", "name": "big map",
        "bearing": bearing(), "load": [10, 100], "speed": [10, 100]});
    let id = submit(&base, &spec, "");
    wait_for(&base, &id, Duration::from_secs(60), |v| {
        v["status"] == "done"
    });
    drop(server);
    // A 60 MB result document (valid, pretty JSON) stored for it.
    let pad = "0.0, ".repeat(12 << 20);
    let doc = format!("{{\n  \"pad\": [{} 0.0]\n}}\n", pad);
    {
        let c = rusqlite::Connection::open(data.join("sweeps.db")).unwrap();
        c.execute(
            "UPDATE sweeps SET result_doc = ?2 WHERE id = ?1",
            rusqlite::params![id, doc],
        )
        .unwrap();
    }
    let server = Server::start(&data, &[]);
    let base = server.url.clone();
    for _ in 0..3 {
        assert_eq!(get(&format!("{base}/api/sweeps"), None).status, 200);
        assert_eq!(get(&format!("{base}/api/sweeps/{id}"), None).status, 200);
        assert_eq!(get(&format!("{base}/metrics"), None).status, 200);
    }
    let cpu0 = cpu_s(server.pid());
    std::thread::sleep(Duration::from_secs(3));
    let idle_cpu = cpu_s(server.pid()) - cpu0;
    let rss = rss_bytes(server.pid());
    assert!(
        rss < 60 * MIB,
        "idle server RSS {} MiB with a 60 MB result stored (bound 60 MiB: the result must not be read)",
        rss / MIB
    );
    assert!(
        idle_cpu < 0.3,
        "idle server used {idle_cpu:.2} s of CPU in 3 s (bound 0.3 s)"
    );
    // The result itself is still served, streamed as stored.
    let r = get(&format!("{base}/api/sweeps/{id}/result"), None);
    assert_eq!(r.status, 200);
    assert_eq!(r.text.len(), doc.len(), "result length");
}

/// Item 3: a second `serve` on the same `--data` is refused, naming the folder and the
/// holder's pid; the first keeps serving.
#[test]
fn a_second_server_on_one_store_is_refused() {
    let dir = scratch("attack-lock");
    let data = dir.join("data");
    let first = Server::start(&data, &[]);
    let mut second = bin()
        .args(["serve", "--bind", "127.0.0.1:0", "--data"])
        .arg(&data)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = second.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(20) {
            let _ = second.kill();
            let _ = second.wait();
            panic!("a second server on {} is serving", data.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(!status.success(), "the second server exited with {status}");
    let mut err = String::new();
    std::io::Read::read_to_string(&mut second.stderr.take().unwrap(), &mut err).unwrap();
    assert!(
        err.contains(&data.display().to_string()),
        "message does not name the folder: {err}"
    );
    assert!(
        err.contains(&format!("process {}", first.pid())),
        "message does not name the holder's pid {}: {err}",
        first.pid()
    );
    assert_eq!(get(&format!("{}/healthz", first.url), None).status, 200);
    // Once the first is gone (even by SIGKILL) the store can be served again.
    first.kill9();
    let again = Server::start(&data, &[]);
    assert_eq!(get(&format!("{}/healthz", again.url), None).status, 200);
}

/// Item 6: a connection that sends half a header is closed after the header timeout;
/// connections per client are bounded (the issue's 500 half headers stayed 40 s).
#[test]
fn half_headers_time_out_and_connections_per_client_are_bounded() {
    use std::io::{Read, Write};
    let dir = scratch("attack-slow");
    let server = Server::start(
        &dir.join("data"),
        &[
            "--header-timeout-s",
            "1",
            "--max-connections-per-client",
            "8",
        ],
    );
    let addr = server.addr();
    let mut slow = std::net::TcpStream::connect(&addr).unwrap();
    slow.write_all(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
        .unwrap();
    slow.set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let start = Instant::now();
    let mut buf = [0u8; 512];
    let n = slow.read(&mut buf).unwrap_or(0);
    let waited = start.elapsed();
    assert!(
        waited < Duration::from_secs(8),
        "a half header kept its connection {waited:?} (header timeout 1 s)"
    );
    let _ = n; // closed (0) or an error answer, either way the connection ended.
               // Eight idle connections are held; the ninth is closed at once.
    let held: Vec<_> = (0..8)
        .map(|_| std::net::TcpStream::connect(&addr).unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let (status, text) = raw(
        &addr,
        b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
        Duration::from_secs(5),
    );
    assert_eq!(status, 0, "a ninth connection was served: {text}");
    drop(held);
    std::thread::sleep(Duration::from_millis(300));
    let (status, text) = raw(
        &addr,
        b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
        Duration::from_secs(5),
    );
    assert_eq!(status, 200, "{text}");
}

/// Item 7: a foreign page cannot write (Origin) nor read through DNS rebinding (Host),
/// and JSON bodies must say so (a `text/plain` POST is the browser's preflight-free
/// cross-site request).
#[test]
fn foreign_origins_hosts_and_content_types_are_refused() {
    let dir = scratch("attack-origin");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    let spec = synthetic_spec(2, 0).to_string();
    let url = format!("{base}/api/sweeps");
    let (a, _) = post_with(&url, spec.as_bytes(), &[("Content-Type", "text/plain")]);
    assert_eq!(a.status, 415, "{}", a.text);
    assert_eq!(a.json()["error"]["path"], "Content-Type");
    let (a, _) = post_with(
        &format!("{base}/api/eval"),
        &eval_body(1),
        &[("Content-Type", "text/plain;charset=UTF-8")],
    );
    assert_eq!(a.status, 415, "{}", a.text);
    let (a, _) = post_with(
        &url,
        spec.as_bytes(),
        &[
            ("Content-Type", "application/json"),
            ("Origin", "http://evil.example"),
        ],
    );
    assert_eq!(a.status, 403, "{}", a.text);
    assert_eq!(a.json()["error"]["path"], "Origin");
    // DNS rebinding: the page's name resolved to 127.0.0.1.
    let (status, text) = raw(
        &server.addr(),
        b"GET /api/sweeps HTTP/1.1\r\nHost: evil.example:8080\r\nConnection: close\r\n\r\n",
        Duration::from_secs(5),
    );
    assert_eq!(status, 403, "{text}");
    assert!(text.contains("\"Host\""), "{text}");
    // Nothing was stored; the server's own page (same origin) may write.
    let list = get(&format!("{base}/api/sweeps"), None).json();
    assert_eq!(list["sweeps"].as_array().map(Vec::len), Some(0), "{list}");
    let (a, _) = post_with(
        &url,
        spec.as_bytes(),
        &[
            ("Content-Type", "application/json; charset=utf-8"),
            ("Origin", base.as_str()),
        ],
    );
    assert_eq!(a.status, 201, "{}", a.text);
    let (status, text) = raw(
        &server.addr(),
        b"GET /api/sweeps HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n",
        Duration::from_secs(5),
    );
    assert_eq!(status, 200, "{text}");
}

/// Item 8: the event stream of a sweep deleted while queued ends (the issue saw ~9 % of
/// such races hang). Many races, each bounded.
#[test]
fn event_streams_of_deleted_sweeps_end() {
    let dir = scratch("attack-delete-events");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    // A long sweep holds the one running slot, so the raced ones stay queued.
    let blocker = submit(&base, &synthetic_spec(1, 60_000), "");
    let mut failures = Vec::new();
    for round in 0..40 {
        let id = submit(&base, &synthetic_spec(2, 0), "");
        let events_url = format!("{base}/api/sweeps/{id}/events");
        let reader = std::thread::spawn(move || {
            let (status, text) = {
                let a = ureq::Agent::config_builder()
                    .http_status_as_error(false)
                    .timeout_global(Some(Duration::from_secs(20)))
                    .build();
                let agent: ureq::Agent = a.into();
                match agent.get(&events_url).call() {
                    Ok(mut r) => (
                        r.status().as_u16(),
                        r.body_mut()
                            .read_to_string()
                            .unwrap_or_else(|e| format!("ERR {e}")),
                    ),
                    Err(e) => (0, format!("ERR {e}")),
                }
            };
            (status, text)
        });
        if round % 2 == 1 {
            std::thread::sleep(Duration::from_millis(round as u64 % 7));
        }
        let d = delete(&format!("{base}/api/sweeps/{id}"), None);
        assert_eq!(d.status, 204, "{}", d.text);
        let (status, text) = reader.join().unwrap();
        let ended = status == 404 || (status == 200 && text.contains("deleted"));
        if !ended || text.contains("ERR") {
            failures.push(format!("round {round}: {status} {text}"));
        }
    }
    assert!(
        failures.is_empty(),
        "streams that did not end: {failures:?}"
    );
    let _ = post(&format!("{base}/api/sweeps/{blocker}/cancel"), b"", None);
}

/// Item 9: a Content-Length over the body limit is answered 413 from the header, without
/// waiting for a body that never comes (the issue waited 40 s).
#[test]
fn an_oversized_content_length_is_answered_at_once() {
    let dir = scratch("attack-length");
    let server = Server::start(&dir.join("data"), &[]);
    let start = Instant::now();
    let (status, text) = raw(
        &server.addr(),
        b"POST /api/eval HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: 1000000000\r\n\r\n{\"a\":1}",
        Duration::from_secs(20),
    );
    assert_eq!(status, 413, "{text}");
    assert!(text.contains("\"error\""), "{text}");
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "answered after {:?}",
        start.elapsed()
    );
}

/// Item 10: `--max-queued 10` holds under 100 simultaneous submissions.
#[test]
fn the_queue_limit_holds_under_simultaneous_submissions() {
    let dir = scratch("attack-queue");
    let server = Server::start(&dir.join("data"), &["--max-queued", "10"]);
    let base = server.url.clone();
    let body = std::sync::Arc::new(synthetic_spec(1, 30_000).to_string());
    let barrier = std::sync::Arc::new(std::sync::Barrier::new(100));
    let handles: Vec<_> = (0..100)
        .map(|_| {
            let (body, barrier, url) =
                (body.clone(), barrier.clone(), format!("{base}/api/sweeps"));
            std::thread::spawn(move || {
                barrier.wait();
                let (a, h) = post_with(
                    &url,
                    body.as_bytes(),
                    &[("Content-Type", "application/json")],
                );
                (a.status, header(&h, "retry-after").is_some())
            })
        })
        .collect();
    let answers: Vec<(u16, bool)> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    let created = answers.iter().filter(|a| a.0 == 201).count();
    let refused = answers.iter().filter(|a| a.0 == 429 && a.1).count();
    assert_eq!(created, 10, "201s: {created} (limit 10): {answers:?}");
    assert_eq!(refused, 90, "429s with Retry-After: {refused}: {answers:?}");
    let list = get(&format!("{base}/api/sweeps"), None).json();
    assert_eq!(list["sweeps"].as_array().map(Vec::len), Some(10), "{list}");
    for s in list["sweeps"].as_array().unwrap() {
        let id = s["id"].as_str().unwrap();
        let _ = post(&format!("{base}/api/sweeps/{id}/cancel"), b"", None);
    }
}

/// Item 11: duplicate keys are refused over HTTP as `run` refuses them (same parser).
#[test]
fn duplicate_keys_are_refused_as_run_refuses_them() {
    let dir = scratch("attack-dupes");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    let text = r#"{"kind": "synthetic", "name": "a", "name": "b", "base": {"spin": 100.0, "duration": 1.0}, "axes": [{"path": "spin", "values": [50.0]}]}"#;
    let a = post(&format!("{base}/api/sweeps"), text.as_bytes(), None);
    assert_eq!(a.status, 422, "{}", a.text);
    let e = a.json();
    assert_eq!(e["error"]["path"], "name", "{e}");
    let spec_file = dir.join("dupes.json");
    std::fs::write(&spec_file, text).unwrap();
    let o = bin()
        .args(["run"])
        .arg(&spec_file)
        .arg("--out")
        .arg(dir.join("out"))
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(!o.status.success(), "run accepted duplicate keys");
    let err = String::from_utf8_lossy(&o.stderr);
    let reason = e["error"]["message"].as_str().unwrap();
    assert!(
        err.contains(reason),
        "run's message {err:?} differs from the service's {reason:?}"
    );
    let a = post(
        &format!("{base}/api/eval"),
        br#"{"bearing": {"radius": 0.02, "radius": 0.03, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}, "states": []}"#,
        None,
    );
    assert_eq!(a.status, 422, "{}", a.text);
    assert_eq!(a.json()["error"]["path"], "bearing.radius", "{}", a.text);
    let list = get(&format!("{base}/api/sweeps"), None).json();
    assert_eq!(list["sweeps"].as_array().map(Vec::len), Some(0), "{list}");
}

/// Item 12: a store that cannot be opened is named with the reason.
#[test]
fn store_open_errors_name_the_file_and_the_reason() {
    let dir = scratch("attack-store");
    let data = dir.join("data");
    // The database path is a folder: no database can be opened there.
    std::fs::create_dir_all(data.join("sweeps.db")).unwrap();
    let o = bin()
        .args(["serve", "--bind", "127.0.0.1:0", "--data"])
        .arg(&data)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    let file = data.join("sweeps.db").display().to_string();
    assert!(err.contains(&file), "the file is not named: {err}");
    assert!(
        err.to_lowercase().contains("is a directory"),
        "the reason is not given: {err}"
    );
}

/// Item 13: every error answer is the JSON error body, the framework's own rejections
/// included.
#[test]
fn every_error_is_the_json_error_body() {
    let dir = scratch("attack-errors");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    for path in [
        "/api/sweeps/%ff%fe",
        "/api/sweeps/%ff%fe/plots/%ff",
        "/api/sweeps/x/variants?limit=%ff",
        "/api/nothing",
    ] {
        let a = get(&format!("{base}{path}"), None);
        assert!(a.status >= 400, "{path}: {}", a.status);
        assert!(
            a.content_type.starts_with("application/json"),
            "{path}: {} {} {}",
            a.status,
            a.content_type,
            a.text
        );
        let e = a.json();
        assert!(e["error"]["message"].is_string(), "{path}: {e}");
        assert!(e["error"]["path"].is_string(), "{path}: {e}");
    }
}
