//! The sweep service over HTTP on the embedded SQLite store: the API suite
//! (tests/service_support), a rotor sweep equal to `run`'s, token on and off, limits,
//! SIGKILL-restart-resume without recomputation, and SIGTERM draining.

mod service_support;

use std::time::Duration;

use serde_json::Value;
use service_support::*;

#[test]
fn api_suite_on_the_sqlite_store() {
    let dir = scratch("suite");
    let server = Server::start(&dir.join("data"), &["--eval-window-ms", "20"]);
    let base = server.url.clone();
    assert_eq!(get(&format!("{base}/healthz"), None).status, 200);
    suite::bad_input_is_refused_naming_the_field(&base);
    suite::sweep_events_result_and_csv(&base, &dir);
    suite::cancel_stops_within_a_second(&base);
    suite::eval_requests_are_coalesced(&base);
    suite::friction_map_reads_done(&base);
    // The OpenAPI document names every route.
    let doc = get(&format!("{base}/api/openapi.json"), None).json();
    for p in [
        "/api/sweeps",
        "/api/sweeps/{id}",
        "/api/sweeps/{id}/result",
        "/api/sweeps/{id}/variants",
        "/api/sweeps/{id}/events",
        "/api/sweeps/{id}/cancel",
        "/api/sweeps/{id}/plots/{name}",
        "/api/eval",
    ] {
        assert!(doc["paths"][p].is_object(), "openapi lacks {p}");
    }
    // Metrics in Prometheus text.
    let m = get(&format!("{base}/metrics"), None);
    for name in [
        "bearing_sweep_queue_length",
        "bearing_sweep_running",
        "bearing_sweep_variants_done_total",
        "bearing_sweep_variants_failed_total",
        "bearing_sweep_eval_states_per_second",
        "bearing_sweep_http_request_duration_seconds_bucket",
    ] {
        assert!(m.text.contains(name), "metrics lack {name}:\n{}", m.text);
    }
    assert!(metric(&base, "bearing_sweep_variants_done_total") >= 12.0);
}

/// The paper rotor's clearance x viscosity sweep over HTTP equals `run` (all but the
/// `run` section bit for bit), and its figures are the ones `run` draws.
#[test]
fn clearance_viscosity_over_http_equals_run() {
    let dir = scratch("cv");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    let spec_file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/clearance-viscosity.json");
    let spec: Value = serde_json::from_str(&std::fs::read_to_string(&spec_file).unwrap()).unwrap();
    let id = submit(&base, &spec, "?backend=cpu&accuracy=1e-6");
    let cli = run_cli(&spec_file, &dir.join("out"));
    let v = wait_for(&base, &id, Duration::from_secs(600), |v| {
        v["status"] != "queued" && v["status"] != "running"
    });
    assert_eq!(v["status"], "done", "{v}");
    let result = get(&format!("{base}/api/sweeps/{id}/result"), None);
    assert_eq!(result.status, 200);
    let (s, c) = (deterministic_text(&result.text), deterministic_text(&cli));
    assert!(
        s == c,
        "service result differs from run's (lengths {} and {})",
        s.len(),
        c.len()
    );
    let plots = get(&format!("{base}/api/sweeps/{id}/plots"), None).json();
    assert_eq!(
        plots["plots"],
        serde_json::json!(["friction", "h-min"]),
        "{plots}"
    );
    for name in ["h-min", "friction"] {
        let svg = get(&format!("{base}/api/sweeps/{id}/plots/{name}"), None);
        assert_eq!(svg.status, 200);
        let file = std::fs::read_to_string(
            dir.join("out/clearance-viscosity")
                .join(format!("{name}.svg")),
        )
        .unwrap();
        assert!(svg.text == file, "figure {name} differs from run's");
    }
    // Only names from the stored set: a path never reaches the filesystem.
    let a = get(
        &format!("{base}/api/sweeps/{id}/plots/..%2F..%2Fetc%2Fpasswd"),
        None,
    );
    assert_eq!(a.status, 404, "{}", a.text);
}

