//! Rotor sweeps end to end: the paper rotor over clearance x viscosity through the real
//! integrator. A killed run resumed equals an uninterrupted one; shards merged equal the
//! unsharded run; spec and scene errors name JSON paths before anything runs; GPU and CPU
//! sweeps agree (skipped without a GPU backend unless BEARING_SWEEP_REQUIRE_GPU=1).

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::sweep::parse_spec;
use bearing_sweep::sweep::rotor_sim::{validate_scene, RotorSimulator};
use bearing_sweep::sweep::runner::{run_sweep, RunOptions, RunnerOptions};
use serde_json::{json, Value};

mod cli_support;
use cli_support::*;

/// The paper rotor (MODEL.md section 8) for `t_end` s, over `n_c` clearances x 2
/// viscosities.
fn spec(t_end: f64, n_c: usize) -> Value {
    json!({
        "kind": "rotor",
        "base": {
            "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
            "bearings": [
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}
            ],
            "initial": {"spin": 100.0},
            "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": t_end, "sample_interval": 1e-3}
        },
        "axes": [
            {"path": "bearings[*].clearance", "linspace": [2e-4, 4e-4, n_c]},
            {"path": "bearings[*].viscosity", "values": [0.0242, 0.05]}
        ],
        "reductions": {"window": {"fraction": 0.5}, "keep": ["orbit"], "points": 20}
    })
}

#[test]
fn rotor_sweep_reductions_are_physical() {
    let dir = scratch("sweep-rotor", "physical");
    // 0.4 s (6.4 revolutions): the last 3 revolutions are past most of the start-up.
    let mut sp = spec(0.4, 3);
    sp["reductions"]["window"] = json!({"revolutions": 3});
    let p = write(&dir, "cv.json", &sp);
    let root = dir.join("out");
    let (ok, err) = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let d = read(&root.join("cv/result.json"));
    assert_eq!(d["settings"]["simulator"], json!("rotor"));
    for v in d["variants"].as_array().unwrap() {
        let id = &v["id"];
        assert_eq!(v["status"], json!("ok"), "variant {id}: {}", v["message"]);
        let c = v["params"]["bearings[*].clearance"].as_f64().unwrap();
        let r = &v["reductions"];
        let h = r["h_min"]["value_m"].as_f64().unwrap();
        assert!(
            h > 0.0 && h < c,
            "variant {id}: h_min {h} outside (0, clearance {c})"
        );
        for (k, b) in r["bearings"].as_array().unwrap().iter().enumerate() {
            let e = b["eccentricity_max"]["value"].as_f64().unwrap();
            let hb = b["h_min_m"]["value"].as_f64().unwrap();
            // h_min = δ (1 − ε_max) at the same instant (MODEL.md section 7).
            assert!(
                (hb - c * (1.0 - e)).abs() < 1e-12,
                "variant {id} bearing {k}: h_min {hb} vs δ(1 − ε) {} (tol 1e-12 m)",
                c * (1.0 - e)
            );
            // Power loss = mean |M_z ω| and friction torque = mean |M_z|: at a nearly
            // constant spin of ~100 rad/s their ratio is the spin.
            let pw = b["power_loss_w"].as_f64().unwrap();
            let tq = b["friction_torque_nm"]["mean"].as_f64().unwrap();
            assert!(
                (pw / tq - 100.0).abs() < 1.0,
                "variant {id} bearing {k}: power / torque = {} rad/s, expected ~100 (tol 1)",
                pw / tq
            );
        }
        // Unbalance response: synchronous forward whirl.
        let wr = r["whirl_ratio"].as_f64().unwrap();
        assert!(
            (wr - 1.0).abs() < 0.05,
            "variant {id}: whirl ratio {wr}, expected ~1 (tol 0.05)"
        );
        assert_eq!(r["oil_whirl"], json!(false), "variant {id}");
        assert_eq!(
            v["series"]["t"].as_array().unwrap().len(),
            20,
            "variant {id}"
        );
    }
}

