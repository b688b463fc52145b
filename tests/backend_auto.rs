//! `auto`, the default backend of `run` and `eval`: the CPU for small batches, a hardware
//! GPU adapter for large ones, never a software rasteriser; the choice and its reason in
//! one stderr line and in the output (scene `result.json` top level, sweep
//! `run.simulator`, `eval` output). The environment is only read here (backend_select.rs
//! changes it), so the tests may run in parallel.

mod cli_support;

use bearing_sweep::backend::{
    choose_backend, BackendKind, FilmBackend, GpuBackend, GpuOptions, DEFAULT_CPU_BELOW,
};
use bearing_sweep::bearing::Accuracy;
use cli_support::{bin, read, scratch, write};
use serde_json::{json, Value};

/// The stderr lines of an `auto` choice.
fn auto_lines(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains("backend auto"))
        .collect()
}

#[test]
fn auto_takes_the_cpu_below_the_crossover_and_says_why_in_one_line() {
    let acc = Accuracy::default();
    let small = DEFAULT_CPU_BELOW - 1;
    let (b, notices) = choose_backend(BackendKind::Auto, acc, Some(small)).expect("auto");
    assert_eq!(b.info().name, "cpu", "{small} states per call");
    let choice = b.choice().expect("auto records its choice");
    assert_eq!(choice.requested, BackendKind::Auto);
    assert_eq!(choice.backend, "cpu");
    assert!(
        choice
            .reason
            .contains(&format!("{small} bearing states per call")),
        "reason: {}",
        choice.reason
    );
    assert_eq!(notices.len(), 1, "notices: {notices:?}");
    assert!(
        notices[0].contains("backend auto")
            && notices[0].contains("using the CPU backend")
            && !notices[0].contains('\n'),
        "notice: {}",
        notices[0]
    );

    // An explicit request is recorded as such and prints nothing.
    let (b, notices) = choose_backend(BackendKind::Cpu, acc, Some(1_000_000)).expect("cpu");
    let choice = b.choice().expect("cpu records its choice");
    assert_eq!(
        (
            choice.requested,
            choice.backend.as_str(),
            choice.reason.as_str()
        ),
        (BackendKind::Cpu, "cpu", "requested")
    );
    assert!(notices.is_empty(), "notices: {notices:?}");
}

#[test]
fn auto_on_a_large_batch_takes_a_hardware_adapter_and_never_a_software_one() {
    let acc = Accuracy::default();
    let adapter = GpuOptions::from_env().and_then(|o| GpuBackend::new(acc, o));
    let (b, notices) = choose_backend(BackendKind::Auto, acc, Some(100_000)).expect("auto");
    let choice = b.choice().expect("auto records its choice");
    assert_eq!(choice.backend, b.info().name);
    assert_eq!(notices.len(), 1, "one line: {notices:?}");
    match adapter {
        Err(e) => {
            eprintln!("notice: no GPU adapter ({e}); checking the CPU fallback only");
            assert_eq!(b.info().name, "cpu");
            assert!(
                choice.reason.contains("no GPU adapter"),
                "{}",
                choice.reason
            );
        }
        Ok(g) if g.is_software() => {
            assert_eq!(b.info().name, "cpu", "auto passed over {}", g.info().device);
            assert!(choice.reason.contains("software"), "{}", choice.reason);
        }
        Ok(g) => {
            assert_eq!(b.info().name, "gpu", "auto takes {}", g.info().device);
            assert!(choice.reason.contains("hardware"), "{}", choice.reason);
            assert!(notices[0].contains("using the GPU backend"), "{notices:?}");
        }
    }
}

/// The paper's rotor, shortened to 20 ms.
fn short_scene() -> Value {
    let mut s: Value = serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    s["compare_ideal"] = json!(false);
    s["integrator"]["t_end"] = json!(0.02);
    s
}

