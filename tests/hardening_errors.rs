//! Issue 13 items 6 and 7: every bad input gets a short, human error naming its JSON path.
//! Synthetic scene errors name the field (not `$`); wide linspace/logspace ranges do not
//! overflow; two axes setting one parameter are refused naming both; duplicate keys and a
//! struct written as an array are refused naming the key (spec, scene and eval inputs);
//! a plot's `y` is checked; numbers are short and echoed input is cut; `merge` creates
//! its output folder and its messages carry no Rust Debug text.

use serde_json::{json, Value};

use bearing_sweep::sweep::{parse_spec, Expansion, SweepError};

mod cli_support;
use cli_support::*;

const BEARING: &str =
    r#"{"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}"#;
const STATE: &str = r#"{"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100}"#;

/// Runs the binary on a file holding `text` exactly (duplicate keys survive): (ok, stderr).
fn run_text(tag: &str, cmd: &str, text: &str) -> (bool, String) {
    let dir = scratch("hardening-errors", tag);
    let p = dir.join("in.json");
    std::fs::write(&p, text).unwrap();
    let out = dir.join("out");
    let args: Vec<&str> = match cmd {
        "eval" => vec!["eval", p.to_str().unwrap()],
        _ => vec![
            "run",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ],
    };
    let (ok, err) = run(&args);
    assert!(!err.contains("panicked"), "{tag}: panic: {err}");
    (ok, err)
}

fn expect_error(tag: &str, cmd: &str, text: &str, needles: &[&str]) {
    let (ok, err) = run_text(tag, cmd, text);
    assert!(!ok, "{tag}: accepted; stderr {err}");
    for n in needles {
        assert!(
            err.contains(n),
            "{tag}: stderr `{}` lacks `{n}`",
            err.trim()
        );
    }
}

fn spec_err(doc: Value) -> (String, String) {
    match parse_spec(&doc, None) {
        Err(SweepError::Spec { path, reason }) => (path, reason),
        other => panic!("expected a spec error for {doc}, got {other:?}"),
    }
}

