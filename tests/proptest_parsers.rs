//! Issue 13, "keep it from coming back": property tests over the spec, scene and eval
//! parsers. Random JSON trees, and random mutations of every file in `sweeps/`, must
//! never panic, hang or give NaN: always a result or an error naming a path.
//!
//! `cargo test` runs 64 cases per property; a longer run:
//! `PROPTEST_CASES=5000 cargo test --release --test proptest_parsers`.

use std::path::Path;

use bearing_sweep::app::{eval_json, EvalOptions};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::rotor::load_scene;
use bearing_sweep::sweep::friction_map::{friction_map, FrictionMapSpec};
use bearing_sweep::sweep::{parse_spec, Expansion, SweepError};
use proptest::prelude::*;
use serde_json::{json, Value};

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(64),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Numbers that break naive code: zeros, signs, subnormals, extremes, integers.
fn nasty_number() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(json!(0.0)),
        Just(json!(-0.0)),
        Just(json!(-1)),
        Just(json!(1)),
        Just(json!(5e-324)),
        Just(json!(1e-310)),
        Just(json!(1.7976931348623157e308)),
        Just(json!(-1.7976931348623157e308)),
        Just(json!(u64::MAX)),
        Just(json!(i64::MIN)),
        Just(json!(1e9)),
        any::<f64>()
            .prop_filter("finite", |x| x.is_finite())
            .prop_map(|x| json!(x)),
        (-1e3f64..1e3).prop_map(|x| json!(x)),
    ]
}

fn leaf() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        nasty_number(),
        "[a-z_\\[\\]\\*\\.0-9]{0,12}".prop_map(Value::String),
        Just(json!("x".repeat(5000))),
    ]
}

