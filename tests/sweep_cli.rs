//! The sweep command end to end on the binary, with the synthetic (analytic) simulator:
//! spec errors, a killed run resumed, shards merged equal to the unsharded run, friction
//! maps. Rotor sweeps have their own tests once the integrator is wired.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

mod cli_support;
use cli_support::*;

/// 4 x 3 x 2 = 24 variants; variant 5 fails on purpose; `cost_ms` slows each variant.
fn synthetic_spec(cost_ms: u64) -> Value {
    json!({
        "kind": "synthetic",
        "base": {"spin": 100.0, "duration": 1.0, "samples": 401, "cost_ms": cost_ms, "fail": false,
                 "bearings": [{"whirl": 0.0, "whirl_ratio": 0.45, "orbit": 5e-6},
                              {"whirl": 0.0, "whirl_ratio": 0.45, "orbit": 2e-6}]},
        "axes": [
            {"path": "bearings[*].whirl", "values": [0.0, 1e-6, 5e-6, 2e-5]},
            {"path": "bearings[0].whirl_ratio", "linspace": [0.4, 0.5, 3]},
            {"path": "spin", "logspace": [50, 200, 2]},
            {"path": "fail", "values": [false], "zip": "f"}
        ],
        "reductions": {"window": {"revolutions": 10}, "keep": ["orbit", "film"], "points": 20},
        "plots": [{"name": "whirl", "x": "bearings[0].whirl_ratio", "series": "bearings[*].whirl",
                   "y": "bearings[0].whirl.subsync_amplitude_m"}]
    })
}

