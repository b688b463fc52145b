//! Issue 13 item 8: validating a sweep costs in proportion to the spec, not to the grid.
//! A 10^8-variant grid used to be validated variant by variant (minutes); now every
//! factor value is checked once (range axes at 65 spread values) plus 1000 sampled
//! variants. Counted validator calls are the measure (timings live in BENCHMARKS.md).

use std::cell::Cell;

use bearing_sweep::sweep::expand::{RANGE_CHECKS, SAMPLED_VARIANTS, VALIDATE_EVERY_VARIANT_BELOW};
use bearing_sweep::sweep::{parse_spec, Expansion, SweepError};
use serde_json::{json, Value};

/// A grid of 100 (list) x 10^4 (linspace) x 100 (logspace) = 10^8 variants.
fn big_grid(bad_spin: Option<f64>) -> Value {
    let mut spins: Vec<Value> = (0..100).map(|i| json!(50.0 + i as f64)).collect();
    if let Some(s) = bad_spin {
        spins[99] = json!(s);
    }
    json!({"kind": "synthetic", "base": {"spin": 100, "duration": 1.0, "bearings": [{"whirl": 0.0}]},
           "axes": [{"path": "spin", "values": spins},
                    {"path": "duration", "linspace": [2.0, 1.0, 10000]},
                    {"path": "bearings[0].whirl", "logspace": [1e-9, 1e-6, 100]}]})
}

thread_local! {
    /// Validator calls on this test's thread.
    static CALLS: Cell<u64> = const { Cell::new(0) };
}

/// The synthetic validator, counting its calls.
fn counting(scene: &Value) -> Result<(), (String, String)> {
    CALLS.with(|c| c.set(c.get() + 1));
    bearing_sweep::sweep::synthetic::validate(scene)
}

fn calls() -> u64 {
    CALLS.with(Cell::get)
}

#[test]
fn a_huge_grid_is_validated_in_spec_proportional_calls() {
    let spec = parse_spec(&big_grid(None), None).unwrap();
    let e = Expansion::new(&spec);
    assert_eq!(e.count(), 100_000_000);
    e.validate_all(&spec, &counting).unwrap();
    // 100 list values + 65 + 65 range values + 1000 samples (+ the last id).
    let bound = 100 + 2 * RANGE_CHECKS + SAMPLED_VARIANTS + 1;
    assert!(
        calls() <= bound,
        "validator calls: actual {}, expected at most {bound}",
        calls()
    );
}

#[test]
fn the_failing_variant_and_path_are_still_named() {
    let spec = parse_spec(&big_grid(Some(0.0)), None).unwrap();
    let e = Expansion::new(&spec);
    match e.validate_all(&spec, &counting) {
        Err(SweepError::Variant {
            id,
            assignment,
            path,
            reason,
        }) => {
            assert_eq!(id, 99 * 10_000 * 100, "{assignment}");
            assert_eq!(path, "spin");
            assert!(
                assignment.contains("spin = 0.0") && reason.contains("positive"),
                "{assignment}: {reason}"
            );
        }
        other => panic!("expected a variant error, got {other:?}"),
    }
    assert!(calls() <= 200, "found after {} calls", calls());
    // A bad end of a range axis is found at its end.
    let mut doc = big_grid(None);
    doc["axes"][1]["linspace"] = json!([2.0, -1.0, 10000]);
    let spec = parse_spec(&doc, None).unwrap();
    match Expansion::new(&spec).validate_all(&spec, &bearing_sweep::sweep::synthetic::validate) {
        Err(SweepError::Variant { path, .. }) => assert_eq!(path, "duration"),
        other => panic!("expected a variant error, got {other:?}"),
    }
}

#[test]
fn small_sweeps_still_check_every_variant() {
    // 50 x 50 = 2500 variants <= the threshold: one inner-grid variant alone is bad
    // (duration and samples are fine separately; spin 0 only at one grid point).
    let doc = json!({"kind": "synthetic", "base": {"spin": 1.0, "duration": 1.0},
        "axes": [{"path": "spin", "linspace": [-1.0, 1.0, 51]}, {"path": "duration", "linspace": [1.0, 2.0, 49]}]});
    let spec = parse_spec(&doc, None).unwrap();
    let e = Expansion::new(&spec);
    assert!(e.count() <= VALIDATE_EVERY_VARIANT_BELOW);
    match e.validate_all(&spec, &counting) {
        Err(SweepError::Variant { id, path, .. }) => {
            assert_eq!((id, path.as_str()), (25 * 49, "spin"));
        }
        other => panic!("expected a variant error, got {other:?}"),
    }
    assert_eq!(calls(), 25 * 49 + 1, "every variant up to the failing one");
}
