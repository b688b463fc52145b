//! Every shipped example works (issue 23 item 1): each file of `sweeps/` runs end to end
//! through the command line at reduced size, and every example the web page lists
//! (`GET /api/examples`) passes the page's "Check spec" (`POST /api/validate`, the full
//! file) and runs on the service (reduced) or, for the eval example, answers
//! `POST /api/eval`.
//!
//! Reduced size, so the whole file runs in about a minute on 2 cores: a copy of each file
//! with every simulated time capped at [`T_END_S`] (`integrator.t_end` of scenes and bases,
//! and the values of a `t_end` axis), grid axes cut to their first [`GRID_VALUES`] values
//! (ranges to [`GRID_VALUES`] points between the same ends) and friction-map loads to
//! [`MAP_LOADS`] points. Zipped sweeps (`sweeps/stress.json`) keep every variant: each is
//! a documented edge case. Everything else in the files is run as written.

mod service_support;

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::{json, Value};
use service_support::{bin, get, post, scratch, submit, wait_for, Server};

/// Longest simulated time of a reduced example, s (the paper's run is 0.5 s).
const T_END_S: f64 = 0.02;
/// Values kept per grid axis.
const GRID_VALUES: usize = 3;
/// Loads of a reduced friction map.
const MAP_LOADS: usize = 9;

fn sweeps_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps")
}

