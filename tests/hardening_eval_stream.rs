//! Issue 13 item 9: `eval` streams. The `states` array is parsed element by element and
//! evaluated in chunks of `EVAL_CHUNK` states, each chunk written as it is done; the
//! output bytes are the whole document pretty-printed (what `eval` always wrote), across
//! chunk boundaries, with the states before or after the bearing. Memory and time
//! figures are in BENCHMARKS.md ("Limits and memory").

use bearing_sweep::app::{eval_json, eval_stream, EvalOptions, EVAL_CHUNK};
use serde_json::{json, Value};

const BEARING: &str =
    r#"{"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}"#;

/// State `k` of a deterministic family: tilted, squeezed, some through the wall or
/// overflowing (per-state errors), both spin signs.
fn state(k: usize) -> String {
    let d = 3e-4;
    let f = |m: usize| ((k * 7919 + m * 104729) % 1000) as f64 / 1000.0;
    let (xi, yj) = if k % 997 == 5 {
        (2.0 * d, 0.0)
    } else {
        (0.8 * d * (f(1) - 0.5), 0.8 * d * (f(2) - 0.5))
    };
    let omega = if k % 1009 == 7 {
        1e300
    } else {
        600.0 * (f(3) - 0.5)
    };
    format!(
        r#"{{"xi": {xi:e}, "yi": {:e}, "xj": {:e}, "yj": {yj:e}, "vxi": {:e}, "vyi": 0, "vxj": 0, "vyj": {:e}, "omega": {omega:e}}}"#,
        0.5 * d * (f(4) - 0.5),
        0.7 * d * (f(5) - 0.5),
        0.02 * (f(6) - 0.5),
        0.02 * (f(7) - 0.5)
    )
}