#[test]
fn with_a_token_every_api_route_needs_it_and_healthz_stays_open() {
    let dir = scratch("token");
    let token = "s3cret-token-for-tests";
    let server = Server::start(&dir.join("data"), &["--token", token]);
    let base = server.url.clone();
    assert_eq!(get(&format!("{base}/healthz"), None).status, 200);
    for (k, t) in [None, Some("wrong"), Some("")].iter().enumerate() {
        let a = get(&format!("{base}/api/sweeps"), *t);
        assert_eq!(a.status, 401, "case {k}: {}", a.text);
        assert!(a.json()["error"]["message"].is_string(), "case {k}");
        let a = post(&format!("{base}/api/eval"), b"{}", *t);
        assert_eq!(a.status, 401, "case {k} eval: {}", a.text);
    }
    assert_eq!(get(&format!("{base}/api/sweeps"), Some(token)).status, 200);
    // The token never appears in the server's output.
    std::thread::sleep(Duration::from_millis(200));
    assert!(!server.log.lock().unwrap().contains(token));

    // Without a token the API is open.
    let open = Server::start(&dir.join("data2"), &[]);
    assert_eq!(get(&format!("{}/api/sweeps", open.url), None).status, 200);
}

#[test]
fn a_public_bind_without_a_token_refuses_to_start_and_says_why() {
    let dir = scratch("public");
    let out = bin()
        .args(["serve", "--bind", "0.0.0.0:0", "--data"])
        .arg(dir.join("data"))
        .env_remove("BEARING_SWEEP_TOKEN")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("without a token") && err.contains("--token"),
        "{err}"
    );
}

#[test]
fn limits_answer_413_422_and_429_naming_the_flag() {
    let dir = scratch("limits");
    let server = Server::start(
        &dir.join("data"),
        &[
            "--max-body-bytes",
            "2000",
            "--max-variants",
            "50",
            "--max-queued",
            "1",
        ],
    );
    let base = server.url.clone();
    let big = vec![b' '; 5000];
    let a = post(&format!("{base}/api/sweeps"), &big, None);
    assert_eq!(a.status, 413, "{}", a.text);
    assert!(a.json()["error"]["message"]
        .as_str()
        .unwrap()
        .contains("--max-body-bytes"));
    let a = post(
        &format!("{base}/api/sweeps"),
        synthetic_spec(51, 0).to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 422, "{}", a.text);
    assert!(a.json()["error"]["message"]
        .as_str()
        .unwrap()
        .contains("--max-variants"));
    // One slow sweep fills the queue; the next is refused with 429.
    let first = submit(&base, &synthetic_spec(20, 500), "");
    let a = post(
        &format!("{base}/api/sweeps"),
        synthetic_spec(2, 0).to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 429, "{}", a.text);
    assert!(a.json()["error"]["message"]
        .as_str()
        .unwrap()
        .contains("--max-queued"));
    post(&format!("{base}/api/sweeps/{first}/cancel"), b"", None);
}

/// SIGKILL mid-sweep, restart on the same data: the sweep goes on, no committed variant
/// is computed again (`variants_computed` equals the count), and the result equals an
/// uninterrupted `run`'s.
#[test]
fn sigkill_restart_resumes_without_recomputing_finished_variants() {
    let dir = scratch("kill");
    let data = dir.join("data");
    let spec = synthetic_spec(24, 150);
    let server = Server::start(&data, &[]);
    let base = server.url.clone();
    let id = submit(&base, &spec, "");
    let v = wait_for(&base, &id, Duration::from_secs(60), |v| {
        v["progress"]["done"].as_u64().unwrap_or(0) >= 6
    });
    server.kill9();
    let before = v["progress"]["done"].as_u64().unwrap();
    let server = Server::start(&data, &[]);
    let base = server.url.clone();
    let v = wait_for(&base, &id, Duration::from_secs(120), |v| {
        v["status"] == "done"
    });
    assert_eq!(v["progress"]["done"], 24, "{v}");
    assert_eq!(
        v["variants_computed"], 24,
        "a finished variant was computed again (done {before} before the kill): {v}"
    );
    let result = get(&format!("{base}/api/sweeps/{id}/result"), None);
    let resumed = result.json()["run"]["variants_resumed"].as_u64().unwrap();
    assert!(
        resumed >= before,
        "resumed {resumed} of the {before} done before the kill"
    );
    let spec_file = dir.join("killed.json");
    std::fs::write(&spec_file, spec.to_string()).unwrap();
    let cli = run_cli(&spec_file, &dir.join("out"));
    assert!(
        deterministic_text(&result.text) == deterministic_text(&cli),
        "resumed result differs from run's"
    );
}

