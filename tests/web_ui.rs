//! The web page of `serve` in a real browser: Debian's chromium driven through
//! chromedriver (W3C WebDriver over HTTP, `tests/web_support`). The test starts `serve` on
//! an ephemeral port, submits a small sweep through the page, waits for `done` through the
//! live progress, checks the variant table against `result.json`, opens a figure, submits
//! a bad spec and checks the inline error, uses the eval panel, and saves screenshots at
//! desktop (1280x800) and phone (390x844) widths under target/screenshots/ (or the folder
//! `BEARING_SWEEP_SCREENSHOTS` names: `reports/screenshots` refreshes the committed copies).
//!
//! Without chromium and chromedriver the browser tests skip with a notice, unless
//! `BEARING_SWEEP_REQUIRE_BROWSER=1` (set by `.ci/run`, which installs both). The asset
//! test needs no browser.

mod web_support;

use std::path::PathBuf;
use std::time::Duration;

use serde_json::{json, Value};
use web_support::{agent, browser_required, find_program, read_json, Browser, Server};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bearing-sweep-web-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// chromium and chromedriver, or None after a notice (a panic when they are required).
fn browser_tools() -> Option<(PathBuf, PathBuf)> {
    let chromium = find_program(
        "BEARING_SWEEP_CHROMIUM",
        &["chromium", "chromium-browser", "google-chrome"],
    );
    let driver = find_program("BEARING_SWEEP_CHROMEDRIVER", &["chromedriver"]);
    match (chromium, driver) {
        (Some(c), Some(d)) => Some((c, d)),
        (c, d) => {
            let msg = format!(
                "chromium ({}) and chromedriver ({}) are needed: apt-get install -y chromium chromium-driver",
                c.map_or("missing".into(), |p| p.display().to_string()),
                d.map_or("missing".into(), |p| p.display().to_string())
            );
            if browser_required() {
                panic!("BEARING_SWEEP_REQUIRE_BROWSER=1 but {msg}");
            }
            eprintln!("SKIPPED (no browser): {msg}");
            None
        }
    }
}

fn get(url: &str, token: Option<&str>) -> (u16, String) {
    let mut req = agent().get(url);
    if let Some(t) = token {
        req = req.header("Authorization", &format!("Bearer {t}"));
    }
    let mut r = req.call().unwrap_or_else(|e| panic!("GET {url}: {e}"));
    let status = r.status().as_u16();
    let ctype = r
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    let body = r
        .body_mut()
        .with_config()
        .limit(256 << 20)
        .read_to_string()
        .unwrap();
    (status, format!("{ctype}\n{body}"))
}

fn get_json(url: &str) -> (u16, Value) {
    let mut r = agent()
        .get(url)
        .call()
        .unwrap_or_else(|e| panic!("GET {url}: {e}"));
    let status = r.status().as_u16();
    (status, read_json(&mut r).unwrap_or(Value::Null))
}

fn post_json(url: &str, body: &str) -> (u16, Value) {
    let mut r = agent()
        .post(url)
        .header("Content-Type", "application/json")
        .send(body)
        .unwrap_or_else(|e| panic!("POST {url}: {e}"));
    let status = r.status().as_u16();
    (status, read_json(&mut r).unwrap_or(Value::Null))
}

/// The number of sweeps the server lists (the list may be bare or under "sweeps").
fn sweep_count(base: &str) -> usize {
    let (status, v) = get_json(&format!("{base}/api/sweeps"));
    assert_eq!(status, 200, "GET /api/sweeps: {v}");
    v.as_array()
        .or_else(|| v["sweeps"].as_array())
        .map_or(0, Vec::len)
}

/// `rel(actual, expected) <= tol`, printing both and the tolerance otherwise.
fn assert_close(what: &str, actual: f64, expected: f64, tol: f64) {
    let rel = (actual - expected).abs() / expected.abs().max(f64::MIN_POSITIVE);
    assert!(
        rel <= tol,
        "{what}: actual {actual:e}, expected {expected:e}, relative difference {rel:e} > tolerance {tol:e}"
    );
}