fn doc(states: &[String], bearing_first: bool) -> String {
    let s = format!("[{}]", states.join(",\n"));
    if bearing_first {
        format!(r#"{{"bearing": {BEARING}, "states": {s}}}"#)
    } else {
        format!(r#"{{"states": {s}, "bearing": {BEARING}}}"#)
    }
}

fn stream(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    eval_stream(text.as_bytes(), &mut out, EvalOptions::default())
        .map(|_| out)
        .map_err(|e| e.to_string())
}

#[test]
fn streamed_output_is_the_pretty_document_across_chunks() {
    let n = 2 * EVAL_CHUNK + 3;
    let states: Vec<String> = (0..n).map(state).collect();
    let bytes = stream(&doc(&states, true)).unwrap();
    let v: Value = serde_json::from_slice(&bytes).unwrap();
    // The bytes are exactly the document's pretty form and a newline.
    let canonical = serde_json::to_string_pretty(&v).unwrap() + "\n";
    if let Some(k) = bytes
        .iter()
        .zip(canonical.as_bytes())
        .position(|(a, b)| a != b)
    {
        panic!(
            "byte {k}: actual {:?}, expected {:?}",
            String::from_utf8_lossy(&bytes[k.saturating_sub(40)..(k + 40).min(bytes.len())]),
            &canonical[k.saturating_sub(40)..(k + 40).min(canonical.len())]
        );
    }
    assert_eq!(bytes.len(), canonical.len());
    let loads = v["loads"].as_array().unwrap();
    assert_eq!(loads.len(), n);
    // Each load equals that state evaluated alone (around both chunk boundaries, and
    // the per-state errors keep their own index).
    let mut check: Vec<usize> = vec![0, 1, 5, 7, 997 + 5, 1009 + 7, n - 1];
    for b in [EVAL_CHUNK, 2 * EVAL_CHUNK] {
        check.extend(b - 2..b + 2);
    }
    for k in check {
        let (alone, _) = eval_json(&doc(&[state(k)], true), EvalOptions::default()).unwrap();
        let mut expected = alone["loads"][0].clone();
        if let Some(e) = expected.get_mut("error") {
            *e = json!(e
                .as_str()
                .unwrap()
                .replacen("states[0]", &format!("states[{k}]"), 1));
        }
        assert_eq!(loads[k], expected, "index {k}");
    }
    assert_eq!(loads[5]["status"], "through_wall");
    assert_eq!(loads[7]["status"], "overflow");
    // States before the bearing: the same bytes.
    assert_eq!(
        stream(&doc(&states, false)).unwrap(),
        bytes,
        "order of the keys changed the output"
    );
}

#[test]
fn empty_and_bad_documents() {
    let out = stream(&doc(&[], true)).unwrap();
    let v: Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["loads"], json!([]));
    assert_eq!(
        String::from_utf8(out).unwrap(),
        serde_json::to_string_pretty(&v).unwrap() + "\n"
    );
    let mut states: Vec<String> = (0..EVAL_CHUNK + 10).map(state).collect();
    states[EVAL_CHUNK + 4] =
        r#"{"xi": 0, "yi": 0, "xj": 0, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0}"#.into();
    let e = stream(&doc(&states, true)).unwrap_err();
    assert!(
        e.starts_with(&format!(
            "states[{}]: missing field `omega`",
            EVAL_CHUNK + 4
        )),
        "{e}"
    );
    for (text, expected) in [
        (format!(r#"{{"bearing": {BEARING}}}"#), "states: missing"),
        (r#"{"states": []}"#.to_string(), "bearing: missing"),
        (format!(r#"{{"bearing": {BEARING}, "states": {{}}}}"#), "states: expected an array"),
        (format!(r#"{{"bearing": {BEARING}, "states": [], "extra": 1}}"#), "extra: unknown field"),
        (r#"{"bearing": {"radius": -1, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}, "states": []}"#.to_string(), "bearing.radius: must be positive"),
        ("[1, 2]".to_string(), "$: invalid type"),
        (format!(r#"{{"bearing": {BEARING}, "states": [}}"#), "$: not valid JSON"),
    ] {
        let e = stream(&text).unwrap_err();
        assert!(e.starts_with(expected), "{text}: got `{e}`, expected `{expected}...`");
    }
}

/// The service's evaluator pool: one backend serves many requests (a GPU backend costs a
/// device and a pipeline), and a reused evaluator answers each request exactly as a new
/// one would, finite-film warm starts included (the fields of the previous request are
/// forgotten), in either order of the requests.
#[test]
fn a_pooled_evaluator_answers_as_a_new_one() {
    use bearing_sweep::app::{eval_json_pooled, EvaluatorPool};
    let finite = BEARING.replace(
        '}',
        r#", "model": "finite", "finite": {"n_theta": 32, "n_z": 8}}"#,
    );
    let short_doc = doc(&(0..40).map(state).collect::<Vec<_>>(), true);
    let finite_doc = |from: usize| {
        let s: Vec<String> = (from..from + 6).map(state).collect();
        format!(r#"{{"bearing": {finite}, "states": [{}]}}"#, s.join(","))
    };
    let docs = [
        finite_doc(0),
        finite_doc(100),
        short_doc.clone(),
        finite_doc(0),
    ];
    let pool = EvaluatorPool::default();
    for round in 0..2 {
        let order: Vec<&String> = if round == 0 {
            docs.iter().collect()
        } else {
            docs.iter().rev().collect()
        };
        for d in order {
            let (pooled, _) = eval_json_pooled(d, EvalOptions::default(), Some(&pool)).unwrap();
            let (fresh, _) = eval_json(d, EvalOptions::default()).unwrap();
            assert_eq!(
                pooled, fresh,
                "round {round}: pooled answer differs from a new evaluator's"
            );
        }
    }
    // One evaluator per key (backend request, size class, accuracy): all these calls are
    // CPU calls of fewer than 64 states at the default accuracy.
    assert_eq!(
        pool.created(),
        1,
        "evaluators created for 8 sequential calls"
    );
}