#[test]
fn duplicate_keys_are_refused_in_every_input() {
    expect_error(
        "dup-eval",
        "eval",
        &format!(r#"{{"bearing": {BEARING}, "states": [{STATE}, {{"xi": 1, "xi": 2}}]}}"#),
        &["states[1].xi: duplicate key"],
    );
    expect_error(
        "dup-eval-top",
        "eval",
        &format!(r#"{{"bearing": {BEARING}, "states": [], "bearing": {BEARING}}}"#),
        &["bearing: duplicate key"],
    );
    expect_error(
        "dup-spec",
        "run",
        r#"{"kind": "synthetic", "base": {"spin": 100}, "axes": [{"path": "spin", "values": [1], "values": [2]}]}"#,
        &["axes[0].values: duplicate key"],
    );
    // A scene file (the paper example) with a duplicate key at its top level.
    let text = std::fs::read_to_string("sweeps/paper-example.json").unwrap();
    let text = text.replacen('{', r#"{"name": "a", "name": "b","#, 1);
    expect_error("dup-scene", "run", &text, &["name: duplicate key"]);
}

#[test]
fn a_struct_written_as_an_array_is_refused() {
    expect_error(
        "array-bearing",
        "eval",
        &format!(r#"{{"bearing": [0.02, 0.02, 0.0003, 0.0242], "states": [{STATE}]}}"#),
        &["bearing: expected an object", "got an array"],
    );
    expect_error(
        "array-state",
        "eval",
        &format!(r#"{{"bearing": {BEARING}, "states": [[1e-4, 0, 1e-4, 0, 0, 0, 0, 0, 100]]}}"#),
        &["states[0]: expected an object"],
    );
    expect_error(
        "array-map-bearing",
        "run",
        r#"{"kind": "friction_map", "bearing": [0.02, 0.02, 0.0003, 0.0242], "load": [1], "speed": [10]}"#,
        &["bearing: expected an object"],
    );
    expect_error(
        "array-synthetic-bearing",
        "run",
        r#"{"kind": "synthetic", "base": {"bearings": [[3e-4, 0.3]]}}"#,
        &["bearings[0]: expected an object"],
    );
}

#[test]
fn synthetic_scene_errors_name_the_field() {
    expect_error(
        "synthetic-path",
        "run",
        r#"{"kind": "synthetic", "base": {"spin": "fast"}}"#,
        &["spin: invalid type"],
    );
    expect_error(
        "synthetic-nested",
        "run",
        r#"{"kind": "synthetic", "base": {"bearings": [{"orbit": 1e-6}, {"whirl": "x"}]}}"#,
        &["bearings[1].whirl: invalid type"],
    );
    let (_, err) = run_text(
        "synthetic-no-dollar",
        "run",
        r#"{"kind": "synthetic", "base": {"samples": -3}}"#,
    );
    assert!(err.contains("samples:") && !err.contains(" $:"), "{err}");
}

#[test]
fn wide_ranges_do_not_overflow() {
    let doc = json!({"base": {"a": 1.0, "b": 1.0}, "axes": [
        {"path": "a", "linspace": [-1.7976931348623157e308, 1.7976931348623157e308, 5]},
        {"path": "b", "logspace": [5e-324, 1.7976931348623157e308, 7]}]});
    let spec = parse_spec(&doc, None).unwrap();
    let e = Expansion::new(&spec);
    let mut prev_b = 0.0;
    for id in 0..e.count() {
        let v = e.values(&spec, id);
        let (a, b) = (v[0].as_f64(), v[1].as_f64());
        assert!(a.is_some_and(f64::is_finite), "variant {id}: a = {}", v[0]);
        let b = b.unwrap_or_else(|| panic!("variant {id}: b = {}", v[1]));
        assert!(b.is_finite() && b > 0.0, "variant {id}: b = {b}");
        if id % 7 > 0 {
            assert!(
                b > prev_b,
                "variant {id}: logspace not increasing: {prev_b} then {b}"
            );
        }
        prev_b = b;
    }
    let mid = e.values(&spec, 2 * 7)[0].as_f64().unwrap();
    assert!(
        mid.abs() <= 1e292,
        "index 14: actual {mid:e}, expected 0, tolerance 1e292"
    );
    // Latin hypercube: continuous values inside the same ranges.
    let mut doc = doc;
    doc["mode"] = json!({"latin_hypercube": {"samples": 50, "seed": 3}});
    let spec = parse_spec(&doc, None).unwrap();
    let e = Expansion::new(&spec);
    for id in 0..50 {
        let v = e.values(&spec, id);
        assert!(
            v.iter().all(|x| x.as_f64().is_some_and(f64::is_finite)),
            "variant {id}: {v:?}"
        );
    }
}

#[test]
fn two_axes_setting_one_parameter_are_refused_naming_both() {
    let base = json!({"rotor": {"mass": 1.0}, "bearings": [{"c": 1.0}, {"c": 2.0}], "speed": 1.0});
    let cases = [
        (
            json!([{"path": "speed", "values": [1]}, {"path": "speed", "values": [2]}]),
            "axes[1].path",
            "axes[0] (`speed`)",
        ),
        (
            json!([{"path": "bearings[*].c", "values": [1]}, {"path": "bearings[1].c", "values": [2]}]),
            "axes[1].path",
            "axes[0] (`bearings[*].c`)",
        ),
        (
            json!([{"path": "speed", "values": [1]}, {"path": "rotor", "values": [{"mass": 2}]}, {"path": "rotor.mass", "values": [2]}]),
            "axes[2].path",
            "axes[1] (`rotor`)",
        ),
    ];
    for (k, (axes, path, reason)) in cases.into_iter().enumerate() {
        let (p, r) = spec_err(json!({"base": base, "axes": axes}));
        assert!(
            p == path && r.contains(reason) && r.contains("already swept"),
            "case {k}: {p}: {r}"
        );
    }
    // Neighbours that merely share a prefix are fine.
    let ok = json!({"base": {"c": 1.0, "c2": 1.0}, "axes": [{"path": "c", "values": [1]}, {"path": "c2", "values": [2]}]});
    parse_spec(&ok, None).unwrap();
}

#[test]
fn a_plot_y_path_is_checked() {
    let doc = |y: &str| {
        json!({"kind": "synthetic", "base": {"spin": 1.0}, "axes": [{"path": "spin", "values": [1, 2]}],
               "plots": [{"name": "p", "x": "spin", "y": y}]})
    };
    parse_spec(&doc("bearings[0].whirl.subsync_amplitude_m"), None).unwrap();
    parse_spec(&doc("h_min.value_m"), None).unwrap();
    for (y, reason) in [
        (
            "bearings[0].whirl.subsync_amplitude",
            "no field `subsync_amplitude`",
        ),
        ("h_min", "not a number"),
        ("bearing[0].orbit.radius_m", "no field `bearing`"),
    ] {
        let (p, r) = spec_err(doc(y));
        assert!(p == "plots[0].y" && r.contains(reason), "y = {y}: {p}: {r}");
    }
}

#[test]
fn messages_are_short_and_human() {
    let huge = "k".repeat(1 << 20);
    for (tag, cmd, text) in [
        (
            "huge-kind",
            "run",
            format!(r#"{{"kind": "{huge}", "base": {{}}}}"#),
        ),
        (
            "huge-key",
            "eval",
            format!(r#"{{"bearing": {BEARING}, "states": [], "{huge}": 1}}"#),
        ),
        (
            "huge-value",
            "eval",
            format!(r#"{{"bearing": {BEARING}, "states": [{{"xi": "{huge}"}}]}}"#),
        ),
        (
            "huge-path",
            "run",
            format!(
                r#"{{"kind": "synthetic", "base": {{}}, "axes": [{{"path": "{huge}", "values": [1]}}]}}"#
            ),
        ),
    ] {
        let (ok, err) = run_text(tag, cmd, &text);
        assert!(!ok, "{tag}: accepted");
        assert!(err.len() < 3000, "{tag}: {} bytes of message", err.len());
        assert!(
            err.contains("more characters"),
            "{tag}: no note of the cut: {err}"
        );
    }
    // Numbers: short forms, no 309 digits, no `inf`.
    let (_, err) = run_text(
        "big-number",
        "run",
        r#"{"kind": "synthetic", "base": {"duration": -1e308}}"#,
    );
    assert!(err.contains("-1e308") && !err.contains("00000000"), "{err}");
    let doc = json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 1e-300, "viscosity": 0.0242},
                     "states": [{"xi": 1e10, "yi": 0, "xj": 0, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 1}]});
    let (out, _) = bearing_sweep::app::eval_json(&doc.to_string(), Default::default()).unwrap();
    let msg = out["loads"][0]["error"].as_str().unwrap();
    assert!(
        msg.contains("through the wall") && !msg.contains("inf") && !msg.contains(" I"),
        "{msg}"
    );
}

#[test]
fn merge_creates_its_folder_and_speaks_plainly() {
    let dir = scratch("hardening-errors", "merge");
    let spec = write(
        &dir,
        "s.json",
        &json!({"kind": "synthetic", "base": {"samples": 11, "spin": 100.0},
        "axes": [{"path": "spin", "values": [50, 100, 150]}]}),
    );
    let root = dir.join("out");
    let mut shards = Vec::new();
    for k in 0..2 {
        let (ok, err) = run(&[
            "run",
            spec.to_str().unwrap(),
            "--shard",
            &format!("{k}/2"),
            "--out",
            root.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(ok, "{err}");
        shards.push(root.join(format!("s/shard-{k}-of-2/result.json")));
    }
    let merged = dir.join("new/deeper/merged.json");
    let (ok, err) = run(&[
        "merge",
        merged.to_str().unwrap(),
        shards[0].to_str().unwrap(),
        shards[1].to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert_eq!(read(&merged)["variants"].as_array().unwrap().len(), 3);
    // One shard only: the missing variant is named without Debug brackets.
    let (ok, err) = run(&[
        "merge",
        dir.join("m2.json").to_str().unwrap(),
        shards[0].to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(err.contains("first: 1)") && !err.contains('['), "{err}");
    // A shard without a shard count: no `Some(..)`/`None`.
    let mut d = read(&shards[1]);
    d["shard"] = json!({"index": 1});
    let odd = write(&dir, "odd.json", &d);
    let (ok, err) = run(&[
        "merge",
        dir.join("m3.json").to_str().unwrap(),
        shards[0].to_str().unwrap(),
        odd.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("shard count missing") && !err.contains("Some(") && !err.contains("None"),
        "{err}"
    );
}