#[test]
fn page_assets_and_examples_are_served() {
    let data = scratch("assets");
    let server = Server::start(&data, &[]);
    let base = &server.base;
    let (s, page) = get(&format!("{base}/"), None);
    assert_eq!(s, 200);
    assert!(
        page.starts_with("text/html"),
        "GET / content type: {page:.80}"
    );
    assert!(page.contains(r#"<script src="/app.js""#) && page.contains("/style.css"));
    for (path, ctype, file) in [
        ("/app.js", "text/javascript", "src/service/web/app.js"),
        ("/style.css", "text/css", "src/service/web/style.css"),
    ] {
        let (s, body) = get(&format!("{base}{path}"), None);
        assert_eq!(s, 200, "GET {path}");
        let (got_type, got) = body.split_once('\n').unwrap();
        assert!(
            got_type.starts_with(ctype),
            "GET {path}: type {got_type}, expected {ctype}"
        );
        let want =
            std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(file)).unwrap();
        assert_eq!(got, want, "GET {path} is not the compiled-in {file}");
    }
    // Examples: every sweeps/ file listed, each served byte for byte.
    let (s, list) = get_json(&format!("{base}/api/examples"));
    assert_eq!(s, 200, "{list}");
    let list = list.as_array().expect("an array of examples").clone();
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let files = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(
        list.len(),
        files,
        "examples listed vs files in sweeps/: {list:?}"
    );
    for e in &list {
        let name = e["name"].as_str().unwrap();
        let (s, body) = get(&format!("{base}/api/examples/{name}"), None);
        assert_eq!(s, 200, "example {name}");
        let want = std::fs::read_to_string(dir.join(format!("{name}.json"))).unwrap();
        assert_eq!(body.split_once('\n').unwrap().1, want, "example {name}");
    }
    let sweep = list
        .iter()
        .find(|e| e["name"] == "clearance-viscosity")
        .unwrap();
    assert_eq!(sweep["role"], "sweep");
    // The check behind "Check spec": the submission's verdict, nothing stored.
    let good = serde_json::to_string(&small_spec()).unwrap();
    let (s, v) = post_json(&format!("{base}/api/validate"), &good);
    assert_eq!(
        (s, &v["variants"], &v["kind"]),
        (200, &json!(6), &json!("rotor")),
        "{v}"
    );
    let mut bad = small_spec();
    bad["base"]["bearings"][1]["length"] = json!(-0.02);
    let bad = serde_json::to_string(&bad).unwrap();
    let (s1, checked) = post_json(&format!("{base}/api/validate"), &bad);
    let (s2, submitted) = post_json(&format!("{base}/api/sweeps"), &bad);
    assert_eq!(
        (s1, &checked),
        (s2, &submitted),
        "validate vs submit of a bad spec"
    );
    assert_eq!(s1, 422);
    let (s, v) = post_json(&format!("{base}/api/validate?backend=abacus"), &good);
    assert_eq!((s, &v["error"]["path"]), (422, &json!("?backend")), "{v}");
    assert_eq!(sweep_count(base), 0, "validate stored a sweep");
    // The page's API routes are in the OpenAPI document (and so in CI's schemathesis pass).
    let (_, doc) = get_json(&format!("{base}/api/openapi.json"));
    for p in ["/api/examples", "/api/examples/{name}", "/api/validate"] {
        assert!(doc["paths"][p].is_object(), "openapi lacks {p}");
    }
    // An example that is not there: 404 with the JSON error shape naming the field.
    let (s, err) = get_json(&format!("{base}/api/examples/nope"));
    assert_eq!(s, 404);
    assert_eq!(err["error"]["path"], "name", "{err}");
    assert!(err["error"]["message"]
        .as_str()
        .unwrap()
        .contains("clearance-viscosity"));
}

/// A small rotor sweep: the paper rotor for 0.1 s over 3 clearances x 2 viscosities.
fn small_spec() -> Value {
    let text = include_str!("../sweeps/clearance-viscosity.json");
    let mut spec: Value = serde_json::from_str(text).unwrap();
    spec["name"] = json!("web test: clearance x viscosity");
    spec["base"]["integrator"]["t_end"] = json!(0.1);
    spec["axes"][0]["logspace"] = json!([0.0001, 0.0006, 3]);
    spec["axes"][1]["logspace"] = json!([0.005, 0.1, 2]);
    spec["reductions"]["window"] = json!({"fraction": 0.5});
    spec
}

/// Sets the editor's text by typing it (as a person pasting would: keys, then input events).
fn type_spec(b: &Browser, text: &str) {
    b.clear("#spec");
    b.type_into("#spec", text);
    let got = b.exec("return document.querySelector('#spec').value", json!([]));
    assert_eq!(
        got.as_str().unwrap(),
        text,
        "the editor holds what was typed"
    );
}

#[test]
fn page_submits_watches_and_reads_a_sweep_in_chromium() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let data = scratch("ui");
    let server = Server::start(&data, &[]);
    let base = server.base.clone();
    let b = Browser::start(&chromium, &chromedriver, data.join("profile"))
        .unwrap_or_else(|e| panic!("browser: {e}"));
    b.viewport(1280, 800, false);
    b.goto(&format!("{base}/"));
    let long = Duration::from_secs(180);
    let short = Duration::from_secs(30);

    // 1. The editor starts with an example (no "Load example" needed); pick another and
    // load it.
    b.wait("an example already in the editor", short, || {
        let v = b.exec("return document.querySelector('#spec').value", json!([]));
        v.as_str().unwrap_or("").contains("\"axes\"").then_some(())
    });
    b.wait("the example list", short, || {
        (b.count("#example option[value='clearance-viscosity']") == 1).then_some(())
    });
    b.click("#example option[value='clearance-viscosity']");
    b.click("#example-load");
    b.wait("the example in the editor", short, || {
        let v = b.exec("return document.querySelector('#spec').value", json!([]));
        v.as_str()
            .unwrap_or("")
            .contains("Paper rotor")
            .then_some(())
    });

    // 2. A bad spec: the server's error at its field, inline, and nothing stored or run.
    let before = sweep_count(&base);
    let mut bad = small_spec();
    // (not the clearance: the sweep's axis sets every bearing's clearance)
    bad["base"]["bearings"][1]["length"] = json!(-0.02);
    let bad_text = serde_json::to_string(&bad).unwrap();
    let (status, server_err) = post_json(&format!("{base}/api/sweeps"), &bad_text);
    assert_eq!(status, 422, "the API refuses the bad spec: {server_err}");
    let path = server_err["error"]["path"].as_str().unwrap().to_string();
    let message = server_err["error"]["message"].as_str().unwrap().to_string();
    assert!(
        path.contains("bearings[1].length"),
        "error path names the field: {server_err}"
    );
    type_spec(&b, &bad_text);
    // "Check spec" (nothing stored) and "Submit" both show it at the field.
    for button in ["#check", "#submit"] {
        b.exec("document.querySelector('#spec-error').hidden = true; document.querySelector('#spec-error').textContent = ''", json!([]));
        b.click(button);
        let shown = b.wait("the inline error", short, || {
            let t = b.text("#spec-error");
            (!t.is_empty()).then_some(t)
        });
        assert!(
            shown.contains(&path) && shown.contains(&message),
            "{button}: inline error {shown:?} lacks the server's path {path:?} or message {message:?}"
        );
        // The editor's cursor is put at the bad field (line of "length": -0.02).
        let caret = b.exec(
            "const t = document.querySelector('#spec'); return t.value.slice(t.selectionStart, t.selectionStart + 5)",
            json!([]),
        );
        assert_eq!(
            caret,
            json!("-0.02"),
            "{button}: the cursor is not at the bad value"
        );
    }
    let invalid = b.exec(
        "return document.querySelector('#spec').getAttribute('aria-invalid')",
        json!([]),
    );
    assert_eq!(invalid, json!("true"), "the editor is marked invalid");
    assert_eq!(sweep_count(&base), before, "a bad spec was stored");

    // Every control has a label (its own <label>, or aria-label), every button a name.
    let unlabelled = b.exec(
        "return [...document.querySelectorAll('input, select, textarea')]
            .filter(e => e.type !== 'hidden' && !(e.labels && e.labels.length) && !e.getAttribute('aria-label'))
            .map(e => e.id || e.outerHTML.slice(0, 60))
            .concat([...document.querySelectorAll('button')].filter(e => !e.textContent.trim() && !e.getAttribute('aria-label')).map(e => e.outerHTML.slice(0, 60)))",
        json!([]),
    );
    assert_eq!(unlabelled, json!([]), "controls without a label");

    // 3. Submit the small sweep; watch the live progress reach done.
    let spec = small_spec();
    type_spec(&b, &serde_json::to_string_pretty(&spec).unwrap());
    b.click("#check");
    b.wait("the check's verdict", short, || {
        b.text("#submit-status")
            .contains("6 variants")
            .then_some(())
    });
    assert_eq!(sweep_count(&base), before, "a checked spec was stored");
    b.click("#submit");
    b.wait("the error box to clear", short, || {
        b.text("#spec-error").is_empty().then_some(())
    });
    let id = b.wait("the new sweep in the queue", short, || {
        let v = b.exec(
            "const r = document.querySelector('#queue tbody tr.sel'); return r ? r.dataset.id : null",
            json!([]),
        );
        v.as_str().map(str::to_string)
    });
    let mut seen_counts = Vec::new();
    b.wait("status done through the live progress", long, || {
        let counts = b.text("#sweep-counts");
        if seen_counts.last() != Some(&counts) {
            seen_counts.push(counts);
        }
        let status = b.text("#sweep-status");
        assert!(
            !["failed", "cancelled"].contains(&status.as_str()),
            "sweep ended {status}: {}",
            b.text("#sweep-message")
        );
        (status == "done").then_some(())
    });
    let n = 6;
    b.wait("the final counts", short, || {
        b.text("#sweep-counts")
            .starts_with(&format!("{n} / {n} done"))
            .then_some(())
    });
    eprintln!("progress texts seen: {seen_counts:?}");
    // `done` came through the event stream (not only through the list's polling).
    let live = b.exec(
        "const d = document.querySelector('#detail').dataset; return [Number(d.events || 0), d.lastEvent || '']",
        json!([]),
    );
    assert_eq!(live[1], json!("status:done"), "last live event: {live}");
    assert!(live[0].as_u64().unwrap() >= 2, "live events: {live}");

    // 4. The table against result.json: row count and numbers.
    let (status, result) = get_json(&format!("{base}/api/sweeps/{id}/result"));
    assert_eq!(status, 200, "result: {result}");
    let variants = result["variants"].as_array().unwrap();
    assert_eq!(variants.len(), n);
    b.wait("one table row per variant", short, || {
        (b.count("#variants tbody tr") == n).then_some(())
    });
    for v in variants {
        let vid = v["id"].as_u64().unwrap();
        let expected = v["reductions"]["h_min"]["value_m"].as_f64().unwrap();
        let sel = format!("#variants tbody tr[data-id='{vid}'] td[data-key='h_min']");
        let cell = b.exec(
            "const c = document.querySelector(arguments[0]); return c ? [c.dataset.value, c.textContent] : null",
            json!([sel]),
        );
        let exact: f64 = cell[0].as_str().unwrap().parse().unwrap();
        assert_eq!(
            exact.to_bits(),
            expected.to_bits(),
            "variant {vid}: h_min in the table {exact:e} vs result.json {expected:e}"
        );
        // Shown in µm with 4 significant digits: within half a unit of the 4th digit.
        let shown: f64 = cell[1].as_str().unwrap().parse().unwrap();
        assert_close(
            &format!("variant {vid}: h_min shown (µm)"),
            shown,
            expected * 1e6,
            5e-4,
        );
    }
    // The spec's own figures, as `run` draws them, each shown once.
    let (_, plots) = get_json(&format!("{base}/api/sweeps/{id}/plots"));
    let plots = plots["plots"].as_array().map_or(0, Vec::len);
    assert_eq!(plots, 2, "the spec asks for two plots");
    b.wait("the server's figures", short, || {
        (b.count("#server-plots figure svg") == plots).then_some(())
    });
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(
        b.count("#server-plots figure svg"),
        plots,
        "figures shown twice"
    );
    // The CSV download is the API's CSV.
    let downloads = data.join("downloads");
    std::fs::create_dir_all(&downloads).unwrap();
    b.cmd(
        "POST",
        "/goog/cdp/execute",
        Some(json!({"cmd": "Browser.setDownloadBehavior",
                    "params": {"behavior": "allow", "downloadPath": downloads.to_string_lossy()}})),
    )
    .expect("allow downloads");
    b.click("#dl-csv");
    let csv = b.wait("the CSV download", short, || {
        let f = std::fs::read_dir(&downloads)
            .ok()?
            .flatten()
            .find(|e| e.path().extension().is_some_and(|x| x == "csv"))?;
        std::fs::read_to_string(f.path())
            .ok()
            .filter(|t| !t.is_empty())
    });
    let (s_csv, api_csv) = get(&format!("{base}/api/sweeps/{id}/variants?format=csv"), None);
    assert_eq!(s_csv, 200);
    assert_eq!(
        csv,
        api_csv.split_once('\n').unwrap().1,
        "downloaded CSV vs the API's"
    );
    assert_eq!(
        csv.lines().filter(|l| !l.starts_with('#')).count(),
        n + 1,
        "CSV: comment lines, a header and one row per variant"
    );
    let header = b.text("#variants thead th[data-key='h_min']");
    assert!(
        header.contains("µm"),
        "the h_min column names its unit: {header:?}"
    );
    // Sorting by h_min (button in the header) orders the rows by it.
    b.click("#variants thead th[data-key='h_min'] button");
    let order = b.exec(
        "return [...document.querySelectorAll('#variants tbody td[data-key=h_min]')].map(c => Number(c.dataset.value))",
        json!([]),
    );
    let order: Vec<f64> = order
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        order.windows(2).all(|w| w[0] <= w[1]),
        "not ascending: {order:?}"
    );

    // 5. A figure: the h_min map cell of variant 3 holds its value; clicking opens its orbit.
    let cell = "#map-h_min rect.cell[data-id='3']";
    b.wait("the h_min map", short, || {
        (b.count(cell) == 1).then_some(())
    });
    let map_value = b.exec(
        "return Number(document.querySelector(arguments[0]).dataset.value)",
        json!([cell]),
    );
    let v3 = variants.iter().find(|v| v["id"] == 3).unwrap();
    assert_eq!(
        map_value.as_f64().unwrap(),
        v3["reductions"]["h_min"]["value_m"].as_f64().unwrap(),
        "map cell of variant 3"
    );
    b.click(cell);
    b.wait("variant 3 in the orbit panel", short, || {
        b.text("#variant-id").starts_with("3 ").then_some(())
    });
    // The orbit is drawn at full resolution: the variant simulated again through
    // GET .../variants/3/series, not the spec's kept samples (a polygon).
    b.wait("the full-resolution orbit", long, || {
        (b.exec(
            "return document.querySelector('#orbit').dataset.full",
            json!([]),
        ) == json!("1"))
        .then_some(())
    });
    let points = b.exec(
        "const p = document.querySelector('#orbit path.series'); return p ? (p.getAttribute('d').match(/[ML]/g) || []).length : 0",
        json!([]),
    );
    let kept = v3["series"]["bearings"][0]["xi"].as_array().unwrap();
    assert!(
        kept.len() > 10,
        "the spec keeps the orbit: {} points",
        kept.len()
    );
    let (status, full) = get_json(&format!(
        "{base}/api/sweeps/{id}/variants/3/series?points=4000"
    ));
    assert_eq!(status, 200, "{full}");
    let full_xi = full["series"]["bearings"][0]["xi"].as_array().unwrap();
    assert_eq!(
        points.as_u64().unwrap() as usize,
        full_xi.len(),
        "orbit path points vs the full series"
    );
    // Every simulated sample (up to 4000), not the spec's decimation.
    assert!(
        full_xi.len() > kept.len(),
        "full resolution {} samples vs {} kept",
        full_xi.len(),
        kept.len()
    );
    // The same simulation: the kept samples' ends are the full series' ends.
    for (what, a, e) in [
        ("first", &full_xi[0], &kept[0]),
        ("last", full_xi.last().unwrap(), kept.last().unwrap()),
    ] {
        assert_close(
            &format!("variant 3 orbit, {what} xi"),
            a.as_f64().unwrap(),
            e.as_f64().unwrap(),
            1e-9,
        );
    }
    // Parameters in engineering units.
    let params = b.text("#variant-params");
    assert!(
        params.contains("µm") && params.contains("mPa·s") && !params.contains("0.000"),
        "parameters not in engineering units: {params:?}"
    );
    // Hover reads a value (after the page's smooth scroll to the orbit has settled).
    let hover_cell = "#map-h_min rect.cell[data-id='0']";
    let mut tip = String::new();
    for _ in 0..5 {
        std::thread::sleep(Duration::from_millis(800));
        b.exec(
            "document.querySelector(arguments[0]).scrollIntoView({block: 'center'})",
            json!([hover_cell]),
        );
        std::thread::sleep(Duration::from_millis(200));
        let target = b.find(hover_cell).unwrap();
        b.cmd(
            "POST",
            "/actions",
            Some(json!({"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
                "actions": [{"type": "pointerMove", "duration": 0, "origin": {"element-6066-11e4-a52e-4f735466cecf": target}, "x": 3, "y": 3}]}]})),
        )
        .expect("hover");
        tip = b.text("#tip");
        if !tip.is_empty() {
            break;
        }
    }
    assert!(tip.contains("variant 0"), "hover text {tip:?}");
    // By keyboard: a focused map cell opens its variant with Enter.
    let cell1 = "#map-h_min rect.cell[data-id='1']";
    b.exec(
        "document.querySelector(arguments[0]).focus()",
        json!([cell1]),
    );
    b.type_into(cell1, "\u{E007}");
    b.wait("variant 1 opened by keyboard", short, || {
        b.text("#variant-id").starts_with("1 ").then_some(())
    });

    // 6. The eval panel: its loads against the same request straight to the API.
    b.click("#eval-run");
    let wx = b.wait("the eval answer", short, || {
        let v = b.exec(
            "const c = document.querySelector('#eval-out tr[data-key=wx] td'); return c && c.dataset.value ? Number(c.dataset.value) : null",
            json!([]),
        );
        v.as_f64()
    });
    let input = b.exec(
        "const g = (id) => Number(document.getElementById(id).value);
         return {bearing: {radius: g('eval-b-radius'), length: g('eval-b-length'), clearance: g('eval-b-clearance'),
                 viscosity: g('eval-b-viscosity'), clearance_convention: document.getElementById('eval-b-clearance_convention').value},
                 states: [Object.fromEntries(['xi','yi','xj','yj','vxi','vyi','vxj','vyj','omega'].map(k => [k, g('eval-s-' + k)]))]}",
        json!([]),
    );
    let (status, direct) = post_json(&format!("{base}/api/eval"), &input.to_string());
    assert_eq!(status, 200, "{direct}");
    assert_close(
        "eval wx page vs API",
        wx,
        direct["loads"][0]["wx"].as_f64().unwrap(),
        1e-12,
    );
    // A bad bearing field: the error at that input.
    b.clear("#eval-b-clearance");
    b.type_into("#eval-b-clearance", "-0.0003");
    b.click("#eval-run");
    let err = b.wait("the eval error", short, || {
        let t = b.text("#eval-error");
        (!t.is_empty()).then_some(t)
    });
    assert!(err.contains("bearing.clearance"), "eval error {err:?}");
    let marked = b.exec(
        "return document.getElementById('eval-b-clearance').getAttribute('aria-invalid')",
        json!([]),
    );
    assert_eq!(marked, json!("true"));
    b.clear("#eval-b-clearance");
    b.type_into("#eval-b-clearance", "0.0003");
    b.click("#eval-run");

    // 7. Cancel a running sweep from the page: it stops, its finished variants stay readable.
    let mut long_spec = spec.clone();
    long_spec["name"] = json!("web test: cancelled");
    long_spec["base"]["integrator"]["t_end"] = json!(3.0);
    type_spec(&b, &serde_json::to_string(&long_spec).unwrap());
    b.click("#submit");
    let long_id = b.wait("the second sweep selected", short, || {
        let v = b.exec(
            "const r = document.querySelector('#queue tbody tr.sel'); return r ? r.dataset.id : null",
            json!([]),
        );
        v.as_str().filter(|s| *s != id).map(str::to_string)
    });
    b.wait("the second sweep running", long, || {
        (b.text("#sweep-status") == "running").then_some(())
    });
    b.click("#detail-cancel");
    b.wait("status cancelled", short, || {
        (b.text("#sweep-status") == "cancelled").then_some(())
    });
    let (_, info) = get_json(&format!("{base}/api/sweeps/{long_id}"));
    assert_eq!(info["status"], "cancelled", "{info}");
    let done = info["progress"]["done"].as_u64().unwrap() as usize;
    assert!(
        done < n,
        "cancelled after {done} of {n}: too late to show a cancel"
    );
    b.wait(
        "the finished variants of the cancelled sweep",
        short,
        || (b.count("#variants tbody tr") == done).then_some(()),
    );
    // A friction map (Fig. 4) straight from the example picker: one curve per speed.
    b.click("#example option[value='friction-map']");
    b.click("#example-load");
    b.wait("the friction-map example", short, || {
        let v = b.exec("return document.querySelector('#spec').value", json!([]));
        v.as_str()
            .unwrap_or("")
            .contains("friction_map")
            .then_some(())
    });
    b.click("#submit");
    b.wait("the friction map done", long, || {
        (b.text("#detail-name").starts_with("Fig. 4") && b.text("#sweep-status") == "done")
            .then_some(())
    });
    let fm_id = b.exec(
        "const r = document.querySelector('#queue tbody tr.sel'); return r ? r.dataset.id : null",
        json!([]),
    );
    let (_, fm) = get_json(&format!(
        "{base}/api/sweeps/{}/result",
        fm_id.as_str().unwrap()
    ));
    let curves = fm["curves"]
        .as_array()
        .expect("a friction map result has curves");
    let drawn = b.wait("Fig. 4 drawn", short, || {
        let v = b.exec(
            "return [...document.querySelectorAll('#fig4 path.series')].map(p => (p.getAttribute('d').match(/[ML]/g) || []).length)",
            json!([]),
        );
        let v: Vec<usize> = v.as_array()?.iter().map(|x| x.as_u64().unwrap() as usize).collect();
        (!v.is_empty()).then_some(v)
    });
    let expected: Vec<usize> = curves
        .iter()
        .map(|c| c["points"].as_array().unwrap().len())
        .collect();
    assert_eq!(
        drawn, expected,
        "Fig. 4: points per speed curve drawn vs result.json"
    );
    b.exec(
        "document.getElementById('detail-h').scrollIntoView()",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(400));
    b.screenshot(&screenshot_dir().join("desktop-fig4.png"), false);

    // Back to the finished sweep for the screenshots.
    b.click(&format!("#queue tbody tr[data-id='{id}'] button.link"));
    b.wait("the first sweep again", short, || {
        (b.count("#variants tbody tr") == n).then_some(())
    });

    // 8. Screenshots, and no sideways scrolling at phone width.
    let shots = screenshot_dir();
    b.click("#map-h_min rect.cell[data-id='3']");
    b.exec(
        "document.getElementById('detail-h').scrollIntoView()",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(600));
    b.screenshot(&shots.join("desktop.png"), false);
    b.exec(
        "document.getElementById('variant-h').scrollIntoView()",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(300));
    b.screenshot(&shots.join("desktop-orbit.png"), false);
    b.exec("window.scrollTo(0, 0)", json!([]));
    b.screenshot(&shots.join("desktop-full.png"), true);
    b.viewport(390, 844, true);
    std::thread::sleep(Duration::from_millis(600));
    // Wider content would make the phone zoom the whole page out (or scroll sideways).
    let widths = b.exec(
        "const w = document.documentElement.scrollWidth;
         const wide = [...document.querySelectorAll('body *')].filter(e => e.getBoundingClientRect().right > 391 && !e.closest('.tablewrap'))
            .slice(0, 5).map(e => e.tagName + '#' + e.id + '.' + e.className + ' ' + Math.round(e.getBoundingClientRect().right));
         return [w, wide]",
        json!([]),
    );
    let sw = widths[0].as_u64().unwrap();
    assert!(
        sw <= 390,
        "page wider than the 390 px phone: {sw} CSS px; widest: {}",
        widths[1]
    );
    b.exec(
        "document.getElementById('figures-h').scrollIntoView()",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(400));
    b.screenshot(&shots.join("phone.png"), false);
    b.exec("window.scrollTo(0, 0)", json!([]));
    b.screenshot(&shots.join("phone-full.png"), true);
    drop(b);
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
}

