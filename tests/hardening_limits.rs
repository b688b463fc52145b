//! Issue 13 item 2: a spec's memory is estimated before anything runs; a friction map,
//! synthetic sweep or scene over the budget (2 GiB by default, `run --max-memory`) is
//! refused at once, naming the field that drives the estimate.

use std::time::Instant;

use serde_json::json;

mod cli_support;
use cli_support::*;

fn run_spec(tag: &str, spec: &serde_json::Value, extra: &[&str]) -> (bool, String) {
    let dir = scratch("hardening-limits", tag);
    let p = write(&dir, "s.json", spec);
    let out = dir.join("out");
    let mut args = vec![
        "run",
        p.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let start = Instant::now();
    let r = run(&args);
    // Refusals come before any work (the 24 GB map of the issue took minutes to die).
    if !r.0 {
        assert!(
            start.elapsed().as_secs() < 30,
            "{tag}: refusal took {:?}",
            start.elapsed()
        );
    }
    r
}

fn map(loads: u64, speeds: u64) -> serde_json::Value {
    json!({"kind": "friction_map",
           "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
           "load": {"logspace": [1, 1e4, loads]}, "speed": {"linspace": [10, 1000, speeds]}})
}

#[test]
fn friction_map_product_is_checked() {
    let (ok, err) = run_spec("map-product", &map(100_000, 100_000), &[]);
    assert!(
        !ok && err.contains("speed: a map of 100000 loads x 100000 speeds needs about"),
        "{err}"
    );
    assert!(err.contains("--max-memory"), "{err}");
    let (ok, err) = run_spec("map-axis", &map(100_000_000, 2), &[]);
    assert!(!ok && err.contains("load.logspace[2]:"), "{err}");
    // A modest map under a budget lowered below it: refused; raised again: runs.
    let (ok, err) = run_spec("map-low", &map(100, 50), &["--max-memory", "1M"]);
    assert!(
        !ok && err.contains("over the memory budget of 1 MiB"),
        "{err}"
    );
    let (ok, err) = run_spec("map-ok", &map(100, 50), &["--max-memory", "64M"]);
    assert!(ok, "{err}");
}

#[test]
fn synthetic_samples_are_capped() {
    let spec = json!({"kind": "synthetic", "base": {"samples": 1_000_000_000u64}});
    let (ok, err) = run_spec("synthetic", &spec, &[]);
    assert!(!ok && err.contains("samples: 1000000000 samples"), "{err}");
}

#[test]
fn a_scene_keeping_too_many_samples_is_refused() {
    // Samples are decimated to a cap (README "Limits"), so a long t_end alone is no
    // longer refused; what cannot fit even at the 4096-sample floor is, naming the field.
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("sweeps/paper-example.json").unwrap())
            .unwrap();
    scene["integrator"]["t_end"] = json!(1000.0);
    // Two simulations x 4096 samples x 26 numbers x 16 B = 3.4 MB > 2 MiB (each alone,
    // 1.7 MB, fits).
    let (ok, err) = run_spec("scene", &scene, &["--max-memory", "2M"]);
    assert!(
        !ok && err.contains("scenes:") && err.contains("4096 samples") && err.contains("MiB"),
        "{err}"
    );
    // The same scene swept: each variant is checked by the scene validator (one
    // simulation, 1.7 MB > 1 MiB).
    scene.as_object_mut().unwrap().remove("compare_ideal");
    let sweep = json!({"base": scene, "axes": [{"path": "rotor.mass", "values": [1.0, 2.0]}]});
    let (ok, err) = run_spec("scene-sweep", &sweep, &["--max-memory", "1M"]);
    assert!(!ok && err.contains("bearings:"), "{err}");
    let (ok, err) = run_spec("bad-flag", &scene, &["--max-memory", "lots"]);
    assert!(!ok && err.contains("--max-memory:"), "{err}");
}

/// Where [`run_spec`] ran `tag`: its output root.
fn out_of(tag: &str) -> std::path::PathBuf {
    std::env::temp_dir()
        .join(format!(
            "bearing-sweep-hardening-limits-{}-{tag}",
            std::process::id()
        ))
        .join("out")
}

/// Issue 21: the rotor simulator validates each scene within the run's memory budget, not
/// the 2 GiB default. A scene whose samples need more than 2 GiB even at the 4096-sample
/// floor (3300 bearings: 4096 samples x 33 006 numbers x 16 B = 2.16 GB) is refused by
/// default before anything runs, naming `bearings` and the budget; under `--max-memory 8G`
/// it is admitted and then simulated (its step limit of 2 ends it at once), not failed as
/// an invalid variant for the 2 GiB cap. Both as a sweep variant and as a scene file.
#[test]
fn the_simulator_checks_scenes_within_the_runs_budget() {
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("sweeps/paper-example.json").unwrap())
            .unwrap();
    scene.as_object_mut().unwrap().remove("compare_ideal");
    let pair = scene["bearings"].as_array().unwrap().clone();
    scene["bearings"] = json!((0..3300).map(|k| pair[k % 2].clone()).collect::<Vec<_>>());
    // 5001 samples at 1e-4 s over 0.5 s (more than the floor); two steps, then it stops.
    scene["integrator"]["max_steps"] = json!(2);
    let sweep = json!({"base": scene, "axes": [{"path": "rotor.mass", "values": [1.0]}]});
    let (ok, err) = run_spec("budget-default", &sweep, &["--backend", "cpu"]);
    assert!(
        !ok && err.contains("bearings: keeping 4096 samples x 3300 bearings")
            && err.contains("over the memory budget of 2.0 GiB"),
        "{err}"
    );
    let big = ["--backend", "cpu", "--max-memory", "8G"];
    let (ok, err) = run_spec("budget-8g", &sweep, &big);
    assert!(ok, "{err}");
    let result = read(&out_of("budget-8g").join("s").join("result.json"));
    let v = &result["variants"][0];
    assert_eq!(v["status"], "max_steps", "{}", v["message"]);
    // The scene file: admitted at 8G, simulated, not reported as an invalid scene.
    let (ok, err) = run_spec("budget-8g-scene", &scene, &big);
    assert!(ok, "{err}");
    let result = read(&out_of("budget-8g-scene").join("s").join("result.json"));
    let status = &result["results"][0]["status"];
    assert_eq!(status["kind"], "max_steps", "{status}");
}