#[test]
fn rotor_scene_errors_name_the_json_path_before_running() {
    let dir = scratch("sweep-rotor", "errors");
    let mut bad = spec(0.1, 2);
    bad["axes"][0] = json!({"path": "bearings[*].clearance", "values": [3e-4, 0.03]});
    let p = write(&dir, "bad.json", &bad);
    let root = dir.join("out");
    let (ok, err) = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains("variant 2 (bearings[*].clearance = 0.03, bearings[*].viscosity = 0.0242): bearings[0].clearance: must be smaller than the journal radius"),
        "{err}"
    );
    assert!(!root.exists(), "output written before the error");
    // A wrong type from an axis (serde cannot say where): the axis's path is named.
    let mut wrong = spec(0.1, 2);
    wrong["axes"][1] = json!({"path": "bearings[*].viscosity", "values": [0.0242, "thick"]});
    let p = write(&dir, "wrong.json", &wrong);
    let (ok, err) = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains("variant 1 (bearings[*].clearance = 0.0002, bearings[*].viscosity = \"thick\"): bearings[0].viscosity: invalid type"),
        "{err}"
    );
    let mut typo = spec(0.1, 2);
    typo["base"]["bearings"][1]["viscosty"] = json!(0.03);
    let p = write(&dir, "typo.json", &typo);
    let (ok, err) = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(err.contains("bearings[1].viscosty: unknown field"), "{err}");
}

