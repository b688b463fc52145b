//! Reductions as the run goes (issue 21 item 7): a rotor variant whose evaluation window
//! has a fixed length keeps only the window, the run's totals and the samples its
//! whole-run series show. Its reductions and kept series are bit for bit those of the
//! stored samples, and the samples it holds do not grow with `t_end`.

use std::collections::BTreeSet;

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::sweep::reduce::{
    kept_series, reduce, ReductionOptions, SeriesGroup, Span, Window,
};
use bearing_sweep::sweep::rotor_sim::RotorSimulator;
use bearing_sweep::sweep::runner::{BatchSimulator, Outcome, VariantJob};
use serde_json::{json, Value};

/// The paper rotor (sweeps/clearance-viscosity.json's base) at `clearance` m for `t_end` s,
/// samples every 5e-4 s, at most `max_steps` steps.
fn scene(clearance: f64, t_end: f64, max_steps: u64) -> Value {
    json!({
        "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
        "bearings": [
            {"radius": 0.02, "length": 0.02, "clearance": clearance, "viscosity": 0.0242, "axial_position": 0.2},
            {"radius": 0.02, "length": 0.02, "clearance": clearance, "viscosity": 0.0242, "axial_position": -0.1}
        ],
        "gravity": [0.0, 0.0, 0.0],
        "spin": "free",
        "initial": {"spin": 100.0},
        "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": t_end,
                       "sample_interval": 5e-4, "max_steps": max_steps},
        "film": {"threshold": 1e-6}
    })
}

/// The paper rotor at held spin asking for the constant friction coefficient (its check
/// reads every sample after the settling window).
fn held_with_friction_check() -> Value {
    let mut s = scene(3e-4, 0.5, 100_000);
    s["spin"] = json!("held");
    s["reductions"] = json!({"constant_friction": {"enabled": true, "settle_time": 0.1}});
    s
}

/// Runs `scenes` on the CPU, reduced as they go under `opts` (`stream`) or from stored
/// samples.
fn run(scenes: &[Value], opts: Option<&ReductionOptions>) -> Vec<Outcome> {
    let accuracy = Accuracy::default();
    let backend = create_backend(BackendKind::Cpu, accuracy).unwrap().0;
    let mut sim = RotorSimulator::new(LoadEvaluator::new(backend), accuracy);
    if let Some(o) = opts {
        sim.set_reductions(o);
    }
    let jobs: Vec<VariantJob> = scenes
        .iter()
        .enumerate()
        .map(|(i, s)| VariantJob {
            id: i as u64,
            scene: s.clone(),
        })
        .collect();
    let mut out: Vec<Option<Outcome>> = vec![None; jobs.len()];
    sim.run_batch(&jobs, &mut |k, o| out[k] = Some(o));
    out.into_iter()
        .map(|o| o.expect("every job reported"))
        .collect()
}

fn options(window: Window, span: Span) -> ReductionOptions {
    ReductionOptions {
        window,
        keep: [
            SeriesGroup::Orbit,
            SeriesGroup::Film,
            SeriesGroup::Friction,
            SeriesGroup::Forces,
            SeriesGroup::Spin,
        ]
        .into_iter()
        .collect::<BTreeSet<_>>(),
        points: 100,
        span,
        ..ReductionOptions::default()
    }
}

/// Every leaf of `a` equal to `b`'s (numbers bit for bit); panics naming the first path
/// that differs with both values.
fn same(path: &str, a: &Value, b: &Value) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let kx: Vec<_> = x.keys().collect();
            let ky: Vec<_> = y.keys().collect();
            assert_eq!(kx, ky, "{path}: keys differ");
            for (k, v) in x {
                same(&format!("{path}.{k}"), v, &y[k]);
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{path}: lengths differ");
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                same(&format!("{path}[{i}]"), u, v);
            }
        }
        (Value::Number(x), Value::Number(y)) => assert!(
            x.as_f64() == y.as_f64(),
            "{path}: streamed {x}, stored {y} (tolerance 0: bit for bit)"
        ),
        _ => assert_eq!(a, b, "{path}"),
    }
}