/// SIGTERM drains: the server exits 0 within seconds, the running sweep goes back to
/// the queue with its finished variants, and a restart completes it.
#[test]
fn sigterm_drains_and_a_restart_completes_the_sweep() {
    let dir = scratch("term");
    let data = dir.join("data");
    let server = Server::start(&data, &[]);
    let base = server.url.clone();
    let id = submit(&base, &synthetic_spec(30, 200), "");
    wait_for(&base, &id, Duration::from_secs(60), |v| {
        v["progress"]["done"].as_u64().unwrap_or(0) >= 3
    });
    let status = server
        .terminate(Duration::from_secs(10))
        .expect("exited after SIGTERM");
    assert!(status.success(), "exit status {status:?}");
    let server = Server::start(&data, &[]);
    let v = wait_for(&server.url, &id, Duration::from_secs(120), |v| {
        v["status"] == "done"
    });
    assert_eq!(v["variants_computed"], 30, "{v}");
}

/// A rotor sweep's running variants stop within about a second of a cancel (the lockstep
/// integrator polls the flag at every film call), and nothing half-done is stored.
#[test]
fn a_running_rotor_sweep_stops_within_a_second_of_cancel() {
    let dir = scratch("rotor-cancel");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    let spec_file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/clearance-viscosity.json");
    let mut spec: Value =
        serde_json::from_str(&std::fs::read_to_string(&spec_file).unwrap()).unwrap();
    // 20 s of simulated time: each variant takes far longer than the test waits.
    spec["base"]["integrator"]["t_end"] = serde_json::json!(20.0);
    let id = submit(&base, &spec, "");
    wait_for(&base, &id, Duration::from_secs(60), |v| {
        v["status"] == "running"
    });
    std::thread::sleep(Duration::from_millis(500));
    let t = std::time::Instant::now();
    assert_eq!(
        post(&format!("{base}/api/sweeps/{id}/cancel"), b"", None).status,
        200
    );
    let v = wait_for(&base, &id, Duration::from_secs(30), |v| {
        v["status"] == "cancelled"
    });
    let took = t.elapsed();
    assert!(
        took < Duration::from_millis(1500),
        "cancel took {took:?}: {v}"
    );
    let page = get(&format!("{base}/api/sweeps/{id}/variants"), None).json();
    assert_eq!(
        page["variants"].as_array().unwrap().len() as u64,
        v["progress"]["done"].as_u64().unwrap(),
        "{page}"
    );
    for rec in page["variants"].as_array().unwrap() {
        assert_ne!(
            rec["status"], "load_failure",
            "a cancelled variant was stored: {rec}"
        );
    }
}