#[test]
fn run_and_eval_default_to_auto_and_record_the_choice() {
    let dir = scratch("backend-auto", "run");
    let scene = write(&dir, "short.json", &short_scene());
    for (args, requested) in [(vec![], "auto"), (vec!["--backend", "cpu"], "cpu")] {
        let out_dir = dir.join(format!("out-{requested}"));
        let out = bin()
            .args([
                "run",
                scene.to_str().unwrap(),
                "--out",
                out_dir.to_str().unwrap(),
            ])
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "run {args:?}: {stderr}");
        let r = read(&out_dir.join("short").join("result.json"));
        let choice = &r["backend_choice"];
        assert_eq!(choice["requested"], json!(requested), "{choice}");
        assert_eq!(choice["backend"], r["backend"]["name"], "{r:#}");
        let lines = auto_lines(&stderr);
        if requested == "auto" {
            // Two bearings: two states per call, so the CPU whatever the machine has.
            assert_eq!(choice["backend"], json!("cpu"), "{choice}");
            assert_eq!(lines.len(), 1, "one line on stderr: {stderr}");
            assert!(lines[0].contains("2 bearing states per call"), "{stderr}");
        } else {
            assert!(lines.is_empty(), "no auto line for --backend cpu: {stderr}");
        }
    }

    let input = write(
        &dir,
        "states.json",
        &json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
                "states": [{"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}]}),
    );
    let out = bin()
        .args(["eval", input.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "eval: {stderr}");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["backend_choice"]["requested"], json!("auto"), "{doc:#}");
    assert_eq!(doc["backend"]["name"], json!("cpu"), "one state: the CPU");
    assert_eq!(auto_lines(&stderr).len(), 1, "{stderr}");
}

#[test]
fn a_sweep_records_the_choice_in_run_simulator_and_the_backend_in_settings() {
    let dir = scratch("backend-auto", "sweep");
    let mut base = short_scene();
    base.as_object_mut().unwrap().remove("compare_ideal");
    let spec = write(
        &dir,
        "spec.json",
        &json!({"kind": "rotor", "name": "auto", "base": base,
                "axes": [{"path": "initial.spin", "values": [80.0, 120.0]}]}),
    );
    let out_dir = dir.join("out");
    let out = bin()
        .args([
            "run",
            spec.to_str().unwrap(),
            "--quiet",
            "--out",
            out_dir.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "sweep: {stderr}");
    let result = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().path().join("result.json"))
        .find(|p| p.exists())
        .expect("a result.json under the output folder");
    let r = read(&result);
    let choice = &r["run"]["simulator"]["backend_choice"];
    assert_eq!(choice["requested"], json!("auto"), "{r:#}");
    assert_eq!(choice["backend"], r["settings"]["backend"], "{r:#}");
    assert_eq!(auto_lines(&stderr).len(), 1, "{stderr}");
}

/// A short-film rotor sweep under `auto` decides from a calibration of a hardware
/// adapter (backend::Calibration): its reason then starts with "calibrated:"; without a
/// hardware adapter (here: none, or lavapipe) it takes the CPU and says why, on any number
/// of threads; a finite-film sweep is never calibrated and runs on the CPU.
#[test]
fn auto_calibrates_short_film_sweeps_on_hardware_adapters_only() {
    let dir = scratch("backend-auto", "short-sweep");
    let mut base = short_scene();
    base.as_object_mut().unwrap().remove("compare_ideal");
    let mut finite = base.clone();
    for b in finite["bearings"].as_array_mut().unwrap() {
        b["model"] = json!("finite");
    }
    for (name, base, threads, short_reason) in [
        ("short-2", &base, "2", true),
        ("short-1", &base, "1", true),
        ("finite-2", &finite, "2", false),
    ] {
        let spec = write(
            &dir,
            &format!("{name}.json"),
            &json!({"kind": "rotor", "name": name, "base": base,
                    "axes": [{"path": "initial.spin", "values": [80.0, 120.0]}]}),
        );
        let out_dir = dir.join(format!("out-{name}"));
        let out = bin()
            .args(["run", spec.to_str().unwrap(), "--quiet", "--out"])
            .arg(&out_dir)
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        let r = read(&out_dir.join(name).join("result.json"));
        let choice = &r["run"]["simulator"]["backend_choice"];
        let reason = choice["reason"].as_str().unwrap_or_default();
        let calibrated = reason.starts_with("calibrated:");
        let hardware =
            !(reason.contains("software rasteriser") || reason.contains("no GPU adapter"));
        if short_reason {
            assert_eq!(calibrated, hardware, "{name}: reason `{reason}`");
            if !hardware {
                assert_eq!(choice["backend"], json!("cpu"), "{name}: {choice}");
            }
        } else {
            // The finite film's GPU kernel loses to the CPU on hardware too (session 39,
            // H200): `auto` takes the CPU for such a sweep, with that reason.
            assert!(!calibrated, "{name}: reason `{reason}`");
            assert_eq!(choice["backend"], json!("cpu"), "{name}: {choice}");
            assert!(reason.contains("finite film"), "{name}: reason `{reason}`");
        }
    }
}
