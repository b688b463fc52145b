//! What the command line says (issue 23 item 6): a re-run into a folder with other flags
//! names the differing keys and the ways on; implausible inputs warn (path, value, usual
//! range) and still run; unknown fields get a "did you mean"; a JSON syntax error names
//! the file; `auto` on a CPU machine prints no loader error and one short line; a
//! finished folder holds no `result.lock`; `--help` shows defaults as written (`1e-12`).

mod cli_support;

use cli_support::{bin, read, scratch, write};
use serde_json::{json, Value};

/// Runs the binary: (success, stdout, stderr).
fn run(args: &[&str], env_remove: &[&str]) -> (bool, String, String) {
    let mut c = bin();
    c.args(args);
    for k in env_remove {
        c.env_remove(k);
    }
    let out = c.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The paper rotor as a one-variant sweep over 5 ms.
fn tiny_sweep() -> Value {
    let mut scene: Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    scene.as_object_mut().unwrap().remove("compare_ideal");
    scene["integrator"]["t_end"] = json!(0.005);
    json!({"base": scene, "axes": [{"path": "bearings[*].viscosity", "values": [0.0242]}]})
}

fn eval_doc(viscosity: f64, clearance: f64) -> Value {
    json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": clearance, "viscosity": viscosity},
           "states": [{"xi": 1e-5, "yi": 0, "xj": 1e-5, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}]})
}

#[test]
fn a_rerun_with_another_flag_names_the_keys_and_the_ways_on() {
    let dir = scratch("cli-messages", "rerun");
    let spec = write(&dir, "tiny.json", &tiny_sweep());
    let out = dir.join("out");
    let (s, o) = (spec.to_str().unwrap(), out.to_str().unwrap());
    let (ok, _, err) = run(&["run", s, "--out", o, "--backend", "cpu", "--quiet"], &[]);
    assert!(ok, "{err}");
    assert!(
        !out.join("tiny/result.lock").exists(),
        "result.lock left in a finished folder"
    );
    assert!(out.join("tiny/result.json").is_file());
    let (ok, _, err) = run(
        &[
            "run",
            s,
            "--out",
            o,
            "--backend",
            "cpu",
            "--quiet",
            "--accuracy",
            "1e-9",
        ],
        &[],
    );
    assert!(!ok, "a different accuracy resumed the folder: {err}");
    assert!(
        err.contains("`settings.film_accuracy` (--accuracy): folder 1e-6, this run 1e-9"),
        "the differing key is not named: {err}"
    );
    assert!(
        err.contains("another --out") && err.contains("delete"),
        "no way on offered: {err}"
    );
    assert_eq!(err.lines().count(), 1, "one message: {err}");
}

#[test]
fn implausible_inputs_warn_with_the_field_and_the_usual_range_and_still_run() {
    let dir = scratch("cli-messages", "warn");
    // mPa·s typed as Pa·s.
    let f = write(&dir, "mpas.json", &eval_doc(24.2, 0.0003));
    let (ok, stdout, err) = run(&["eval", f.to_str().unwrap(), "--backend", "cpu"], &[]);
    assert!(ok, "{err}");
    assert!(stdout.contains("\"loads\""), "{stdout}");
    assert!(
        err.contains(
            "warning: bearing.viscosity = 24.2 Pa·s is outside the usual range 0.0001 to 1 Pa·s"
        ),
        "{err}"
    );
    // A 3 mm clearance on a 20 mm radius, in a scene run (warned before it runs).
    let mut scene: Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    scene["compare_ideal"] = json!(false);
    scene["integrator"]["t_end"] = json!(0.002);
    scene["bearings"][1]["clearance"] = json!(0.003);
    let f = write(&dir, "loose.json", &scene);
    let o = dir.join("out");
    let (ok, _, err) = run(
        &[
            "run",
            f.to_str().unwrap(),
            "--out",
            o.to_str().unwrap(),
            "--backend",
            "cpu",
        ],
        &[],
    );
    assert!(ok, "{err}");
    assert!(
        err.contains("warning: bearings[1].clearance: clearance / radius = 0.15"),
        "{err}"
    );
    assert!(
        !err.contains("bearings[0]"),
        "bearing 0 is the paper's: {err}"
    );
    // A sweep axis.
    let mut spec = tiny_sweep();
    spec["axes"][0]["values"] = json!([0.0242, 5.0]);
    let f = write(&dir, "axis.json", &spec);
    let (ok, _, err) = run(
        &[
            "run",
            f.to_str().unwrap(),
            "--out",
            o.to_str().unwrap(),
            "--backend",
            "cpu",
            "--quiet",
        ],
        &[],
    );
    assert!(ok, "{err}");
    assert!(
        err.contains("warning: axes[0] (bearings[*].viscosity) = 5 Pa·s"),
        "{err}"
    );
    // The paper's own files warn about nothing.
    let f = write(&dir, "paper.json", &eval_doc(0.0242, 0.0003));
    let (ok, _, err) = run(&["eval", f.to_str().unwrap(), "--backend", "cpu"], &[]);
    assert!(ok && !err.contains("warning"), "{err}");
}