/// A 3-axis synthetic sweep (4 x 5 x 2 = 40 variants, seconds to run).
fn three_axis_spec() -> Value {
    let mut spec: Value =
        serde_json::from_str(include_str!("../sweeps/synthetic-whirl.json")).unwrap();
    spec["name"] = json!("web test: three axes");
    spec["axes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"path": "bearings[*].eccentricity", "values": [0.2, 0.4]}));
    spec
}

fn wait_done(base: &str, id: &str) {
    let t = std::time::Instant::now();
    loop {
        let (_, info) = get_json(&format!("{base}/api/sweeps/{id}"));
        if info["status"] == "done" {
            return;
        }
        assert!(
            t.elapsed() < Duration::from_secs(300),
            "sweep not done: {info}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Issue 23 item 5: a sweep at its own URL (a reload keeps it and the open variant), the
/// queue without sideways scrolling at 1280 px (rate, ETA and Cancel in view), zoom and
/// SVG/PNG export on every figure, legends clear of the data, and parallel coordinates
/// for a sweep with three axes.
#[test]
fn page_urls_zoom_export_and_parallel_coordinates_in_chromium() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let data = scratch("urls");
    let server = Server::start(&data, &[]);
    let base = server.base.clone();
    let short = Duration::from_secs(30);
    let (s, created) = post_json(
        &format!("{base}/api/sweeps"),
        &three_axis_spec().to_string(),
    );
    assert_eq!(s, 201, "{created}");
    let id = created["id"].as_str().unwrap().to_string();
    wait_done(&base, &id);
    let b = Browser::start(&chromium, &chromedriver, data.join("profile"))
        .unwrap_or_else(|e| panic!("browser: {e}"));
    b.viewport(1280, 800, false);

    // 1. A link to the sweep and a variant opens both; a reload keeps them.
    b.goto(&format!("{base}/#sweep={id}&variant=7"));
    for round in ["link", "reload"] {
        b.wait(&format!("{round}: the sweep from the URL"), short, || {
            b.text("#detail-name").contains(&id).then_some(())
        });
        b.wait(&format!("{round}: variant 7 from the URL"), short, || {
            b.text("#variant-id").starts_with("7 ").then_some(())
        });
        if round == "link" {
            b.exec("location.reload()", json!([]));
            std::thread::sleep(Duration::from_millis(500));
        }
    }

    // 2. Parallel coordinates: one line per variant; a click opens it and the URL follows.
    b.wait("the parallel coordinates", short, || {
        (b.count("#parallel .pc-line") == 40).then_some(())
    });
    assert_eq!(
        b.exec(
            "return document.querySelector('#parallel-fig').hidden",
            json!([])
        ),
        json!(false)
    );
    let axes_drawn = b.exec(
        "return [...document.querySelectorAll('#parallel text.label')].map(t => t.textContent)",
        json!([]),
    );
    assert_eq!(
        axes_drawn.as_array().unwrap().len(),
        4,
        "3 parameters and the quantity: {axes_drawn}"
    );
    b.exec(
        "document.querySelector('#parallel .pc-line[data-id=\"12\"]').dispatchEvent(new MouseEvent('click', {bubbles: true}))",
        json!([]),
    );
    b.wait("variant 12 from the parallel coordinates", short, || {
        b.text("#variant-id").starts_with("12 ").then_some(())
    });
    let hash = b.exec("return location.hash", json!([]));
    assert_eq!(
        hash,
        json!(format!("#sweep={id}&variant=12")),
        "the URL follows the variant"
    );

    // 3. Every figure has zoom and export; legends leave the data clear.
    let missing = b.exec(
        "return [...document.querySelectorAll('#detail figure')].filter(f => !f.hidden && f.querySelector('svg') && f.querySelector('svg').childElementCount)
            .filter(f => !f.querySelector('.figtools .export-svg') || !f.querySelector('.figtools .export-png') || !f.querySelector('.figtools .zoom-reset'))
            .map(f => f.querySelector('svg').id)",
        json!([]),
    );
    assert_eq!(missing, json!([]), "figures without zoom/export tools");
    let figures = b.count("#detail figure .figtools");
    assert!(
        figures >= 5,
        "{figures} figures with tools (maps, curves, parallel, orbit, history)"
    );
    let overlaps = b.exec(
        "const bad = [];
         for (const s of document.querySelectorAll('#detail svg')) {
           const lg = s.querySelector('rect.legend'); if (!lg) continue;
           const r = lg.getBBox();
           for (const p of s.querySelectorAll('path.series')) {
             const pts = (p.getAttribute('d').match(/-?[\\d.]+,-?[\\d.]+/g) || []).map(q => q.split(',').map(Number));
             for (let i = 0; i < pts.length; i++) {
               const [x, y] = pts[i];
               if (x >= r.x && x <= r.x + r.width && y >= r.y && y <= r.y + r.height) { bad.push(s.id + ' point ' + i); break; }
             }
           }
         }
         return bad",
        json!([]),
    );
    assert_eq!(overlaps, json!([]), "legend boxes over data points");
    // Zoom by dragging on the curves: the x axis re-ticks to the dragged range; reset.
    let ticks = |b: &Browser| {
        b.exec(
            "return [...document.querySelectorAll('#curves text.tick.x')].map(t => t.textContent).join(' ')",
            json!([]),
        )
    };
    b.exec(
        "document.getElementById('curves').scrollIntoView({block: 'center'})",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(300));
    let before = ticks(&b);
    let target = b.find("#curves").unwrap();
    let el = json!({"element-6066-11e4-a52e-4f735466cecf": target});
    b.cmd(
        "POST",
        "/actions",
        Some(json!({"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [{"type": "pointerMove", "duration": 0, "origin": el, "x": -60, "y": -40},
                        {"type": "pointerDown", "button": 0},
                        {"type": "pointerMove", "duration": 100, "origin": el, "x": 0, "y": 20},
                        {"type": "pointerMove", "duration": 100, "origin": el, "x": 40, "y": 40},
                        {"type": "pointerUp", "button": 0}]}]})),
    )
    .expect("drag");
    let zoomed = b.wait("the zoomed axis", short, || {
        let t = ticks(&b);
        (t != before).then_some(t)
    });
    eprintln!("x ticks {before:?} -> zoomed {zoomed:?}");
    b.click("#curves-fig .zoom-reset");
    assert_eq!(ticks(&b), before, "reset zoom restores the axis");
    // Export: the SVG file is the figure (styles inlined); the PNG a PNG.
    let downloads = data.join("downloads");
    std::fs::create_dir_all(&downloads).unwrap();
    b.cmd(
        "POST",
        "/goog/cdp/execute",
        Some(json!({"cmd": "Browser.setDownloadBehavior",
                    "params": {"behavior": "allow", "downloadPath": downloads.to_string_lossy()}})),
    )
    .expect("allow downloads");
    for (button, ext) in [("export-svg", "svg"), ("export-png", "png")] {
        b.click(&format!("#curves-fig .{button}"));
        let bytes = b.wait(&format!("the {ext} download"), short, || {
            let f = std::fs::read_dir(&downloads)
                .ok()?
                .flatten()
                .find(|e| e.path().extension().is_some_and(|x| x == ext))?;
            std::fs::read(f.path()).ok().filter(|t| t.len() > 100)
        });
        if ext == "svg" {
            let text = String::from_utf8(bytes).unwrap();
            assert!(
                text.contains("<svg")
                    && text.contains("<style>")
                    && text.contains("class=\"series\""),
                "exported SVG: {:.300}",
                text
            );
        } else {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "exported PNG signature");
        }
    }
    std::thread::sleep(Duration::from_millis(300));
    let shots = screenshot_dir();
    b.exec(
        "document.getElementById('parallel-fig').scrollIntoView()",
        json!([]),
    );
    std::thread::sleep(Duration::from_millis(400));
    b.screenshot(&shots.join("desktop-parallel.png"), false);

    // 4. The queue at 1280 px with a running sweep: no sideways scroll; rate, ETA and
    // Cancel in view. (t_end 60 s: ~15 s of work here; at 5 s the sweep now ends in ~1.5 s,
    // before the page shows it running.)
    let mut long = small_spec();
    long["name"] = json!("web test: a long-running sweep with a long name to cut");
    long["base"]["integrator"]["t_end"] = json!(60.0);
    let (s, running) = post_json(&format!("{base}/api/sweeps"), &long.to_string());
    assert_eq!(s, 201, "{running}");
    let rid = running["id"].as_str().unwrap().to_string();
    b.exec("window.scrollTo(0, 0)", json!([]));
    let cancel = format!("#queue tbody tr[data-id='{rid}'] button[aria-label^='cancel']");
    b.wait(
        "the running sweep's Cancel in the queue",
        Duration::from_secs(60),
        || (b.count(&cancel) == 1).then_some(()),
    );
    let fit = b.exec(
        "const w = document.documentElement;
         const wrap = document.querySelector('#queue-sec .tablewrap');
         const btn = document.querySelector(arguments[0]);
         const row = btn.closest('tr');
         return {page: w.scrollWidth, view: w.clientWidth, wrap: wrap.scrollWidth, wrapView: wrap.clientWidth,
                 cancelRight: btn.getBoundingClientRect().right, wrapRight: wrap.getBoundingClientRect().right,
                 cells: [...row.children].map(c => c.textContent)}",
        json!([cancel]),
    );
    eprintln!("queue at 1280 px: {fit}");
    assert!(
        fit["page"].as_f64() <= fit["view"].as_f64(),
        "page scrolls sideways: {fit}"
    );
    assert!(
        fit["wrap"].as_f64() <= fit["wrapView"].as_f64(),
        "queue scrolls sideways: {fit}"
    );
    assert!(
        fit["cancelRight"].as_f64() <= fit["wrapRight"].as_f64(),
        "Cancel out of view: {fit}"
    );
    b.wait("rate and ETA of the running sweep", Duration::from_secs(120), || {
        let cells = b.exec(
            "return [...document.querySelector(arguments[0]).closest('tr').children].map(c => c.textContent)",
            json!([cancel]),
        );
        let c: Vec<String> = cells.as_array()?.iter().map(|x| x.as_str().unwrap_or("").to_string()).collect();
        (c.len() == 7 && c[4].ends_with("/s") && c[5] != "—").then_some(())
    });
    b.screenshot(&shots.join("desktop-queue.png"), false);
    let _ = post_json(&format!("{base}/api/sweeps/{rid}/cancel"), "");
    drop(b);
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
}