/// `submit --wait` prints the id, then where the result is.
#[test]
fn submit_prints_the_id_and_with_wait_where_the_result_is() {
    let dir = scratch("submit");
    let server = Server::start(&dir.join("data"), &[]);
    let spec_file = dir.join("s.json");
    std::fs::write(&spec_file, synthetic_spec(5, 0).to_string()).unwrap();
    let out = bin()
        .args(["submit"])
        .arg(&spec_file)
        .args(["--server", &server.url, "--wait"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.lines().next().unwrap().trim().to_string();
    assert_eq!(id.len(), 16, "{text}");
    assert!(
        text.contains(&format!("{}/api/sweeps/{id}/result", server.url)),
        "{text}"
    );
    let v = get(&format!("{}/api/sweeps/{id}", server.url), None).json();
    assert_eq!(v["status"], "done", "{v}");
    // A bad spec: the server's path and message, non-zero exit.
    std::fs::write(
        &spec_file,
        r#"{"kind": "synthetic", "base": {}, "axse": []}"#,
    )
    .unwrap();
    let out = bin()
        .args(["submit"])
        .arg(&spec_file)
        .args(["--server", &server.url])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("axse"), "{err}");
}

/// `POST /api/coefficients` answers what `coefficients` prints for the same input (the
/// Friswell Example 5.5.1 bearing), and a bad field is a 422 naming its JSON path.
#[test]
fn coefficients_over_http_equal_the_cli() {
    let dir = scratch("coefficients");
    let server = Server::start(&dir.join("data"), &[]);
    let base = server.url.clone();
    let input = serde_json::json!({
        "bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1},
        "speed": 157.1,
        "load": [0.0, -525.0]
    });
    let file = dir.join("coefficients.json");
    std::fs::write(&file, input.to_string()).unwrap();
    let o = bin()
        .args(["coefficients", "--backend", "cpu"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cli: Value = serde_json::from_slice(&o.stdout).unwrap();
    let a = post(
        &format!("{base}/api/coefficients"),
        input.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 200, "{}", a.text);
    let http = a.json();
    for key in ["equilibrium", "order", "stiffness", "damping"] {
        assert!(cli.get(key).is_some(), "the CLI output lacks {key}");
        assert_eq!(http[key], cli[key], "{key}: HTTP vs CLI");
    }
    let mut bad = input.clone();
    bad["bearing"]["clearance"] = serde_json::json!(-1e-4);
    let a = post(
        &format!("{base}/api/coefficients"),
        bad.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 422, "{}", a.text);
    let path = a.json()["error"]["path"].as_str().unwrap_or("").to_string();
    assert!(path.contains("bearing.clearance"), "error path: {}", a.text);
}

/// Every `$ref` in `v` (recursively).
fn refs(v: &Value, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                match (k.as_str(), x) {
                    ("$ref", Value::String(r)) => out.push(r.clone()),
                    _ => refs(x, out),
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|x| refs(x, out)),
        _ => {}
    }
}

/// Issue 14: the request body of POST /api/sweeps and /api/validate is the spec's own
/// types (serde derive + utoipa), not free-form JSON: the components hold them, every
/// reference resolves, unknown fields are refused in the schema as by the parser, and
/// every example of sweeps/ uses only fields the schema names.
#[test]
fn openapi_spec_body_comes_from_the_spec_types() {
    let dir = scratch("openapi-spec");
    let server = Server::start(&dir.join("data"), &[]);
    let doc = get(&format!("{}/api/openapi.json", server.url), None).json();
    let schemas = &doc["components"]["schemas"];
    for name in [
        "SpecDocument",
        "SweepSpecDoc",
        "AxisDoc",
        "ModeDoc",
        "LatinHypercubeDoc",
        "ReductionsDoc",
        "WindowDoc",
        "WhirlDoc",
        "PlotDoc",
        "FrictionMapDoc",
        "SpecRange",
        "SpecNumbers",
    ] {
        assert!(schemas[name].is_object(), "components.schemas lacks {name}");
    }
    for route in ["/api/sweeps", "/api/validate"] {
        assert_eq!(
            doc["paths"][route]["post"]["requestBody"]["content"]["application/json"]["schema"]
                ["$ref"],
            "#/components/schemas/SpecDocument",
            "{route}"
        );
    }
    let mut all = Vec::new();
    refs(&doc, &mut all);
    for r in &all {
        let name = r.strip_prefix("#/components/schemas/").unwrap_or(r);
        assert!(schemas[name].is_object(), "unresolved reference {r}");
    }
    let fields = |schema: &str| -> Vec<String> {
        let s = &schemas[schema];
        assert_eq!(s["additionalProperties"], false, "{schema}: {s}");
        s["properties"]
            .as_object()
            .unwrap()
            .keys()
            .cloned()
            .collect()
    };
    let mut top = fields("SweepSpecDoc");
    top.sort();
    assert_eq!(
        top,
        [
            "axes",
            "base",
            "description",
            "kind",
            "mode",
            "name",
            "plots",
            "reductions"
        ]
    );
    assert_eq!(
        schemas["SweepSpecDoc"]["required"],
        serde_json::json!(["base"])
    );
    let axis = fields("AxisDoc");
    let plot = fields("PlotDoc");
    let reductions = fields("ReductionsDoc");
    let map = fields("FrictionMapDoc");
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let mut seen = 0;
    for e in std::fs::read_dir(&examples).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "json") {
            continue;
        }
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        let (own, known) = if v["kind"] == "friction_map" {
            (v.as_object().unwrap(), &map)
        } else if v.get("base").is_some() {
            (v.as_object().unwrap(), &top)
        } else {
            continue; // a scene file used as a base
        };
        seen += 1;
        for k in own.keys() {
            assert!(
                known.contains(k),
                "{}: `{k}` not in the schema",
                p.display()
            );
        }
        for a in v["axes"].as_array().into_iter().flatten() {
            for k in a.as_object().unwrap().keys() {
                assert!(axis.contains(k), "{}: axis field `{k}`", p.display());
            }
        }
        for pl in v["plots"].as_array().into_iter().flatten() {
            for k in pl.as_object().unwrap().keys() {
                assert!(plot.contains(k), "{}: plot field `{k}`", p.display());
            }
        }
        for k in v["reductions"]
            .as_object()
            .into_iter()
            .flatten()
            .map(|(k, _)| k)
        {
            assert!(reductions.contains(k), "{}: reductions `{k}`", p.display());
        }
    }
    assert!(seen >= 5, "{seen} sweep examples");
}