#[test]
fn streamed_reductions_equal_stored_ones_bit_for_bit() {
    // Finished runs (1001 samples), a run ended early by the step limit (fewer samples
    // than a finished one: the whole-run series come from the fallback store), and a
    // tight clearance.
    let scenes = [
        scene(3e-4, 0.5, 100_000),
        scene(1e-4, 0.5, 100_000),
        scene(3e-4, 0.5, 400),
        // Held spin with the constant-friction check: run as the samples come.
        held_with_friction_check(),
    ];
    let stored = run(&scenes, None);
    for (window, span) in [
        (Window::Revolutions(3.0), Span::Run),
        (Window::Revolutions(3.0), Span::Window),
        (Window::Seconds(0.1), Span::Run),
        (Window::Seconds(0.1), Span::Window),
        // Longer than the run: the whole run, truncated.
        (Window::Revolutions(1e4), Span::Window),
        (Window::Seconds(10.0), Span::Run),
    ] {
        let opts = options(window, span);
        let streamed = run(&scenes, Some(&opts));
        for (k, (s, r)) in streamed.iter().zip(&stored).enumerate() {
            let at = format!("{window:?} {span:?} variant {k}");
            assert_eq!(s.status, r.status, "{at}");
            assert_eq!(s.extra, r.extra, "{at}: sim record");
            let signals = r.signals.as_ref().expect("stored samples");
            assert!(
                s.signals.is_none(),
                "{at}: streamed variant stored its samples"
            );
            let red = s.reduced.as_ref().expect("reduced as it ran");
            let want = serde_json::to_value(reduce(signals, &opts)).unwrap();
            same(
                &format!("{at}: reductions"),
                &serde_json::to_value(&red.reductions).unwrap(),
                &want,
            );
            let series = kept_series(signals, &opts).expect("series kept");
            same(
                &format!("{at}: series"),
                red.series.as_ref().expect("series kept"),
                &series,
            );
        }
    }
    // The early-ended run really ended early (the fallback path was exercised), and the
    // friction check reported a deviation.
    assert_ne!(stored[2].status, "ok");
    let fr = &stored[3].extra.as_ref().unwrap()["model_reductions"]["declined"];
    assert!(
        fr.as_array()
            .unwrap()
            .iter()
            .any(|e| e["name"] == "constant_friction" && e["error"].is_number()),
        "no friction deviation reported: {fr}"
    );
}

#[test]
fn held_samples_do_not_grow_with_t_end() {
    // The example sweep's reductions: a 3-revolution window and a 100-point orbit over
    // the run. Stored, a run keeps every sample (up to the budget's cap): 8001 and 32001
    // here; reduced as it runs, the window's samples (about 380), the 100 picks and the
    // fallback store of at most 4097.
    let opts = ReductionOptions {
        window: Window::Revolutions(3.0),
        keep: [SeriesGroup::Orbit].into_iter().collect(),
        points: 100,
        span: Span::Run,
        ..ReductionOptions::default()
    };
    let peak = |t_end: f64| {
        let o = run(&[scene(3e-4, t_end, 10_000_000)], Some(&opts));
        assert_eq!(o[0].status, "ok", "t_end {t_end}: {:?}", o[0].message);
        o[0].reduced.as_ref().unwrap().peak_stored_samples
    };
    let (short, long) = (peak(4.0), peak(16.0));
    let samples_long = 32_001;
    assert!(
        (long as f64) <= 1.25 * short as f64,
        "held samples grew with t_end: {short} at 4 s, {long} at 16 s (allowed 1.25x)"
    );
    assert!(
        long < samples_long / 4,
        "held {long} samples of a {samples_long}-sample run (allowed a quarter)"
    );
}

#[test]
fn an_invalid_variant_streamed_reports_like_a_stored_one() {
    // A negative clearance fails the scene check before anything runs: no samples, no
    // panic in the whole-run series, the same record as the stored path.
    let bad = scene(-3e-4, 0.5, 100_000);
    let opts = options(Window::Revolutions(3.0), Span::Run);
    let stored = run(std::slice::from_ref(&bad), None);
    let streamed = run(&[bad], Some(&opts));
    assert_eq!(streamed[0].status, stored[0].status);
    assert_ne!(streamed[0].status, "ok");
    let red = streamed[0].reduced.as_ref().expect("reduced");
    let want = serde_json::to_value(reduce(stored[0].signals.as_ref().unwrap(), &opts)).unwrap();
    same(
        "invalid: reductions",
        &serde_json::to_value(&red.reductions).unwrap(),
        &want,
    );
    assert_eq!(red.series, None);
}