#[test]
fn unknown_fields_get_a_did_you_mean_with_the_json_path() {
    let dir = scratch("cli-messages", "typo");
    let mut doc = eval_doc(0.0242, 0.0003);
    let b = doc["bearing"].as_object_mut().unwrap();
    let v = b.remove("viscosity").unwrap();
    b.insert("viscosty".into(), v);
    let f = write(&dir, "typo.json", &doc);
    let (ok, _, err) = run(&["eval", f.to_str().unwrap()], &[]);
    assert!(!ok);
    assert!(
        err.starts_with("error: bearing.viscosty: unknown field")
            && err.contains("did you mean `viscosity`?"),
        "{err}"
    );
    // In a sweep spec (the spec's own reworded messages), and a scene inside it.
    let mut spec = tiny_sweep();
    let axes = spec.as_object_mut().unwrap().remove("axes").unwrap();
    spec["axis"] = axes;
    let f = write(&dir, "spec.json", &spec);
    let (ok, _, err) = run(
        &[
            "run",
            f.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ],
        &[],
    );
    assert!(!ok);
    assert!(
        err.contains("axis: unknown field") && err.contains("did you mean `axes`?"),
        "{err}"
    );
    let mut scene: Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    scene["integrator"]["t_ned"] = json!(0.1);
    let f = write(&dir, "scene.json", &scene);
    let (ok, _, err) = run(
        &[
            "run",
            f.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ],
        &[],
    );
    assert!(!ok);
    assert!(
        err.contains("integrator.t_ned: unknown field") && err.contains("did you mean `t_end`?"),
        "{err}"
    );
}

#[test]
fn a_json_syntax_error_names_the_file() {
    let dir = scratch("cli-messages", "syntax");
    let f = dir.join("broken.json");
    std::fs::write(&f, "{\"bearing\": {\"radius\": 0.02,}\n").unwrap();
    let name = f.to_str().unwrap();
    for args in [
        vec!["eval", name],
        vec!["run", name, "--out", dir.to_str().unwrap()],
        vec!["coefficients", name],
    ] {
        let (ok, _, err) = run(&args, &[]);
        assert!(!ok, "{args:?}");
        assert!(
            err.starts_with(&format!("error: {name}")) && err.contains("not valid JSON"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn auto_prints_no_loader_error_and_at_most_one_short_line() {
    // 100 states: `auto` looks for a GPU adapter (lavapipe here, where installed), whose
    // loader complained about a missing XDG_RUNTIME_DIR on stderr.
    let dir = scratch("cli-messages", "auto");
    let mut doc = eval_doc(0.0242, 0.0003);
    let state = doc["states"][0].clone();
    doc["states"] = Value::Array(
        (0..100)
            .map(|k| {
                let mut s = state.clone();
                s["xi"] = json!(1e-6 * k as f64);
                s
            })
            .collect(),
    );
    let f = write(&dir, "many.json", &doc);
    let (ok, _, err) = run(&["eval", f.to_str().unwrap()], &["XDG_RUNTIME_DIR"]);
    assert!(ok, "{err}");
    assert!(!err.contains("XDG_RUNTIME_DIR"), "{err}");
    assert!(err.lines().count() <= 1, "{err}");
    for l in err.lines() {
        assert!(
            l.chars().count() <= 140,
            "a long notice ({} characters): {l}",
            l.chars().count()
        );
    }
    // A short-film sweep under auto on 2 threads: its line is short too.
    let spec = write(&dir, "tiny.json", &tiny_sweep());
    let out = dir.join("out");
    let mut c = bin();
    c.args([
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ])
    .env("RAYON_NUM_THREADS", "2")
    .env_remove("XDG_RUNTIME_DIR");
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("XDG_RUNTIME_DIR"), "{err}");
    for l in err.lines().filter(|l| l.starts_with("notice")) {
        assert!(
            l.chars().count() <= 140,
            "a long notice ({} characters): {l}",
            l.chars().count()
        );
    }
    let r = read(&out.join("tiny/result.json"));
    assert!(
        r["run"]["simulator"]["backend_choice"]["reason"].is_string(),
        "the full reason stays in the result"
    );
}

#[test]
fn help_shows_defaults_as_written() {
    for (cmd, want) in [
        ("run", "[default: 1e-6]"),
        ("coefficients", "[default: 1e-12]"),
    ] {
        let (ok, stdout, err) = run(&[cmd, "--help"], &[]);
        assert!(ok, "{err}");
        assert!(
            stdout.contains(want),
            "{cmd} --help lacks {want}:\n{stdout}"
        );
        assert!(!stdout.contains("0.000"), "{cmd} --help:\n{stdout}");
    }
}
