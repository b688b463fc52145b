//! Scaffolding for service tests: a `serve` process on 127.0.0.1 with an ephemeral port
//! (killed on drop), blocking HTTP helpers, and the API suite written against a server
//! URL so that any store (SQLite here, PostgreSQL later) runs the same checks.
#![allow(dead_code)] // each test crate uses its own subset

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
}

/// A fresh, empty scratch folder for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "bearing-sweep-service-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A running `serve` process.
pub struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT`.
    pub url: String,
    /// Everything it printed on stderr after the address line (read by a thread).
    pub log: std::sync::Arc<std::sync::Mutex<String>>,
}

impl Server {
    /// Starts `serve --bind 127.0.0.1:0 --data DATA ARGS...` and waits for its address.
    pub fn start(data: &Path, args: &[&str]) -> Server {
        let mut child = bin()
            .args(["serve", "--bind", "127.0.0.1:0", "--data"])
            .arg(data)
            .args(args)
            .env_remove("BEARING_SWEEP_TOKEN")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start serve");
        let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
        let mut url = None;
        let mut seen = String::new();
        for line in lines.by_ref() {
            let line = line.unwrap();
            seen.push_str(&line);
            seen.push('\n');
            if let Some(rest) = line.strip_prefix("listening on ") {
                url = Some(rest.split_whitespace().next().unwrap().to_string());
                break;
            }
        }
        let url = url.unwrap_or_else(|| panic!("serve did not start; it said:\n{seen}"));
        let log = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let sink = log.clone();
        std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                let mut l = sink.lock().unwrap();
                l.push_str(&line);
                l.push('\n');
            }
        });
        Server { child, url, log }
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `127.0.0.1:PORT`.
    pub fn addr(&self) -> String {
        self.url.trim_start_matches("http://").to_string()
    }

    /// Whether the process has exited (reaping it).
    pub fn exited(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(Some(_)))
    }

    /// SIGKILL, and reap.
    pub fn kill9(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// SIGTERM; waits up to `timeout` for the exit status.
    pub fn terminate(mut self, timeout: Duration) -> Option<std::process::ExitStatus> {
        // SAFETY: kill(2) on our own child's pid.
        unsafe {
            libc::kill(self.child.id() as i32, libc::SIGTERM);
        }
        let start = Instant::now();
        while start.elapsed() < timeout {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An HTTP answer: status and body text.
pub struct Answer {
    /// HTTP status.
    pub status: u16,
    /// Body.
    pub text: String,
    /// Content type.
    pub content_type: String,
}

impl Answer {
    /// The body as JSON (panics with the body when it is not).
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.text).unwrap_or_else(|e| panic!("not JSON ({e}): {}", self.text))
    }
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(120)))
        .build()
        .into()
}

fn finish(r: Result<ureq::http::Response<ureq::Body>, ureq::Error>) -> Answer {
    let mut r = r.expect("HTTP exchange");
    let content_type = r
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    Answer {
        status: r.status().as_u16(),
        text: r
            .body_mut()
            .with_config()
            .limit(1 << 30)
            .read_to_string()
            .unwrap(),
        content_type,
    }
}

/// GET `url` (with a bearer token if given).
pub fn get(url: &str, token: Option<&str>) -> Answer {
    let mut r = agent().get(url);
    if let Some(t) = token {
        r = r.header("Authorization", format!("Bearer {t}"));
    }
    finish(r.call())
}

/// POST `body` to `url`.
pub fn post(url: &str, body: &[u8], token: Option<&str>) -> Answer {
    let mut r = agent().post(url).content_type("application/json");
    if let Some(t) = token {
        r = r.header("Authorization", format!("Bearer {t}"));
    }
    finish(r.send(body))
}

/// DELETE `url`.
pub fn delete(url: &str, token: Option<&str>) -> Answer {
    let mut r = agent().delete(url);
    if let Some(t) = token {
        r = r.header("Authorization", format!("Bearer {t}"));
    }
    finish(r.call())
}

/// Submits a spec; returns its id (panics unless 201).
pub fn submit(base: &str, spec: &Value, query: &str) -> String {
    let a = post(
        &format!("{base}/api/sweeps{query}"),
        spec.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 201, "submit: {}", a.text);
    a.json()["id"].as_str().unwrap().to_string()
}

/// Polls the sweep until `pred(status document)` or `timeout` (panics then).
pub fn wait_for(base: &str, id: &str, timeout: Duration, pred: impl Fn(&Value) -> bool) -> Value {
    let start = Instant::now();
    loop {
        let a = get(&format!("{base}/api/sweeps/{id}"), None);
        assert_eq!(a.status, 200, "status of {id}: {}", a.text);
        let v = a.json();
        if pred(&v) {
            return v;
        }
        assert!(
            start.elapsed() < timeout,
            "sweep {id} did not reach the condition in {timeout:?}: {v}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A synthetic sweep of `n` variants costing `cost_ms` each (deterministic signals).
pub fn synthetic_spec(n: usize, cost_ms: u64) -> Value {
    let spins: Vec<f64> = (0..n).map(|k| 50.0 + k as f64).collect();
    serde_json::json!({
        "kind": "synthetic",
        "name": "synthetic service test",
        "base": {"spin": 100.0, "duration": 1.0, "cost_ms": cost_ms},
        "axes": [{"path": "spin", "values": spins}],
        "reductions": {"window": {"revolutions": 3}}
    })
}

/// A result without its `run` section (the part that must equal `run`'s bit for bit),
/// as text.
pub fn deterministic_text(text: &str) -> String {
    let mut v: Value = serde_json::from_str(text).unwrap();
    v.as_object_mut().unwrap().remove("run");
    serde_json::to_string(&v).unwrap()
}

/// Runs `bearing-sweep run SPEC --out OUT --quiet` and returns result.json's text.
pub fn run_cli(spec_file: &Path, out: &Path) -> String {
    let o = bin()
        .args(["run"])
        .arg(spec_file)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "run failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stem = spec_file.file_stem().unwrap();
    std::fs::read_to_string(out.join(stem).join("result.json")).unwrap()
}

/// Resident memory of process `pid`, bytes (Linux `/proc`; 0 elsewhere).
pub fn rss_bytes(pid: u32) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// CPU time (user + system) of process `pid` so far, s (Linux `/proc`).
pub fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name (which may hold spaces) in parentheses.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    // utime and stime are fields 14 and 15 of stat, 12 and 13 after the name.
    (ticks(11) + ticks(12)) / hz.max(1.0)
}

/// One raw HTTP/1.1 exchange on a fresh connection: sends `request` as is, reads until
/// the server closes or `timeout`; returns the status (0: none) and the whole answer.
pub fn raw(addr: &str, request: &[u8], timeout: Duration) -> (u16, String) {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(timeout)).unwrap();
    let _ = s.write_all(request);
    let mut out = Vec::new();
    let mut buf = [0u8; 8192];
    let start = Instant::now();
    while start.elapsed() < timeout {
        match s.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                out.extend_from_slice(&buf[..n]);
                // One answer is enough: stop at the end of a JSON error body.
                let text = String::from_utf8_lossy(&out);
                if let Some((head, body)) = text.split_once("\r\n\r\n") {
                    let len = head.lines().find_map(|l| {
                        l.to_ascii_lowercase()
                            .strip_prefix("content-length:")
                            .map(|v| v.trim().parse::<usize>().unwrap_or(0))
                    });
                    if len.is_some_and(|n| body.len() >= n) {
                        break;
                    }
                }
            }
            Err(_) => break,
        }
    }
    let text = String::from_utf8_lossy(&out).to_string();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (status, text)
}

/// POST `body` with extra headers; the answer and its headers (lower-case names).
pub fn post_with(
    url: &str,
    body: &[u8],
    headers: &[(&str, &str)],
) -> (Answer, Vec<(String, String)>) {
    let mut r = agent().post(url);
    for (k, v) in headers {
        r = r.header(*k, *v);
    }
    let resp = r.send(body);
    let hs: Vec<(String, String)> = resp
        .as_ref()
        .map(|r| {
            r.headers()
                .iter()
                .map(|(k, v)| (k.as_str().to_string(), v.to_str().unwrap_or("").to_string()))
                .collect()
        })
        .unwrap_or_default();
    (finish(resp), hs)
}

/// Reads one `bearing_sweep_...` value from `/metrics`.
pub fn metric(base: &str, name: &str) -> f64 {
    let a = get(&format!("{base}/metrics"), None);
    assert_eq!(a.status, 200);
    a.text
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{name} ")))
        .unwrap_or_else(|| panic!("no metric {name} in\n{}", a.text))
        .trim()
        .parse()
        .unwrap()
}

/// The API suite, against a server at `base` whatever its store.
pub mod suite {
    use super::*;

    /// Bad specs and bodies get 4xx naming the field; unknown routes and ids 404 as JSON.
    pub fn bad_input_is_refused_naming_the_field(base: &str) {
        let cases: [(Value, u16, &str); 4] = [
            (
                serde_json::json!({"kind": "synthetic", "base": {"spin": 1.0}, "axse": []}),
                422,
                "axse",
            ),
            (
                serde_json::json!({"kind": "synthetic", "base": {"spin": 1.0}, "axes": [{"path": "spin", "logspace": [-1, 2, 3]}]}),
                422,
                "axes[0].logspace[0]",
            ),
            (
                serde_json::json!({"kind": "synthetic", "base": {"spin": 1.0}, "axes": "spin"}),
                422,
                "axes",
            ),
            (
                serde_json::json!({"kind": "rotor", "base": "paper.json", "axes": []}),
                422,
                "base",
            ),
        ];
        for (k, (spec, status, path)) in cases.iter().enumerate() {
            let a = post(
                &format!("{base}/api/sweeps"),
                spec.to_string().as_bytes(),
                None,
            );
            assert_eq!(a.status, *status, "case {k}: {}", a.text);
            let e = a.json();
            assert_eq!(e["error"]["path"], *path, "case {k}: {e}");
            assert!(
                !e["error"]["message"].as_str().unwrap_or("").is_empty(),
                "case {k}: {e}"
            );
        }
        let a = post(&format!("{base}/api/sweeps"), b"{not json", None);
        assert_eq!(a.status, 400, "{}", a.text);
        assert_eq!(a.json()["error"]["path"], "$");
        let a = post(&format!("{base}/api/sweeps?backend=quantum"), b"{}", None);
        assert_eq!(a.status, 422, "{}", a.text);
        assert_eq!(a.json()["error"]["path"], "?backend");
        for url in ["/api/nothing", "/api/sweeps/0000000000000000", "/nowhere"] {
            let a = get(&format!("{base}{url}"), None);
            assert_eq!(a.status, 404, "{url}: {}", a.text);
            assert!(
                a.json()["error"]["message"].is_string(),
                "{url}: {}",
                a.text
            );
        }
        // Before anything was stored: nothing was queued by the bad submissions.
        let list = get(&format!("{base}/api/sweeps"), None).json();
        assert_eq!(list["sweeps"].as_array().unwrap().len(), 0, "{list}");
    }

    /// The schema a GET route's 200 answer documents for `media_type`, `$ref` resolved;
    /// fails naming the route when that media type is not documented (a client or a
    /// fuzzer reading the document would refuse the answer).
    pub fn documented_schema(doc: &Value, path: &str, media_type: &str) -> Value {
        let content = &doc["paths"][path]["get"]["responses"]["200"]["content"];
        let schema = &content[media_type]["schema"];
        assert!(
            schema.is_object(),
            "GET {path} answers {media_type} but its 200 documents only {:?}",
            content.as_object().map(|c| c.keys().collect::<Vec<_>>())
        );
        match schema["$ref"]
            .as_str()
            .and_then(|r| r.strip_prefix("#/components/schemas/"))
        {
            Some(name) => doc["components"]["schemas"][name].clone(),
            None => schema.clone(),
        }
    }

    /// A synthetic sweep: events reach `done`, the result equals `run`'s (bit for bit but
    /// for the `run` section), the CSV has one row per variant with the same numbers.
    pub fn sweep_events_result_and_csv(base: &str, scratch_dir: &Path) {
        let spec = synthetic_spec(12, 0);
        let id = submit(base, &spec, "");
        // Events: read the stream to its end (it ends after the final status).
        let a = get(&format!("{base}/api/sweeps/{id}/events"), None);
        assert_eq!(a.status, 200, "{}", a.text);
        assert!(
            a.content_type.starts_with("text/event-stream"),
            "{}",
            a.content_type
        );
        let events: Vec<(String, Value)> = a
            .text
            .split("\n\n")
            .filter_map(|block| {
                let ev = block.lines().find_map(|l| l.strip_prefix("event: "))?;
                let data = block.lines().find_map(|l| l.strip_prefix("data: "))?;
                Some((ev.to_string(), serde_json::from_str(data).unwrap()))
            })
            .collect();
        // The OpenAPI document describes what came: each event (an object of `event` and
        // `data`, OpenAPI before 3.2 reading a `text/event-stream` schema per event), its
        // name one the schema allows.
        let doc = get(&format!("{base}/api/openapi.json"), None).json();
        let event_schema = documented_schema(&doc, "/api/sweeps/{id}/events", "text/event-stream");
        assert_eq!(event_schema["type"], "object", "{event_schema}");
        for field in ["event", "data"] {
            assert_eq!(
                event_schema["properties"][field]["type"], "string",
                "{event_schema}"
            );
            assert!(
                event_schema["required"]
                    .as_array()
                    .is_some_and(|r| r.iter().any(|f| f == field)),
                "event field {field} not required: {event_schema}"
            );
        }
        let names = event_schema["properties"]["event"]["pattern"]
            .as_str()
            .unwrap_or("");
        for (e, _) in &events {
            assert!(
                names.contains(e.as_str()),
                "event {e} not in the documented pattern {names}"
            );
        }
        let last = events.last().expect("some events");
        assert_eq!(last.0, "status", "{events:?}");
        assert_eq!(last.1["status"], "done", "{events:?}");
        assert_eq!(last.1["progress"]["done"], 12, "{events:?}");
        let variant_ids: std::collections::BTreeSet<u64> = events
            .iter()
            .filter(|(e, _)| e == "variant")
            .map(|(_, v)| v["id"].as_u64().unwrap())
            .collect();
        // The stream may have started after some variants finished: every id it names is
        // one of the sweep's, at most once.
        assert!(variant_ids.iter().all(|&i| i < 12), "{variant_ids:?}");

        let result = get(&format!("{base}/api/sweeps/{id}/result"), None);
        assert_eq!(result.status, 200, "{}", result.text);
        let spec_file = scratch_dir.join("synthetic-service.json");
        std::fs::write(&spec_file, spec.to_string()).unwrap();
        let cli = run_cli(&spec_file, &scratch_dir.join("out"));
        let (s, c) = (deterministic_text(&result.text), deterministic_text(&cli));
        assert!(
            s == c,
            "service result differs from run's:\nservice {s}\nrun     {c}"
        );

        // CSV: header with units, one row per variant, numbers equal to the result's.
        let csv = get(&format!("{base}/api/sweeps/{id}/variants?format=csv"), None);
        assert_eq!(csv.status, 200);
        assert!(
            csv.content_type.starts_with("text/csv"),
            "{}",
            csv.content_type
        );
        check_csv_against_result(&csv.text, &result.json());
        documented_schema(&doc, "/api/sweeps/{id}/variants", "text/csv");
        documented_schema(&doc, "/api/sweeps/{id}/variants", "application/json");

        // JSON pages: offset/limit.
        let page = get(
            &format!("{base}/api/sweeps/{id}/variants?offset=10&limit=5"),
            None,
        )
        .json();
        let ids: Vec<u64> = page["variants"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v["id"].as_u64().unwrap())
            .collect();
        assert_eq!(ids, vec![10, 11], "{page}");
        let a = get(&format!("{base}/api/sweeps/{id}/variants?limit=x"), None);
        assert_eq!(a.status, 422);
        assert_eq!(a.json()["error"]["path"], "?limit");

        // Delete: gone, 404 after.
        assert_eq!(delete(&format!("{base}/api/sweeps/{id}"), None).status, 204);
        assert_eq!(get(&format!("{base}/api/sweeps/{id}"), None).status, 404);
    }

    /// Splits one CSV line (fields in double quotes may hold commas and `""`).
    pub fn csv_fields(line: &str) -> Vec<String> {
        let mut out = vec![String::new()];
        let mut quoted = false;
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    chars.next();
                    out.last_mut().unwrap().push('"');
                }
                ('"', _) => quoted = !quoted,
                (',', false) => out.push(String::new()),
                (c, _) => out.last_mut().unwrap().push(c),
            }
        }
        out
    }

    /// Every number of `v` (objects and arrays walked), as bits.
    fn numbers(v: &Value, out: &mut Vec<u64>) {
        match v {
            Value::Object(m) => m.values().for_each(|x| numbers(x, out)),
            Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
            Value::Number(n) => out.push(n.as_f64().unwrap().to_bits()),
            _ => {}
        }
    }

    /// The CSV for pandas (issue 23 item 7): comment lines first (`#`), then a header of
    /// short snake_case names, each numeric column's name ending with a documented unit
    /// suffix, no text column that is the same on every row, one row per variant, and each
    /// row's reduction columns holding exactly the numbers of the variant's reductions,
    /// bit for bit.
    pub fn check_csv_against_result(csv: &str, result: &Value) {
        use bearing_sweep::service::csv::UNIT_SUFFIXES;
        let mut lines = csv.lines().skip_while(|l| l.starts_with('#'));
        let header = csv_fields(lines.next().unwrap());
        assert_eq!(header[0], "id");
        let variants = result["variants"].as_array().unwrap();
        let rows: Vec<Vec<String>> = lines.map(csv_fields).collect();
        assert_eq!(rows.len(), variants.len(), "one row per variant");
        let n_params = variants[0]["params"].as_object().unwrap().len();
        assert_eq!(header[n_params + 1], "status", "{header:?}");
        for (c, name) in header.iter().enumerate() {
            assert!(
                !name.is_empty()
                    && name
                        .chars()
                        .all(|ch| ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '_'),
                "column {c} `{name}` is not snake_case"
            );
            let cells: Vec<&str> = rows
                .iter()
                .map(|r| r[c].as_str())
                .filter(|x| !x.is_empty())
                .collect();
            let numeric = !cells.is_empty() && cells.iter().all(|x| x.parse::<f64>().is_ok());
            if numeric && name != "id" {
                assert!(
                    UNIT_SUFFIXES.iter().any(|(s, _)| name.ends_with(s)),
                    "numeric column {c} `{name}` has no unit suffix"
                );
            }
            // Booleans (`oil_whirl`, `truncated`) are values of each variant, not text.
            let boolean = cells.iter().all(|x| *x == "true" || *x == "false");
            let text = !numeric && !boolean && c > n_params + 2;
            if text && rows.len() > 1 {
                assert!(
                    rows.iter().any(|r| r[c] != rows[0][c]),
                    "text column {c} `{name}` is `{}` on every row: it belongs in the comments",
                    rows[0][c]
                );
            }
        }
        let mut checked = 0;
        for (k, (row, v)) in rows.iter().zip(variants).enumerate() {
            assert_eq!(row.len(), header.len(), "row {k}: {row:?}");
            assert_eq!(row[0], v["id"].to_string(), "row {k}");
            let mut want = Vec::new();
            numbers(&v["reductions"], &mut want);
            let mut got: Vec<u64> = header
                .iter()
                .zip(row)
                .skip(n_params + 3)
                .filter(|(h, _)| !h.starts_with("sim_"))
                .filter_map(|(_, x)| x.parse::<f64>().ok())
                .map(f64::to_bits)
                .collect();
            want.sort_unstable();
            got.sort_unstable();
            assert!(
                got == want,
                "row {k}: the reduction columns' numbers {got:?} are not the result's {want:?} (tolerance 0)"
            );
            checked += got.len();
        }
        assert!(
            checked >= rows.len(),
            "too few numeric columns checked ({checked})"
        );
    }

    /// Cancel stops a running sweep within about a second; finished variants stay
    /// readable.
    pub fn cancel_stops_within_a_second(base: &str) {
        let id = submit(base, &synthetic_spec(40, 200), "");
        wait_for(base, &id, Duration::from_secs(60), |v| {
            v["progress"]["done"].as_u64().unwrap_or(0) >= 2
        });
        let t = Instant::now();
        let a = post(&format!("{base}/api/sweeps/{id}/cancel"), b"", None);
        assert_eq!(a.status, 200, "{}", a.text);
        let v = wait_for(base, &id, Duration::from_secs(10), |v| {
            v["status"] == "cancelled"
        });
        let took = t.elapsed();
        assert!(
            took < Duration::from_millis(1500),
            "cancel took {took:?} (expected < 1 s plus polling)"
        );
        let done = v["progress"]["done"].as_u64().unwrap();
        assert!((2..40).contains(&done), "{v}");
        let page = get(&format!("{base}/api/sweeps/{id}/variants?limit=100"), None).json();
        assert_eq!(
            page["variants"].as_array().unwrap().len() as u64,
            done,
            "{page}"
        );
        let r = get(&format!("{base}/api/sweeps/{id}/result"), None);
        assert_eq!(r.status, 409, "{}", r.text);
    }

    /// A friction map (no variants, every point in one step) ends `done` with its progress
    /// at `total / total` in the status and the list (it read 0 / total), and its result is
    /// the map of `run`.
    pub fn friction_map_reads_done(base: &str) {
        let spec = serde_json::json!({"kind": "friction_map", "name": "suite map",
            "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
            "load": {"logspace": [1, 1000, 7]}, "speed": [10, 100, 1000]});
        let id = submit(base, &spec, "");
        let v = wait_for(base, &id, Duration::from_secs(60), |v| {
            v["status"] != "queued" && v["status"] != "running"
        });
        assert_eq!(v["status"], "done", "{v}");
        assert_eq!(
            (&v["progress"]["done"], &v["progress"]["total"]),
            (&serde_json::json!(21), &serde_json::json!(21)),
            "friction map progress (done, total): {v}"
        );
        let list = get(&format!("{base}/api/sweeps"), None).json();
        let row = list["sweeps"]
            .as_array()
            .and_then(|l| l.iter().find(|r| r["id"] == serde_json::json!(id)))
            .cloned()
            .unwrap_or_else(|| panic!("{id} not listed: {list}"));
        assert_eq!(row["done"], serde_json::json!(21), "{row}");
        let r = get(&format!("{base}/api/sweeps/{id}/result"), None);
        assert_eq!(r.status, 200, "{}", r.text);
        let doc = r.json();
        let points: usize = doc["curves"]
            .as_array()
            .map(|c| {
                c.iter()
                    .map(|c| c["points"].as_array().map_or(0, Vec::len))
                    .sum()
            })
            .unwrap_or(0);
        assert_eq!(points, 21, "points in the stored map: {doc}");
    }

    /// 64 concurrent one-state eval requests reach the backend in far fewer calls, and each
    /// caller gets exactly the loads of its own state.
    pub fn eval_requests_are_coalesced(base: &str) {
        let bearing = serde_json::json!({"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242});
        let doc = |k: usize| {
            serde_json::json!({"bearing": bearing, "states": [
                {"xi": 1e-4, "yi": 0.5e-4 + 1e-6 * k as f64, "xj": 1e-4, "yj": 0.5e-4,
                 "vxi": 0.0, "vyi": 0.0, "vxj": 0.0, "vyj": 0.0, "omega": 100.0 + k as f64}
            ]})
        };
        // Reference: each state alone through the library function behind `eval`.
        let expected: Vec<Value> = (0..64)
            .map(|k| {
                bearing_sweep::app::eval_json(&doc(k).to_string(), Default::default())
                    .unwrap()
                    .0["loads"][0]
                    .clone()
            })
            .collect();
        let before = metric(base, "bearing_sweep_eval_backend_calls_total");
        let barrier = std::sync::Arc::new(std::sync::Barrier::new(64));
        let handles: Vec<_> = (0..64)
            .map(|k| {
                let (barrier, url, body) = (
                    barrier.clone(),
                    format!("{base}/api/eval"),
                    doc(k).to_string(),
                );
                std::thread::spawn(move || {
                    barrier.wait();
                    post(&url, body.as_bytes(), None)
                })
            })
            .collect();
        for (k, h) in handles.into_iter().enumerate() {
            let a = h.join().unwrap();
            assert_eq!(a.status, 200, "request {k}: {}", a.text);
            let loads = a.json()["loads"].clone();
            assert_eq!(loads.as_array().unwrap().len(), 1, "request {k}: {loads}");
            assert_eq!(
                loads[0], expected[k],
                "request {k}: got {}, expected {}",
                loads[0], expected[k]
            );
        }
        let calls = metric(base, "bearing_sweep_eval_backend_calls_total") - before;
        assert!(
            calls <= 16.0,
            "64 concurrent requests took {calls} backend calls (expected far fewer than 64)"
        );
        // A bad state in one request names its own path.
        let a = post(
            &format!("{base}/api/eval"),
            serde_json::json!({"bearing": bearing, "states": [{"xi": 0.0}, {"xi": "x"}]})
                .to_string()
                .as_bytes(),
            None,
        );
        assert_eq!(a.status, 422, "{}", a.text);
        assert!(
            a.json()["error"]["path"]
                .as_str()
                .unwrap()
                .starts_with("states["),
            "{}",
            a.text
        );
    }
}