/// `POST /api/eval`'s body is described field by field (issue 24: the lubricant, supply
/// temperature, thermal settings, grooves and arcs are in the OpenAPI document), and a body
/// using those fields as documented is answered with the thermal balance.
#[test]
fn openapi_eval_body_names_the_bearing_fields() {
    let dir = scratch("openapi-eval");
    let server = Server::start(&dir.join("data"), &[]);
    let doc = get(&format!("{}/api/openapi.json", server.url), None).json();
    let schemas = &doc["components"]["schemas"];
    assert_eq!(
        doc["paths"]["/api/eval"]["post"]["requestBody"]["content"]["application/json"]["schema"]
            ["$ref"],
        "#/components/schemas/EvalBody"
    );
    assert_eq!(
        schemas["EvalBody"]["properties"]["bearing"]["$ref"],
        "#/components/schemas/BearingBody"
    );
    let props = schemas["BearingBody"]["properties"].as_object().unwrap();
    for f in [
        "radius",
        "length",
        "clearance",
        "viscosity",
        "lubricant",
        "supply_temperature",
        "thermal",
        "model",
        "finite",
        "grooves",
        "arcs",
        "clearance_convention",
    ] {
        assert!(props.contains_key(f), "BearingBody lacks {f}");
    }
    let mut required: Vec<String> = schemas["BearingBody"]["required"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    required.sort();
    assert_eq!(required, ["clearance", "length", "radius"]);
    // The documented fields, used together, are accepted and answered.
    let body = serde_json::json!({
        "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003,
                    "lubricant": "ISO VG 46", "supply_temperature": 40.0,
                    "thermal": {"effective_factor": 0.8},
                    "model": "finite", "finite": {"n_theta": 32, "n_z": 8},
                    "grooves": [{"angle": 90.0, "width": 20.0, "supply_pressure": 0.0},
                                {"angle": 270.0, "width": 20.0, "supply_pressure": 0.0}]},
        "states": [{"xi": 1e-4, "yi": -5e-5, "xj": 1e-4, "yj": -5e-5,
                    "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 300}]
    });
    let a = post(
        &format!("{}/api/eval", server.url),
        body.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 200, "{}", a.text);
    let out = a.json();
    let l = &out["loads"][0];
    assert_eq!(l["status"], "ok", "{out}");
    let t = &l["thermal"];
    assert!(
        t["effective_temperature_c"].as_f64().unwrap() > 40.0,
        "the film heats the oil: {t}"
    );
}