/// Random JSON trees, keys drawn from the project's field names (so that they get past
/// the first lookups) and random ones.
fn tree() -> impl Strategy<Value = Value> {
    let key = prop_oneof![
        Just("kind".to_string()),
        Just("base".to_string()),
        Just("axes".to_string()),
        Just("path".to_string()),
        Just("values".to_string()),
        Just("linspace".to_string()),
        Just("logspace".to_string()),
        Just("mode".to_string()),
        Just("bearing".to_string()),
        Just("bearings".to_string()),
        Just("states".to_string()),
        Just("load".to_string()),
        Just("speed".to_string()),
        Just("samples".to_string()),
        Just("integrator".to_string()),
        Just("t_end".to_string()),
        Just("plots".to_string()),
        Just("reductions".to_string()),
        "[a-z]{1,6}",
    ];
    leaf().prop_recursive(5, 64, 6, move |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(Value::Array),
            prop::collection::btree_map(key.clone(), inner, 0..6)
                .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// Every path (as steps) into `v`.
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    Index(usize),
}

fn paths(v: &Value, at: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                at.push(Step::Key(k.clone()));
                paths(c, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                at.push(Step::Index(i));
                paths(c, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |v, s| match s {
        Step::Key(k) => v.get_mut(k.as_str()),
        Step::Index(i) => v.get_mut(*i),
    })
}

/// What a mutation does at the chosen node.
#[derive(Clone, Debug)]
enum Mutation {
    Replace(Value),
    Delete,
    WrapInArray,
    AddKey(String, Value),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => tree().prop_map(Mutation::Replace),
        1 => Just(Mutation::Delete),
        1 => Just(Mutation::WrapInArray),
        1 => ("[a-z_]{1,8}", leaf()).prop_map(|(k, v)| Mutation::AddKey(k, v)),
    ]
}

fn mutate(doc: &Value, pick: usize, m: &Mutation) -> Value {
    let mut d = doc.clone();
    let mut all = Vec::new();
    paths(&d, &mut Vec::new(), &mut all);
    let path = &all[pick % all.len()];
    match m {
        Mutation::Replace(v) => {
            if let Some(n) = get_mut(&mut d, path) {
                *n = v.clone();
            }
        }
        Mutation::Delete => {
            if let Some((Step::Key(k), parent)) = path.split_last() {
                if let Some(Value::Object(o)) = get_mut(&mut d, parent) {
                    o.remove(k);
                }
            }
        }
        Mutation::WrapInArray => {
            if let Some(n) = get_mut(&mut d, path) {
                *n = json!([n.clone()]);
            }
        }
        Mutation::AddKey(k, v) => {
            if let Some(Value::Object(o)) = get_mut(&mut d, path) {
                o.insert(k.clone(), v.clone());
            }
        }
    }
    d
}

/// An error must name a path: non-empty, and not just `$` when the document is an object
/// whose problem is inside (a bare `$` is fine for the document as a whole).
fn check_path(what: &str, path: &str, reason: &str) {
    assert!(!path.is_empty(), "{what}: empty path (reason: {reason})");
    assert!(!reason.is_empty(), "{what}: empty reason at {path}");
    assert!(!reason.contains("NaN"), "{what}: {path}: {reason}");
}

fn check_sweep_error(what: &str, e: &SweepError) {
    match e {
        SweepError::Spec { path, reason } | SweepError::Variant { path, reason, .. } => {
            check_path(what, path, reason)
        }
        other => check_path(what, "$", &other.to_string()),
    }
}

/// Feeds `doc` (its text) to every parser that could take it; cheap work only.
fn exercise(doc: &Value) {
    let text = doc.to_string();
    // As a sweep spec (rotor, synthetic) or friction map.
    if doc.get("kind").and_then(Value::as_str) == Some("friction_map") {
        match FrictionMapSpec::parse(doc) {
            Ok(spec) => {
                if spec.load.len() * spec.speed.len() <= 400 {
                    let (result, _) = friction_map(&spec, Accuracy::new(1e-3).unwrap());
                    assert!(!result.to_string().contains("NaN"));
                }
            }
            Err(e) => check_sweep_error("friction map", &e),
        }
    } else {
        match parse_spec(doc, Some(Path::new("sweeps"))) {
            Ok(spec) => {
                let e = Expansion::new(&spec);
                let validator = bearing_sweep::sweep::simulator::scene_validator(spec.kind);
                if let Err(err) = e.validate_all(&spec, validator) {
                    check_sweep_error("validate", &err);
                }
            }
            Err(e) => check_sweep_error("spec", &e),
        }
    }
    // As a scene file.
    if let Err(e) = load_scene(&text) {
        check_path("scene", &e.path, &e.reason);
    }
    // As an eval input (CPU backend, few states).
    if doc
        .get("states")
        .and_then(Value::as_array)
        .is_none_or(|s| s.len() <= 64)
    {
        match eval_json(&text, EvalOptions::default()) {
            Ok((out, _)) => {
                for (k, l) in out["loads"].as_array().unwrap().iter().enumerate() {
                    assert!(
                        l["status"].is_string(),
                        "eval: load {k} without status: {l}"
                    );
                }
            }
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
}

fn sweep_files() -> Vec<(String, Value)> {
    let mut out: Vec<(String, Value)> = std::fs::read_dir("sweeps")
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .map(|e| {
            let name = e.path().display().to_string();
            let v = serde_json::from_str(&std::fs::read_to_string(e.path()).unwrap()).unwrap();
            (name, v)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    assert!(out.len() >= 5, "sweeps/ holds {} files", out.len());
    out
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_trees_never_panic(doc in tree()) {
        exercise(&doc);
    }

    #[test]
    fn mutated_sweep_files_never_panic(file in 0usize..64, pick in any::<usize>(), m in mutation()) {
        let files = sweep_files();
        let (_, doc) = &files[file % files.len()];
        exercise(&mutate(doc, pick, &m));
    }

    #[test]
    fn duplicated_keys_are_always_refused(file in 0usize..64, pick in any::<usize>()) {
        // Text-level: repeat one object's first key (serde_json alone would keep the last).
        let files = sweep_files();
        let (name, _) = &files[file % files.len()];
        let text = std::fs::read_to_string(name).unwrap();
        let opens: Vec<usize> = text.match_indices("{\"").map(|(i, _)| i).collect();
        prop_assume!(!opens.is_empty());
        let at = opens[pick % opens.len()];
        let key_end = text[at + 2..].find('"').unwrap() + at + 2;
        let key = &text[at + 2..key_end];
        let dup = format!("{{\"{key}\": null, {}", &text[at + 1..]);
        let doc = format!("{}{}", &text[..at], dup);
        let e = bearing_sweep::json::parse_json(&doc).unwrap_err();
        prop_assert!(e.reason.contains("duplicate key"), "{name}: {e:?}");
        prop_assert!(e.path.ends_with(&bearing_sweep::json::quote(key)), "{name}: {e:?} for key {key}");
    }
}
