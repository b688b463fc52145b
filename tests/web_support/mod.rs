//! A thin WebDriver client (W3C WebDriver JSON over HTTP with ureq, no extra crate) for
//! driving Debian's chromium through chromedriver, and the `serve` process of the test:
//! both on 127.0.0.1 with ephemeral ports, both killed when dropped.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// The W3C key of an element reference in WebDriver answers.
const ELEMENT_KEY: &str = "element-6066-11e4-a52e-4f735466cecf";

/// An HTTP agent that hands back 4xx/5xx answers as answers (WebDriver and API errors are
/// JSON bodies the tests read), with a global timeout so nothing hangs.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(120)))
        .build()
        .into()
}

/// Reads an answer body as JSON (screenshots are a few MB of base64: no small limit).
pub fn read_json(resp: &mut ureq::http::Response<ureq::Body>) -> Result<Value, String> {
    resp.body_mut()
        .with_config()
        .limit(256 << 20)
        .read_json::<Value>()
        .map_err(|e| format!("answer is not JSON: {e}"))
}

/// The first existing file among an environment variable's value and the candidates
/// (absolute paths or names looked up on PATH).
pub fn find_program(env: &str, candidates: &[&str]) -> Option<PathBuf> {
    if let Ok(p) = std::env::var(env) {
        let p = PathBuf::from(p);
        if p.is_file() {
            return Some(p);
        }
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for c in candidates {
        let c = Path::new(c);
        if c.is_absolute() {
            if c.is_file() {
                return Some(c.to_path_buf());
            }
            continue;
        }
        for dir in std::env::split_paths(&path) {
            let p = dir.join(c);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// A port the OS handed out just now (free at this moment; the tiny race with another
/// process taking it in between is accepted for chromedriver, which cannot report one).
pub fn free_port() -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1:0");
    l.local_addr().unwrap().port()
}

/// A child process killed (and reaped) on drop.
pub struct Proc {
    pub child: Child,
    pub name: &'static str,
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `bearing-sweep serve` on an ephemeral port; `base` is `http://127.0.0.1:PORT`.
pub struct Server {
    pub base: String,
    /// None when `BEARING_SWEEP_WEB_URL` names a server already running (a development
    /// aid: point the browser tests at it instead of starting one).
    pub proc: Option<Proc>,
    /// Every line the server printed so far arrives here (stdout and stderr).
    pub lines: mpsc::Receiver<String>,
}

impl Server {
    /// Starts `serve --bind 127.0.0.1:0 --data DATA` plus `extra` and waits until it
    /// prints the address it bound and answers `/healthz`.
    pub fn start(data: &Path, extra: &[&str]) -> Server {
        if let Ok(base) = std::env::var("BEARING_SWEEP_WEB_URL") {
            let (_tx, lines) = mpsc::channel();
            return Server {
                base: base.trim_end_matches('/').to_string(),
                proc: None,
                lines,
            };
        }
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_bearing-sweep"));
        cmd.args(["serve", "--bind", "127.0.0.1:0", "--data"])
            .arg(data)
            .args(extra)
            .env_remove("BEARING_SWEEP_TOKEN")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().expect("spawn bearing-sweep serve");
        let (tx, rx) = mpsc::channel();
        for out in [
            Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
            Box::new(child.stderr.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(out).lines().map_while(Result::ok) {
                    eprintln!("[serve] {line}");
                    // After the test stops listening, keep draining the pipe.
                    let _ = tx.send(line);
                }
            });
        }
        let proc = Proc {
            child,
            name: "serve",
        };
        let deadline = Instant::now() + Duration::from_secs(60);
        let mut port = None;
        while port.is_none() {
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(line) => port = port_in(&line),
                Err(_) => panic!("serve printed no 127.0.0.1:PORT address within 60 s"),
            }
        }
        let base = format!("http://127.0.0.1:{}", port.unwrap());
        let a = agent();
        loop {
            if let Ok(r) = a.get(format!("{base}/healthz")).call() {
                if r.status().is_success() {
                    break;
                }
            }
            assert!(
                Instant::now() < deadline,
                "{base}/healthz not ready within 60 s"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        Server {
            base,
            proc: Some(proc),
            lines: rx,
        }
    }
}

/// The port of the first `127.0.0.1:PORT` in a line (PORT > 0).
pub fn port_in(line: &str) -> Option<u16> {
    let at = line.find("127.0.0.1:")? + "127.0.0.1:".len();
    let digits: String = line[at..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    digits.parse().ok().filter(|p| *p > 0)
}

/// chromedriver on an ephemeral port, with one headless chromium session.
pub struct Browser {
    agent: ureq::Agent,
    /// `http://127.0.0.1:PORT/session/ID`.
    session: String,
    _driver: Proc,
    _profile: PathBuf,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.agent.delete(&self.session).call();
        let _ = std::fs::remove_dir_all(&self._profile);
    }
}

impl Browser {
    /// Starts chromedriver and a headless chromium session at the given viewport size.
    pub fn start(
        chromium: &Path,
        chromedriver: &Path,
        profile: PathBuf,
    ) -> Result<Browser, String> {
        let port = free_port();
        let child = Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .arg("--allowed-ips=127.0.0.1")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("spawn {}: {e}", chromedriver.display()))?;
        let driver = Proc {
            child,
            name: "chromedriver",
        };
        let base = format!("http://127.0.0.1:{port}");
        let agent = agent();
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Ok(mut r) = agent.get(format!("{base}/status")).call() {
                if read_json(&mut r).is_ok_and(|v| v["value"]["ready"] == true) {
                    break;
                }
            }
            if Instant::now() > deadline {
                return Err("chromedriver not ready within 30 s".into());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        std::fs::create_dir_all(&profile).map_err(|e| e.to_string())?;
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": chromium.to_string_lossy(),
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                         "--no-first-run", "--disable-extensions", "--hide-scrollbars",
                         "--window-size=1280,800", format!("--user-data-dir={}", profile.display())]
            }
        }}});
        let mut r = agent
            .post(format!("{base}/session"))
            .send_json(&caps)
            .map_err(|e| format!("new session: {e}"))?;
        let v = read_json(&mut r)?;
        let id = v["value"]["sessionId"]
            .as_str()
            .ok_or_else(|| format!("new session refused: {v}"))?;
        Ok(Browser {
            agent,
            session: format!("{base}/session/{id}"),
            _driver: driver,
            _profile: profile,
        })
    }

    /// One WebDriver command; its `value`, or the driver's error text.
    pub fn cmd(&self, method: &str, path: &str, body: Option<Value>) -> Result<Value, String> {
        let url = format!("{}{path}", self.session);
        let resp = match (method, body) {
            ("GET", _) => self.agent.get(&url).call(),
            ("DELETE", _) => self.agent.delete(&url).call(),
            (_, b) => self.agent.post(&url).send_json(b.unwrap_or(json!({}))),
        };
        let mut resp = resp.map_err(|e| format!("{method} {path}: {e}"))?;
        let ok = resp.status().is_success();
        let v = read_json(&mut resp)?;
        if ok {
            Ok(v["value"].clone())
        } else {
            Err(format!(
                "{method} {path}: {} {}",
                v["value"]["error"], v["value"]["message"]
            ))
        }
    }

    pub fn goto(&self, url: &str) {
        self.cmd("POST", "/url", Some(json!({"url": url})))
            .expect("navigate");
    }

    /// The element reference of the first match of a CSS selector.
    pub fn find(&self, css: &str) -> Result<String, String> {
        let v = self.cmd(
            "POST",
            "/element",
            Some(json!({"using": "css selector", "value": css})),
        )?;
        v[ELEMENT_KEY]
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| format!("no element reference for {css}: {v}"))
    }

    /// How many elements match a CSS selector.
    pub fn count(&self, css: &str) -> usize {
        self.cmd(
            "POST",
            "/elements",
            Some(json!({"using": "css selector", "value": css})),
        )
        .map(|v| v.as_array().map_or(0, Vec::len))
        .unwrap_or(0)
    }

    /// Clicks the first match (scrolled into view by the driver, as a person would).
    pub fn click(&self, css: &str) {
        self.on_element(css, "click", |id| {
            self.cmd("POST", &format!("/element/{id}/click"), Some(json!({})))
        });
    }

    /// Runs a command on the first match of `css`. The page re-renders parts of itself as
    /// events arrive: a reference that went stale between finding and using is found
    /// again, a few times.
    pub fn on_element(
        &self,
        css: &str,
        what: &str,
        f: impl Fn(&str) -> Result<Value, String>,
    ) -> Value {
        let mut last = String::new();
        for _ in 0..5 {
            let id = self
                .find(css)
                .unwrap_or_else(|e| panic!("{what} {css}: {e}"));
            match f(&id) {
                Ok(v) => return v,
                Err(e) if e.contains("stale element") => last = e,
                Err(e) => panic!("{what} {css}: {e}"),
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        panic!("{what} {css}: {last}");
    }

    /// Types text into the first match (keys, as a person would).
    pub fn type_into(&self, css: &str, text: &str) {
        self.on_element(css, "type into", |id| {
            self.cmd(
                "POST",
                &format!("/element/{id}/value"),
                Some(json!({"text": text})),
            )
        });
    }

    pub fn clear(&self, css: &str) {
        self.on_element(css, "clear", |id| {
            self.cmd("POST", &format!("/element/{id}/clear"), Some(json!({})))
        });
    }

    /// The rendered text of the first match ("" when there is none).
    pub fn text(&self, css: &str) -> String {
        match self.find(css) {
            Ok(id) => self
                .cmd("GET", &format!("/element/{id}/text"), None)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
            Err(_) => String::new(),
        }
    }

    /// Runs a script in the page (`arguments[k]` are `args`); its return value.
    pub fn exec(&self, script: &str, args: Value) -> Value {
        self.cmd(
            "POST",
            "/execute/sync",
            Some(json!({"script": script, "args": args})),
        )
        .unwrap_or_else(|e| panic!("script failed: {e}\n{script}"))
    }

    /// Polls `f` every 100 ms until it gives `Some`, or panics naming `what`.
    pub fn wait<T>(&self, what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> T {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(v) = f() {
                return v;
            }
            if Instant::now() > deadline {
                panic!("timed out after {timeout:?} waiting for {what}");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Emulates a viewport of `w` x `h` CSS pixels (`mobile`: phone-style meta viewport
    /// handling and touch), via the DevTools protocol, which sets exact sizes.
    pub fn viewport(&self, w: u32, h: u32, mobile: bool) {
        self.cmd(
            "POST",
            "/goog/cdp/execute",
            Some(json!({"cmd": "Emulation.setDeviceMetricsOverride",
                        "params": {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": mobile}})),
        )
        .expect("set the viewport");
    }

    /// A PNG of the viewport, or with `full` of the whole page (the viewport's width).
    pub fn screenshot(&self, path: &Path, full: bool) {
        let b64 = if full {
            let v = self
                .cmd(
                    "POST",
                    "/goog/cdp/execute",
                    Some(json!({"cmd": "Page.captureScreenshot",
                                "params": {"format": "png", "captureBeyondViewport": true}})),
                )
                .expect("full-page screenshot");
            v["data"].as_str().unwrap_or_default().to_string()
        } else {
            self.cmd("GET", "/screenshot", None)
                .expect("screenshot")
                .as_str()
                .unwrap_or_default()
                .to_string()
        };
        let png = base64_decode(&b64).expect("screenshot is base64");
        assert!(
            png.starts_with(b"\x89PNG"),
            "screenshot is not a PNG ({} bytes)",
            png.len()
        );
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, png).unwrap();
    }
}

/// Standard base64 (RFC 4648, with padding; whitespace ignored).
pub fn base64_decode(s: &str) -> Option<Vec<u8>> {
    fn val(c: u8) -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    }
    let clean: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut acc = 0u32;
        for (k, c) in chunk.iter().enumerate() {
            acc |= val(*c)? << (18 - 6 * k);
        }
        let bytes = acc.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Some(out)
}

/// Whether browser tests must run (fail instead of skipping when chromium is missing).
pub fn browser_required() -> bool {
    std::env::var("BEARING_SWEEP_REQUIRE_BROWSER").is_ok_and(|v| v == "1")
}