/// Every `sweeps/*.json`, sorted: (stem, document).
fn example_files() -> Vec<(String, Value)> {
    let mut out: Vec<(String, Value)> = std::fs::read_dir(sweeps_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let doc = serde_json::from_str(&text)
                .unwrap_or_else(|e| panic!("{} is not JSON: {e}", p.display()));
            (p.file_stem().unwrap().to_str().unwrap().to_string(), doc)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

fn role(doc: &Value) -> &'static str {
    if doc.get("base").is_some() || doc.get("kind").is_some() {
        "sweep"
    } else if doc.get("states").is_some() {
        "eval"
    } else {
        "scene"
    }
}

fn cap_t_end(scene: &mut Value) {
    if let Some(t) = scene
        .pointer_mut("/integrator/t_end")
        .filter(|t| t.as_f64().is_some_and(|x| x > T_END_S))
    {
        *t = json!(T_END_S);
    }
}

/// The reduced copy of an example (see the module doc).
fn reduce(doc: &Value) -> Value {
    let mut d = doc.clone();
    match role(doc) {
        "scene" => match d.get_mut("scenes").and_then(Value::as_array_mut) {
            Some(list) => list.iter_mut().for_each(cap_t_end),
            None => cap_t_end(&mut d),
        },
        "sweep" if doc["kind"] == "friction_map" => {
            if let Some(r) = d["load"].as_object_mut() {
                for key in ["linspace", "logspace"] {
                    if let Some(a) = r.get_mut(key) {
                        a[2] = json!(MAP_LOADS);
                    }
                }
            }
        }
        "sweep" => {
            if let Some(base) = d.get_mut("base").filter(|b| b.is_object()) {
                cap_t_end(base);
            }
            let zip = d["mode"] == "zip";
            for axis in d["axes"].as_array_mut().into_iter().flatten() {
                if axis["path"] == "integrator.t_end" {
                    for v in axis["values"].as_array_mut().into_iter().flatten() {
                        if v.as_f64().is_some_and(|x| x > T_END_S) {
                            *v = json!(T_END_S);
                        }
                    }
                }
                if zip || axis.get("zip").is_some() {
                    continue;
                }
                if let Some(v) = axis.get_mut("values").and_then(Value::as_array_mut) {
                    v.truncate(GRID_VALUES);
                }
                for key in ["linspace", "logspace"] {
                    if let Some(r) = axis.get_mut(key) {
                        if r[2].as_u64().is_some_and(|n| n > GRID_VALUES as u64) {
                            r[2] = json!(GRID_VALUES);
                        }
                    }
                }
            }
        }
        _ => {}
    }
    d
}

/// Variants of a reduced rotor/synthetic/stability spec: product of the grid axes, or the
/// common length of zipped ones.
fn expected_variants(spec: &Value) -> u64 {
    let len = |a: &Value| -> u64 {
        a["values"]
            .as_array()
            .map(|v| v.len() as u64)
            .or_else(|| a["linspace"][2].as_u64())
            .or_else(|| a["logspace"][2].as_u64())
            .unwrap()
    };
    let axes = spec["axes"].as_array().cloned().unwrap_or_default();
    if spec["mode"] == "zip" {
        axes.first().map_or(1, len)
    } else {
        axes.iter().map(len).product()
    }
}

/// Runs `bearing-sweep ARGS` and returns stdout; panics with stderr on failure.
fn cli(args: &[&str]) -> (String, String) {
    let out = bin()
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(
        out.status.success(),
        "bearing-sweep {args:?} failed ({}):\n{stderr}",
        out.status
    );
    (stdout, stderr)
}

fn read(p: &Path) -> Value {
    let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap()
}

/// The key set of `schema` covers every key of `v`, recursively (arrays by their first
/// element), so a plot's `y` check knows every field a variant writes.
fn keys_covered(at: &str, v: &Value, schema: &Value) {
    match (v, schema) {
        (Value::Object(m), Value::Object(s)) => {
            for (k, x) in m {
                let sub = s.get(k).unwrap_or_else(|| {
                    panic!("{at}.{k}: written by a variant, missing from the schema")
                });
                keys_covered(&format!("{at}.{k}"), x, sub);
            }
        }
        (Value::Array(a), Value::Array(s)) => {
            if let (Some(x), Some(sub)) = (a.first(), s.first()) {
                keys_covered(&format!("{at}[0]"), x, sub);
            }
        }
        (Value::Null, _) => {}
        (x, s) => assert_eq!(
            x.is_number(),
            s.is_number(),
            "{at}: {x} in a variant, {s} in the schema"
        ),
    }
}

#[test]
fn every_file_in_sweeps_runs_end_to_end_at_reduced_size() {
    let dir = scratch("examples-cli");
    let files = example_files();
    assert!(files.len() >= 10, "{} example files", files.len());
    for (stem, doc) in &files {
        let small = reduce(doc);
        let file = dir.join(format!("{stem}.json"));
        std::fs::write(&file, serde_json::to_string_pretty(&small).unwrap()).unwrap();
        let f = file.to_str().unwrap();
        let out = dir.join("out");
        let o = out.to_str().unwrap();
        let folder = out.join(stem);
        match role(doc) {
            "eval" => {
                let (stdout, _) = cli(&["eval", f, "--backend", "cpu"]);
                let v: Value = serde_json::from_str(&stdout).unwrap();
                let loads = v["loads"].as_array().unwrap();
                assert_eq!(
                    loads.len(),
                    doc["states"].as_array().unwrap().len(),
                    "{stem}"
                );
                // The example shows bad states too: each has a documented status and an
                // error naming its index; the others are ok.
                for (k, l) in loads.iter().enumerate() {
                    let status = l["status"].as_str().unwrap_or("");
                    assert!(
                        status == "ok"
                            || [
                                "through_wall",
                                "non_finite_input",
                                "overflow",
                                "invalid_bearing"
                            ]
                            .contains(&status)
                                && l["error"]
                                    .as_str()
                                    .is_some_and(|e| e.starts_with(&format!("states[{k}]"))),
                        "{stem}: state {k}: {l}"
                    );
                }
                assert!(loads.iter().any(|l| l["status"] == "ok"), "{stem}");
            }
            "scene" => {
                cli(&["run", f, "--out", o, "--backend", "cpu"]);
                let r = read(&folder.join("result.json"));
                let results = r["results"].as_array().unwrap();
                let scenes = doc["scenes"].as_array().map_or(1, Vec::len)
                    * if doc["compare_ideal"] == true { 2 } else { 1 };
                assert_eq!(results.len(), scenes, "{stem}");
                for res in results {
                    assert_eq!(res["status"]["kind"], "finished", "{stem}: {}", res["name"]);
                }
                for fig in ["fig7-g-trajectory.svg", "fig8-x-g.svg", "fig9-y-g.svg"] {
                    assert!(folder.join(fig).is_file(), "{stem}: no {fig}");
                }
            }
            _ if doc["kind"] == "friction_map" => {
                cli(&["run", f, "--out", o, "--backend", "cpu", "--quiet"]);
                let r = read(&folder.join("result.json"));
                let curves = r["curves"].as_array().expect("curves");
                assert_eq!(
                    curves.len(),
                    doc["speed"].as_array().unwrap().len(),
                    "{stem}"
                );
                assert!(
                    folder.join("friction-map.svg").is_file(),
                    "{stem}: no figure"
                );
            }
            _ => {
                let (_, stderr) = cli(&["run", f, "--out", o, "--backend", "cpu", "--quiet"]);
                assert!(!stderr.contains("no plot"), "{stem}: {stderr}");
                let r = read(&folder.join("result.json"));
                let want = expected_variants(&small);
                assert_eq!(r["count"].as_u64(), Some(want), "{stem}: variant count");
                let variants = r["variants"].as_array().unwrap();
                assert_eq!(variants.len() as u64, want, "{stem}");
                for v in variants {
                    assert!(v["status"].is_string(), "{stem}: variant {}", v["id"]);
                }
                for plot in doc["plots"].as_array().into_iter().flatten() {
                    let name = plot["name"].as_str().unwrap();
                    let svg = folder.join(format!("{name}.svg"));
                    let text = std::fs::read_to_string(&svg)
                        .unwrap_or_else(|e| panic!("{stem}: plot {name}: {e}"));
                    assert!(text.contains("<svg"), "{stem}: {name}.svg");
                }
                if doc["kind"] == "stability" {
                    // The schema a plot's `y` is checked against knows every field.
                    let schema = bearing_sweep::sweep::stability_sim::reductions_schema();
                    for v in variants.iter().filter(|v| v["status"] == "ok") {
                        keys_covered("reductions", &v["reductions"], &schema);
                    }
                    assert!(
                        variants
                            .iter()
                            .any(|v| v["reductions"]["threshold_speed_rad_s"].is_number()),
                        "{stem}: no threshold speed in any variant"
                    );
                }
                assert!(
                    !folder.join("result.lock").exists(),
                    "{stem}: result.lock left in a finished folder"
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_example_the_page_lists_validates_and_runs_on_the_service() {
    let dir = scratch("examples-page");
    let server = Server::start(&dir.join("data"), &[]);
    let base = &server.url;
    let list = get(&format!("{base}/api/examples"), None).json();
    let list = list.as_array().expect("a list of examples");
    let files: std::collections::BTreeMap<String, Value> = example_files().into_iter().collect();
    let mut sweeps = Vec::new();
    for ex in list {
        let name = ex["name"].as_str().unwrap();
        let text = get(&format!("{base}/api/examples/{name}"), None);
        assert_eq!(text.status, 200, "{name}");
        let doc = text.json();
        assert_eq!(
            Some(&doc),
            files.get(name),
            "{name}: not the file in sweeps/"
        );
        match ex["role"].as_str().unwrap() {
            "sweep" => {
                // The page's "Check spec" on the file as offered.
                let a = post(&format!("{base}/api/validate"), text.text.as_bytes(), None);
                assert_eq!(a.status, 200, "{name}: Check spec refused it: {}", a.text);
                assert_eq!(a.json()["valid"], true, "{name}");
                let id = submit(base, &reduce(&doc), "?backend=cpu");
                sweeps.push((name.to_string(), id, doc));
            }
            "eval" => {
                let a = post(&format!("{base}/api/eval"), text.text.as_bytes(), None);
                assert_eq!(a.status, 200, "{name}: {}", a.text);
                let n = a.json()["loads"].as_array().map_or(0, Vec::len);
                assert_eq!(n, doc["states"].as_array().unwrap().len(), "{name}");
            }
            _ => {} // scenes are not offered by the page (they run with `run`, above)
        }
    }
    assert!(sweeps.len() >= 6, "{} sweeps listed", sweeps.len());
    for (name, id, doc) in &sweeps {
        let v = wait_for(base, id, Duration::from_secs(300), |v| {
            !matches!(v["status"].as_str(), Some("queued" | "running"))
        });
        assert_eq!(v["status"], "done", "{name}: {v}");
        let r = get(&format!("{base}/api/sweeps/{id}/result"), None);
        assert_eq!(r.status, 200, "{name}: {}", r.text);
        if doc["kind"] != "friction_map" {
            let want = expected_variants(&reduce(doc));
            assert_eq!(
                r.json()["variants"].as_array().map(Vec::len),
                Some(want as usize),
                "{name}"
            );
        }
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}