#[test]
fn spec_errors_stop_before_any_computation_and_name_the_path() {
    let dir = scratch("sweep-cli", "errors");
    let cases = [
        (
            json!({"kind": "synthetic", "base": {"spin": 1.0}, "axes": [{"path": "spin", "logspace": [-1, 2, 3]}]}),
            "axes[0].logspace[0]: logspace bounds must be positive",
        ),
        (
            json!({"kind": "synthetic", "base": {"spin": 1.0}, "axse": []}),
            "axse: unknown field",
        ),
        (
            json!({"kind": "synthetic", "base": {"spin": 1.0, "duration": 1.0},
                   "axes": [{"path": "duration", "values": [1.0, -2.0]}]}),
            "variant 1 (duration = -2.0): duration: must be positive",
        ),
        (
            json!({"kind": "friction_map", "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
                   "load": [1.0], "speed": "fast"}),
            "speed: expected a list of numbers",
        ),
    ];
    for (k, (spec, expected)) in cases.iter().enumerate() {
        let p = write(&dir, &format!("bad{k}.json"), spec);
        let root = dir.join(format!("out{k}"));
        let (ok, err) = run(&[
            "run",
            p.to_str().unwrap(),
            "--out",
            root.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(!ok, "case {k}: accepted");
        assert!(
            err.contains(expected),
            "case {k}: stderr `{err}` lacks `{expected}`"
        );
        assert!(!root.exists(), "case {k}: wrote output");
    }
}

#[test]
fn shards_merged_equal_the_unsharded_run() {
    let dir = scratch("sweep-cli", "shards");
    let spec = write(&dir, "s.json", &synthetic_spec(0));
    let s = spec.to_str().unwrap();
    let root = dir.join("out");
    let r = root.to_str().unwrap();
    let full = root.join("s/result.json");
    let (ok, err) = run(&["run", s, "--out", r, "--quiet", "--batch-size", "5"]);
    assert!(ok, "{err}");
    let full_doc = read(&full);
    assert_eq!(full_doc["variants"].as_array().unwrap().len(), 24);
    let mut shard_files = Vec::new();
    for k in 0..3 {
        let out = root.join(format!("s/shard-{k}-of-3/result.json"));
        // Different batch sizes per shard: results must not depend on batching.
        let bs = ["1", "auto", "7"][k];
        let (ok, err) = run(&[
            "run",
            s,
            "--shard",
            &format!("{k}/3"),
            "--out",
            r,
            "--quiet",
            "--batch-size",
            bs,
        ]);
        assert!(ok, "shard {k}: {err}");
        let d = read(&out);
        let ids: Vec<u64> = d["variants"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v["id"].as_u64().unwrap())
            .collect();
        assert_eq!(
            ids,
            (0..24).filter(|i| i % 3 == k as u64).collect::<Vec<_>>(),
            "shard {k} ids"
        );
        shard_files.push(out.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged/result.json");
    std::fs::create_dir_all(merged.parent().unwrap()).unwrap();
    let mut args = vec!["merge", merged.to_str().unwrap()];
    // Any order.
    args.extend(shard_files.iter().rev().map(String::as_str));
    let (ok, err) = run(&args);
    assert!(ok, "{err}");
    let merged_doc = read(&merged);
    for r in [&full, &merged] {
        let svg = std::fs::read_to_string(r.parent().unwrap().join("whirl.svg")).unwrap();
        assert!(
            svg.contains("whirl = 20 µm"),
            "{}: legend missing",
            r.display()
        );
    }
    assert!(
        !root.join("s/shard-0-of-3/whirl.svg").exists(),
        "a shard wrote a plot"
    );
    // The merged figure is the unsharded run's, byte for byte (one figure path: issue 21).
    let figure = |r: &std::path::Path| {
        std::fs::read_to_string(r.parent().unwrap().join("whirl.svg")).unwrap()
    };
    assert!(
        figure(&merged) == figure(&full),
        "merged whirl.svg differs from the unsharded run's"
    );
    assert_eq!(
        deterministic(merged_doc.clone()),
        deterministic(full_doc.clone())
    );
    // Byte-identical deterministic parts (floats survive the JSON round trips exactly).
    assert_eq!(
        serde_json::to_string(&deterministic(merged_doc)).unwrap(),
        serde_json::to_string(&deterministic(full_doc)).unwrap()
    );
    // A missing shard is an error naming the missing variants.
    let (ok, err) = run(&[
        "merge",
        dir.join("m2.json").to_str().unwrap(),
        &shard_files[0],
        &shard_files[1],
    ]);
    assert!(!ok && err.contains("variants missing"), "{err}");
}

#[test]
fn a_killed_run_resumes_without_losing_finished_variants() {
    let dir = scratch("sweep-cli", "resume");
    // Reference: uninterrupted.
    let fast = write(&dir, "fast.json", &synthetic_spec(0));
    let root = dir.join("out");
    let r = root.to_str().unwrap();
    let reference = root.join("fast/result.json");
    let (ok, err) = run(&["run", fast.to_str().unwrap(), "--out", r, "--quiet"]);
    assert!(ok, "{err}");
    // The same sweep, slowed to 40 ms a variant, killed after some variants streamed.
    // `cost_ms` changes the spec (not the signals): compare the variants themselves.
    let slow = write(&dir, "slow.json", &synthetic_spec(40));
    let out = root.join("slow/result.json");
    let stream = out.with_extension("jsonl");
    let mut child = bin()
        .args([
            "run",
            slow.to_str().unwrap(),
            "--out",
            r,
            "--batch-size",
            "4",
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let lines = |p: &Path| {
        std::fs::read_to_string(p)
            .map(|s| s.lines().count())
            .unwrap_or(0)
    };
    // Header + at least 6 variants.
    while lines(&stream) < 7 {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no progress in 60 s"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // Complete variant lines (a kill in mid-write may leave a torn one, which resume drops).
    let text = std::fs::read_to_string(&stream).unwrap();
    let before = text
        .split_inclusive('\n')
        .filter(|l| l.ends_with('\n') && serde_json::from_str::<Value>(l).is_ok())
        .count()
        - 1;
    assert!(
        before < 24,
        "the run finished before the kill ({before} variants)"
    );
    assert!(!out.exists(), "a result was written by the killed run");
    // A torn last line (a kill in mid-write) is tolerated and dropped.
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&stream)
        .unwrap();
    f.write_all(b"{\"id\": 23, \"params\": {\"spin\"").unwrap();
    drop(f);
    let (ok, err) = run(&[
        "run",
        slow.to_str().unwrap(),
        "--out",
        r,
        "--quiet",
        "--batch-size",
        "4",
    ]);
    assert!(ok, "{err}");
    assert!(err.contains(&format!("resuming: {before} of 24")), "{err}");
    let resumed = read(&out);
    assert_eq!(resumed["run"]["variants_resumed"], json!(before));
    assert_eq!(resumed["run"]["variants_run"], json!(24 - before));
    let reference = read(&reference);
    assert_eq!(resumed["variants"], reference["variants"]);
    // Every id once, in order.
    let ids: Vec<u64> = resumed["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, (0..24).collect::<Vec<_>>());
    // A third run has nothing to do and writes the same result.
    let (ok, err) = run(&["run", slow.to_str().unwrap(), "--out", r, "--quiet"]);
    assert!(ok, "{err}");
    assert!(err.contains("24 resumed, 0 run"), "{err}");
    assert_eq!(deterministic(read(&out)), deterministic(resumed));
    // Another spec on the same output is refused.
    let other_dir = dir.join("other");
    std::fs::create_dir_all(&other_dir).unwrap();
    let other = write(&other_dir, "slow.json", &synthetic_spec(1));
    let (ok, err) = run(&["run", other.to_str().unwrap(), "--out", r, "--quiet"]);
    assert!(!ok && err.contains("different spec"), "{err}");
}

#[test]
fn failing_variants_get_a_status_and_the_batch_goes_on() {
    let dir = scratch("sweep-cli", "fail");
    let mut spec = synthetic_spec(0);
    spec["axes"][3] = json!({"path": "fail", "values": [false, true]});
    // A whirl that reaches the wall (at t = 0, where every term peaks): film breakdown.
    spec["axes"][0] = json!({"path": "bearings[*].whirl", "values": [0.0, 2.5e-4]});
    let p = write(&dir, "f.json", &spec);
    let root = dir.join("out");
    let out = root.join("f/result.json");
    let (ok, err) = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let d = read(&out);
    for v in d["variants"].as_array().unwrap() {
        let fail = v["params"]["fail"].as_bool().unwrap();
        let whirl = v["params"]["bearings[*].whirl"].as_f64().unwrap();
        let expected = if fail {
            "failed"
        } else if whirl > 0.0 {
            "film_breakdown"
        } else {
            "ok"
        };
        assert_eq!(v["status"], json!(expected), "variant {}", v["id"]);
        if expected != "ok" {
            assert!(v["message"].is_string(), "variant {}: no message", v["id"]);
        }
    }
}

#[test]
fn friction_map_runs_no_integrator_and_plots() {
    let dir = scratch("sweep-cli", "fmap");
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/friction-map.json");
    let root = dir.join("out");
    let out = root.join("friction-map/result.json");
    let (ok, err) = run(&[
        "run",
        spec.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("no integrator was run"), "{err}");
    let d = read(&out);
    assert_eq!(d["curves"].as_array().unwrap().len(), 5);
    // At 100 rad/s: S = (W / 2r0B) φ² / (μω) with φ = δ/2r0 = 0.0075; f = 3φ/S below
    // S = 1 (slope −1 on log axes), 3φ/√S above (slope −1/2).
    let c = d["curves"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["speed_rad_s"] == json!(100.0))
        .unwrap();
    let pts = c["points"].as_array().unwrap();
    let phi: f64 = 0.0075;
    for p in [&pts[0], &pts[pts.len() - 1]] {
        let w = p["load_n"].as_f64().unwrap();
        let s = w / (2.0 * 0.02 * 0.02) * phi * phi / (0.0242 * 100.0);
        let f = if s < 1.0 {
            3.0 * phi / s
        } else {
            3.0 * phi / s.sqrt()
        };
        let got = p["friction_coefficient"].as_f64().unwrap();
        assert!(
            (got / f - 1.0).abs() < 1e-12,
            "load {w} N: f = {got}, expected {f} (rtol 1e-12)"
        );
    }
    let svg = std::fs::read_to_string(root.join("friction-map/friction-map.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.matches("<polyline").count() >= 5);
}