#[test]
fn page_with_a_token_says_401_plainly_then_works() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let data = scratch("token");
    let token = "web-test-token-3f9a";
    let server = Server::start(&data, &["--token", token]);
    let base = server.base.clone();
    let (s, _) = get(&format!("{base}/api/examples"), None);
    assert_eq!(s, 401, "examples without the token");
    let (s, _) = get(&format!("{base}/api/examples"), Some(token));
    assert_eq!(s, 200, "examples with the token");
    let b = Browser::start(&chromium, &chromedriver, data.join("profile"))
        .unwrap_or_else(|e| panic!("browser: {e}"));
    b.goto(&format!("{base}/"));
    let short = Duration::from_secs(30);
    let banner = b.wait("the 401 banner", short, || {
        let t = b.text("#auth-banner");
        (!t.is_empty()).then_some(t)
    });
    assert!(
        banner.contains("401") && banner.contains("token"),
        "banner {banner:?}"
    );
    b.type_into("#token", token);
    b.click("#token-form button[type=submit]");
    b.wait("the examples after the token", short, || {
        (b.count("#example option[value='clearance-viscosity']") == 1).then_some(())
    });
    b.wait("the banner to go", short, || {
        b.text("#auth-banner").is_empty().then_some(())
    });
    let kept = b.exec(
        "return sessionStorage.getItem('bearing-sweep-token')",
        json!([]),
    );
    assert_eq!(kept, json!(token), "the token is kept in sessionStorage");
    // With the token the whole round trip works, the live events included.
    b.click("#example option[value='synthetic-whirl']");
    b.click("#example-load");
    b.wait("the synthetic example", short, || {
        let v = b.exec("return document.querySelector('#spec').value", json!([]));
        v.as_str().unwrap_or("").contains("synthetic").then_some(())
    });
    b.click("#submit");
    b.wait("the synthetic sweep done", Duration::from_secs(120), || {
        (b.text("#sweep-status") == "done").then_some(())
    });
    let live = b.exec(
        "const d = document.querySelector('#detail').dataset; return d.lastEvent || ''",
        json!([]),
    );
    assert_eq!(live, json!("status:done"), "events with the token");
    b.wait("20 rows", short, || {
        (b.count("#variants tbody tr") == 20).then_some(())
    });
    assert!(b.text("#auth-banner").is_empty(), "a 401 on the way");
    drop(b);
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
}