#[test]
fn rotor_shards_merged_equal_the_unsharded_run() {
    let dir = scratch("sweep-rotor", "shards");
    let p = write(&dir, "cv.json", &spec(0.05, 3));
    let s = p.to_str().unwrap();
    let root = dir.join("out");
    let r = root.to_str().unwrap();
    let (ok, err) = run(&["run", s, "--out", r, "--quiet", "--batch-size", "6"]);
    assert!(ok, "{err}");
    let mut shards = Vec::new();
    for k in 0..2 {
        let (ok, err) = run(&[
            "run",
            s,
            "--out",
            r,
            "--quiet",
            "--shard",
            &format!("{k}/2"),
            "--batch-size",
            "2",
        ]);
        assert!(ok, "shard {k}: {err}");
        shards.push(root.join(format!("cv/shard-{k}-of-2/result.json")));
    }
    let merged = dir.join("merged.json");
    let (ok, err) = run(&[
        "merge",
        merged.to_str().unwrap(),
        shards[0].to_str().unwrap(),
        shards[1].to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert_eq!(
        serde_json::to_string(&deterministic(read(&merged))).unwrap(),
        serde_json::to_string(&deterministic(read(&root.join("cv/result.json")))).unwrap(),
        "merged shards differ from the unsharded run"
    );
}

#[test]
fn a_killed_rotor_sweep_resumes_to_the_uninterrupted_result() {
    let dir = scratch("sweep-rotor", "resume");
    let p = write(&dir, "cv.json", &spec(0.05, 8));
    let s = p.to_str().unwrap();
    let reference_root = dir.join("reference");
    let (ok, err) = run(&[
        "run",
        s,
        "--out",
        reference_root.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let root = dir.join("out");
    let stream = root.join("cv/result.jsonl");
    // One variant per batch so variants stream one by one; kill after 3 have.
    let mut child = bin()
        .args([
            "run",
            s,
            "--out",
            root.to_str().unwrap(),
            "--batch-size",
            "1",
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let complete = |p: &Path| {
        std::fs::read_to_string(p)
            .map(|t| {
                t.split_inclusive('\n')
                    .filter(|l| l.ends_with('\n') && serde_json::from_str::<Value>(l).is_ok())
                    .count()
            })
            .unwrap_or(0)
    };
    while complete(&stream) < 4 {
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("no progress in 120 s");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = complete(&stream) - 1;
    let result = root.join("cv/result.json");
    if before == 16 {
        // The machine finished the whole sweep between two polls: nothing was
        // interrupted (resume is still covered by the synthetic-sweep test).
        eprintln!("note: the sweep finished before the kill");
    } else {
        assert!(!result.exists(), "the killed run wrote a result");
    }
    let (ok, err) = run(&[
        "run",
        s,
        "--out",
        root.to_str().unwrap(),
        "--quiet",
        "--batch-size",
        "5",
    ]);
    assert!(ok, "{err}");
    let resumed = read(&result);
    assert_eq!(resumed["run"]["variants_resumed"], json!(before), "{err}");
    assert_eq!(
        serde_json::to_string(&deterministic(resumed)).unwrap(),
        serde_json::to_string(&deterministic(read(&reference_root.join("cv/result.json"))))
            .unwrap(),
        "resumed result differs from the uninterrupted run"
    );
}

#[test]
fn gpu_and_cpu_sweeps_agree() {
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let accuracy = Accuracy::new(1e-6).unwrap();
    let gpu = match create_backend(BackendKind::Gpu, accuracy) {
        Ok((b, _)) => b,
        Err(e) => {
            assert!(
                !require,
                "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
            );
            eprintln!("skipped: no GPU backend ({e})");
            return;
        }
    };
    let dir = scratch("sweep-rotor", "gpu");
    let spec = parse_spec(&spec(0.1, 2), None).unwrap();
    let mut results = Vec::new();
    for (name, backend) in [
        ("gpu", gpu),
        ("cpu", create_backend(BackendKind::Cpu, accuracy).unwrap().0),
    ] {
        let mut sim = RotorSimulator::new(LoadEvaluator::new(backend), accuracy);
        let out = dir.join(name).join("result.json");
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let opts = RunOptions {
            result: out.clone(),
            progress: false,
            runner: RunnerOptions::default(),
            settings: sim.settings(accuracy.rtol()),
        };
        run_sweep(&spec, &validate_scene, &mut sim, &opts, &mut |_| {}).unwrap();
        results.push(read(&out));
    }
    let (g, c) = (&results[0]["variants"], &results[1]["variants"]);
    for (vg, vc) in g.as_array().unwrap().iter().zip(c.as_array().unwrap()) {
        let id = &vg["id"];
        assert_eq!(vg["status"], vc["status"], "variant {id}");
        // The GPU kernel may run in f32 on nondimensional variables: film and orbit
        // figures agree to a small fraction of the clearance.
        for path in [["h_min", "value_m"], ["g_orbit", "radius_m"]] {
            let a = vg["reductions"][path[0]][path[1]].as_f64().unwrap();
            let b = vc["reductions"][path[0]][path[1]].as_f64().unwrap();
            assert!(
                (a - b).abs() < 1e-8,
                "variant {id} {path:?}: gpu {a}, cpu {b}, tol 1e-8 m"
            );
        }
        let fa = vg["reductions"]["bearings"][0]["friction_coefficient"]["mean"]
            .as_f64()
            .unwrap();
        let fb = vc["reductions"]["bearings"][0]["friction_coefficient"]["mean"]
            .as_f64()
            .unwrap();
        assert!(
            (fa / fb - 1.0).abs() < 1e-4,
            "variant {id} friction: gpu {fa}, cpu {fb}, rtol 1e-4"
        );
    }
}

#[test]
fn results_do_not_depend_on_the_number_of_threads() {
    let dir = scratch("sweep-rotor", "threads");
    let p = write(&dir, "cv.json", &spec(0.05, 3));
    let mut docs = Vec::new();
    for threads in ["1", "3"] {
        let root = dir.join(format!("t{threads}"));
        let out = bin()
            .args([
                "run",
                p.to_str().unwrap(),
                "--out",
                root.to_str().unwrap(),
                "--quiet",
            ])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let d = read(&root.join("cv/result.json"));
        assert_eq!(
            d["run"]["simulator"]["variant_threads"],
            json!(threads.parse::<u64>().unwrap())
        );
        docs.push(deterministic(d));
    }
    assert_eq!(
        serde_json::to_string(&docs[0]).unwrap(),
        serde_json::to_string(&docs[1]).unwrap(),
        "1 thread and 3 threads differ"
    );
}