/// Benchmark (not run by `cargo test`; figures in BENCHMARKS.md "Web page"): how long the
/// page takes to fetch and draw a finished 2000-variant sweep (50 x 40 synthetic grid,
/// orbits kept at 50 points).
/// `cargo test --release --test web_ui -- --ignored --nocapture large_sweep`
#[test]
#[ignore]
fn bench_page_with_a_large_sweep() {
    let Some((chromium, chromedriver)) = browser_tools() else {
        return;
    };
    let data = scratch("bench");
    let server = Server::start(&data, &[]);
    let base = server.base.clone();
    let mut spec: Value =
        serde_json::from_str(include_str!("../sweeps/synthetic-whirl.json")).unwrap();
    spec["name"] = json!("bench: 50 x 40 synthetic");
    spec["axes"][0] = json!({"path": "bearings[*].whirl", "linspace": [0.0, 1e-5, 50]});
    spec["axes"][1]["linspace"] = json!([0.35, 0.55, 40]);
    spec["plots"] = json!([]);
    let (s, created) = post_json(&format!("{base}/api/sweeps"), &spec.to_string());
    assert_eq!(s, 201, "{created}");
    let id = created["id"].as_str().unwrap().to_string();
    let t = std::time::Instant::now();
    loop {
        let (_, info) = get_json(&format!("{base}/api/sweeps/{id}"));
        if info["status"] == "done" {
            break;
        }
        assert!(
            t.elapsed() < Duration::from_secs(600),
            "sweep not done: {info}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let (_, page) = get(
        &format!("{base}/api/sweeps/{id}/variants?offset=0&limit=10000"),
        None,
    );
    let b = Browser::start(&chromium, &chromedriver, data.join("profile"))
        .unwrap_or_else(|e| panic!("browser: {e}"));
    b.viewport(1280, 800, false);
    for round in 0..3 {
        b.goto(&format!("{base}/"));
        let row = format!("#queue tbody tr[data-id='{id}'] button.link");
        b.wait("the queue", Duration::from_secs(30), || {
            (b.count(&row) == 1).then_some(())
        });
        let t0 = std::time::Instant::now();
        b.click(&row);
        b.wait("2000 rows", Duration::from_secs(120), || {
            (b.count("#variants tbody tr") == 2000).then_some(())
        });
        let wall = t0.elapsed().as_secs_f64();
        let d = b.exec(
            "const d = document.querySelector('#detail').dataset; return [Number(d.loadMs), Number(d.renderMs)]",
            json!([]),
        );
        eprintln!(
            "round {round}: 2000 variants ({:.1} MB of records): fetch {} ms, draw {} ms (table, 4 maps, curves, orbit); click to table {:.2} s",
            page.len() as f64 / 1e6,
            d[0],
            d[1],
            wall
        );
    }
    drop(b);
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
}

/// Where the screenshots go: `$BEARING_SWEEP_SCREENSHOTS`, else `target/screenshots` (a
/// test run leaves the committed copies in reports/screenshots/ alone).
fn screenshot_dir() -> PathBuf {
    let dir = std::env::var_os("BEARING_SWEEP_SCREENSHOTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/screenshots"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
