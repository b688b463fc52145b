//! Reductions as the run goes (issue 21 item 7): a rotor variant keeps only its window,
//! the run's totals and the samples its whole-run series show. Its reductions and kept
//! series are bit for bit those of the stored samples (windows of fixed length, and
//! fraction windows of runs that reach `t_end` or whose record was not decimated), a run
//! that ends early is reduced over a fraction window from a bounded record within stated
//! tolerances, and the samples it holds do not grow with `t_end`. JFO finite-film
//! bearings' film series are reduced too (issue 27).

use std::collections::BTreeSet;

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::sweep::reduce::{
    kept_series, reduce, stats, whirl, ReductionOptions, SeriesGroup, Span, Window,
};
use bearing_sweep::sweep::rotor_sim::RotorSimulator;
use bearing_sweep::sweep::runner::{BatchSimulator, Outcome, VariantJob};
use bearing_sweep::sweep::stream::{EARLY_END_RECORD, WHIRL_TAIL, WINDOW_SAMPLES};
use serde_json::{json, Value};

/// Step limit of the early-ended runs (tuned so the run has more samples than the record).
const STEPS: u64 = 20_000;

/// Step limit of the coarse-record whirl run (tuned so its record's stride, at 1e-2 s
/// samples and a 4096-sample record, is 2 or more: a Nyquist limit below `max_ratio`;
/// twice as many steps give stride 4 and a limit below the synchronous whirl).
const WHIRL_STEPS: u64 = 200_000;

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
    run_within(scenes, opts, None)
}

/// [`run`] within the memory budget `max_memory` (bytes; default 2 GiB).
fn run_within(
    scenes: &[Value],
    opts: Option<&ReductionOptions>,
    max_memory: Option<u64>,
) -> Vec<Outcome> {
    let accuracy = Accuracy::default();
    let backend = create_backend(BackendKind::Cpu, accuracy).unwrap().0;
    let mut sim = RotorSimulator::new(LoadEvaluator::new(backend), accuracy);
    if let Some(o) = opts {
        sim.set_reductions(o);
    }
    if let Some(b) = max_memory {
        sim.set_max_memory(bearing_sweep::budget::MemoryBudget::new(b));
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
        // Fractions of the run (the default half, a short one, the whole run): their
        // start is known in advance for the runs that reach t_end; the early-ended run
        // is reduced from its record (1001 samples at most here: not decimated).
        (Window::Fraction(0.5), Span::Run),
        (Window::Fraction(0.5), Span::Window),
        (Window::Fraction(0.013), Span::Window),
        (Window::Fraction(1.0), Span::Run),
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

/// `(path, value)` of every number under `v`.
fn leaves(path: &str, v: &Value, out: &mut Vec<(String, f64)>) {
    match v {
        Value::Object(m) => m
            .iter()
            .for_each(|(k, x)| leaves(&format!("{path}.{k}"), x, out)),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| leaves(&format!("{path}[{i}]"), x, out)),
        Value::Number(n) => out.push((path.to_string(), n.as_f64().unwrap())),
        _ => {}
    }
}

/// The tolerance of a reduction from the decimated record against the exact one, by
/// field (`None`: not compared; `Some(0)`: equal). Measured at strides 4 and 8 (the paper
/// rotor, 52 119 and 104 237 samples into a record of 16 384): window means 2.3e-7
/// relative, window min/max 6.1e-6, orbit sizes and centres 2.0e-4 of the orbit's
/// radius, whirl ratio 5.7e-11, whirl amplitude 2.1e-7, sub-synchronous (side-lobe)
/// ratio 2.6e-5 and amplitude 6.5e-6, window start and revolutions 3.9e-5 (within one
/// kept sample interval); run extremes are kept from every sample: exact. Allowed: about
/// 4 times those.
fn record_tolerance(path: &str) -> Option<(f64, bool)> {
    let leaf = path.rsplit('.').next().unwrap();
    let rel = |x| Some((x, true));
    if path.contains("h_min") || path.contains("_peak_n") || path.contains("eccentricity_max") {
        return Some((0.0, false));
    }
    if path.contains("orbit.") {
        // Absolute, in units of the orbit's radius (applied by the caller).
        return Some((8e-4, false));
    }
    match leaf {
        "samples" | "record_samples" | "sample_stride" | "truncated" => None,
        "t_end_s" => Some((0.0, false)),
        "t_start_s" | "revolutions" => rel(1.6e-4),
        "mean" | "power_loss_w" | "amplitude_m" => rel(1e-6),
        "min" | "max" => rel(2.5e-5),
        "ratio" | "whirl_ratio" => Some((1e-9, false)),
        "subsync_ratio" | "subsync_amplitude_m" => rel(1e-4),
        _ => Some((0.0, false)),
    }
}

/// Checks every number of `got` (reductions from decimated samples) against `exact`'s
/// within [`record_tolerance`]; returns how many were compared.
fn within_record_tolerance(at: &str, got: &Value, exact: &Value) -> usize {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    leaves("", got, &mut a);
    leaves("", exact, &mut b);
    let mut compared = 0;
    for (path, y) in &b {
        let Some((tol, relative)) = record_tolerance(path) else {
            continue;
        };
        let x = a
            .iter()
            .find(|(p, _)| p == path)
            .unwrap_or_else(|| panic!("{path} missing"))
            .1;
        let scale = if path.contains("orbit.") {
            // The orbit's radius (exact).
            let radius = format!("{}.radius_m", path.rsplit_once('.').unwrap().0);
            b.iter().find(|(p, _)| *p == radius).unwrap().1
        } else if relative {
            y.abs()
        } else {
            1.0
        };
        assert!(
            (x - y).abs() <= tol * scale,
            "{at}: {path}: from the record {x}, exact {y} (tolerance {tol} x {scale})"
        );
        compared += 1;
    }
    compared
}

#[test]
fn early_ended_fraction_window_comes_from_a_bounded_record() {
    // The paper rotor sampled every 1e-4 s towards t_end = 1000 s, stopped by the step
    // limit: its half-run window is not known in advance, so it is reduced from the
    // record of the whole run (at most EARLY_END_RECORD samples, decimated). Stored, the
    // run keeps every sample (one variant: the budget's cap is millions). Two step
    // limits: the samples held do not grow with the run.
    let opts = ReductionOptions::default();
    let mut held = Vec::new();
    for steps in [STEPS, 2 * STEPS] {
        let mut s = scene(3e-4, 1000.0, steps);
        s["integrator"]["sample_interval"] = json!(1e-4);
        let stored = run(std::slice::from_ref(&s), None);
        let streamed = run(&[s], Some(&opts));
        assert_ne!(stored[0].status, "ok", "the step limit ends the run");
        let signals = stored[0].signals.as_ref().unwrap();
        let samples = signals.t.len();
        assert!(
            samples > 3 * EARLY_END_RECORD,
            "{samples} samples: record not decimated"
        );
        let exact = serde_json::to_value(reduce(signals, &opts)).unwrap();
        let red = streamed[0].reduced.as_ref().unwrap();
        let got = serde_json::to_value(&red.reductions).unwrap();
        // Said in the result: the window came from a decimated record.
        let w = &got["window"];
        let record = w["record_samples"]
            .as_u64()
            .expect("record_samples reported") as usize;
        assert!(record <= EARLY_END_RECORD + 1, "record of {record} samples");
        assert!(w["sample_stride"].as_u64().unwrap() >= 4, "{w}");
        held.push(red.peak_stored_samples);
        let compared = within_record_tolerance(&format!("steps {steps}"), &got, &exact);
        assert!(compared > 60, "{compared} numbers compared");
    }
    // The record and its latest sample and the full-rate end for the whirl; the tail
    // (the window of a run that reaches t_end = 1000 s starts at 500 s) holds nothing.
    for h in &held {
        assert!(*h <= EARLY_END_RECORD + 1 + WHIRL_TAIL, "held {h} samples");
    }
    assert_eq!(held[0], held[1], "held samples grew with the run: {held:?}");
}

#[test]
fn default_window_held_samples_do_not_grow_with_t_end() {
    // The default half-run window of runs that reach t_end = 4 s and 16 s (8001 and
    // 32 001 samples) under a budget whose sample cap is the floor (4096): the tail
    // holds the window, decimated beyond the cap, and the record at most 4096 samples
    // whatever t_end. Stored, the run keeps up to the cap as well, but the tail's window
    // is every sample where the stored run was: the 4 s run's reductions are bit for bit
    // those of its stored samples.
    let opts = ReductionOptions::default();
    // 2 MiB: one variant of 26 numbers per sample gets the floor cap, 4096.
    let tiny = Some(2 << 20);
    let mut held = Vec::new();
    for t_end in [4.0, 16.0] {
        let s = scene(3e-4, t_end, 10_000_000);
        let o = run_within(std::slice::from_ref(&s), Some(&opts), tiny);
        assert_eq!(o[0].status, "ok", "t_end {t_end}: {:?}", o[0].message);
        let red = o[0].reduced.as_ref().unwrap();
        held.push(red.peak_stored_samples);
        if t_end == 4.0 {
            let stored = run(&[s], None);
            let want =
                serde_json::to_value(reduce(stored[0].signals.as_ref().unwrap(), &opts)).unwrap();
            same(
                "default window, 4 s",
                &serde_json::to_value(&red.reductions).unwrap(),
                &want,
            );
        } else {
            // 16 000 window samples over a cap of 4096: decimated, and said so.
            let w = serde_json::to_value(red.reductions.window).unwrap();
            assert_eq!(w["sample_stride"], json!(4), "{w}");
            assert!(w.get("record_samples").is_none(), "{w}");
        }
    }
    let (short, long) = (held[0], held[1]);
    assert!(
        (long as f64) <= 1.1 * short as f64,
        "held samples grew with t_end: {short} at 4 s, {long} at 16 s (allowed 1.1x)"
    );
    assert!(
        long <= 3 * 4096 + 2,
        "held {long}: over the tail's, record's and full-rate end's caps"
    );
}

#[test]
fn fraction_window_is_held_up_to_a_constant_not_the_budget() {
    // One variant of 140 001 samples (14 s every 1e-4 s) reaching t_end: its half-run
    // window (70 001 samples) is over WINDOW_SAMPLES, so it is kept every other sample
    // whatever the budget (the 2 GiB default's cap is 2^22 samples, 64 GiB's 2^27), and
    // the held samples are the same under both. Against every sample (stored), the
    // decimated window's reductions are within the record's tolerances.
    let opts = ReductionOptions::default();
    let mut s = scene(3e-4, 14.0, 10_000_000);
    s["integrator"]["sample_interval"] = json!(1e-4);
    let stored = run(std::slice::from_ref(&s), None);
    let samples = stored[0].signals.as_ref().unwrap().t.len();
    assert!(samples / 2 > WINDOW_SAMPLES, "{samples} samples");
    let exact = serde_json::to_value(reduce(stored[0].signals.as_ref().unwrap(), &opts)).unwrap();
    let mut held = Vec::new();
    for budget in [None, Some(64 << 30)] {
        let o = run_within(std::slice::from_ref(&s), Some(&opts), budget);
        assert_eq!(o[0].status, "ok", "{:?}", o[0].message);
        let red = o[0].reduced.as_ref().unwrap();
        held.push(red.peak_stored_samples);
        let got = serde_json::to_value(&red.reductions).unwrap();
        assert_eq!(
            got["window"]["sample_stride"],
            json!(2),
            "{}",
            got["window"]
        );
        assert!(got["window"].get("record_samples").is_none());
        let compared = within_record_tolerance(&format!("budget {budget:?}"), &got, &exact);
        assert!(compared > 60, "{compared} numbers compared");
        // Not alias-limited at stride 2: the whirl is the window's, not the tail's.
        for b in got["bearings"].as_array().unwrap() {
            assert!(b["whirl"].get("samples").is_none(), "{}", b["whirl"]);
        }
    }
    assert_eq!(held[0], held[1], "held samples follow the budget: {held:?}");
    // The tail (at most WINDOW_SAMPLES + 1 and the latest sample), the record and the
    // full-rate end, all three bounded by constants.
    assert!(
        held[0] <= WINDOW_SAMPLES + 2 + EARLY_END_RECORD + 1 + WHIRL_TAIL,
        "held {held:?}"
    );
}

#[test]
fn coarse_record_takes_the_whirl_from_the_full_rate_tail() {
    // A long run ended early by the step limit under a budget whose sample cap is the
    // floor (4096): its record is decimated to a stride whose Nyquist limit is below
    // the synchronous whirl (ratio 1), so the whirl comes from the full-rate end of the
    // window (4096 samples here) and says so; its ratio is the one of every stored
    // sample within the tail spectrum's grid step, and the search reaches max_ratio.
    // Two step limits: the held samples do not grow with the run.
    let opts = ReductionOptions::default();
    let tiny = Some(2 << 20);
    let mut held = Vec::new();
    for steps in [WHIRL_STEPS, 2 * WHIRL_STEPS] {
        let mut s = scene(3e-4, 1000.0, steps);
        s["integrator"]["sample_interval"] = json!(1e-2);
        s["integrator"]["rtol"] = json!(1e-4);
        let o = run_within(std::slice::from_ref(&s), Some(&opts), tiny);
        assert_ne!(o[0].status, "ok", "the step limit ends the run");
        let red = o[0].reduced.as_ref().unwrap();
        held.push(red.peak_stored_samples);
        let got = serde_json::to_value(&red.reductions).unwrap();
        let stride = got["window"]["sample_stride"].as_u64().expect("decimated") as f64;
        let stored = run(&[s], None);
        let signals = stored[0].signals.as_ref().unwrap();
        let exact = serde_json::to_value(reduce(signals, &opts)).unwrap();
        for (k, b) in got["bearings"].as_array().unwrap().iter().enumerate() {
            let w = &b["whirl"];
            let want = &exact["bearings"][k]["whirl"];
            // The kept samples' Nyquist ratio (as `whirl` computes it, with its 10 %
            // margin) is below max_ratio (2.5), and for the longer run below the whirl:
            // searched from them, ratio 1 would be missed.
            let ew = &exact["window"];
            let spin = std::f64::consts::TAU * ew["revolutions"].as_f64().unwrap()
                / (ew["t_end_s"].as_f64().unwrap() - ew["t_start_s"].as_f64().unwrap());
            let nyquist = 0.9 * std::f64::consts::PI / (stride * 1e-2 * spin);
            let below = if steps > WHIRL_STEPS { 1.0 } else { 2.5 };
            assert!(
                nyquist < below,
                "steps {steps} bearing {k}: Nyquist {nyquist}"
            );
            let n = w["samples"].as_u64().expect("whirl from the tail") as usize;
            // The full-rate end (4096 samples at this budget's cap) inside the window
            // (from its first kept sample: at most a stride after the exact start).
            let full = exact["window"]["samples"].as_u64().unwrap() as usize;
            let want_n = full.min(4096);
            assert!(
                n <= want_n && n + stride as usize >= want_n,
                "{n} tail samples, expected {want_n}: {w}"
            );
            assert!(w.get("searched_up_to_ratio").is_none(), "{w}");
            assert!(want.get("searched_up_to_ratio").is_none(), "{want}");
            // The tail spectrum's grid step, 1 / (4 revolutions of the tail).
            let revs = spin
                * (got["window"]["t_end_s"].as_f64().unwrap() - w["t_start_s"].as_f64().unwrap())
                / std::f64::consts::TAU;
            let (r, r0) = (
                w["ratio"].as_f64().unwrap(),
                want["ratio"].as_f64().unwrap(),
            );
            assert!(
                (r - r0).abs() <= 0.25 / revs,
                "steps {steps} bearing {k}: whirl ratio {r} from the tail, {r0} exact ({revs} revolutions)"
            );
            // The same spectrum from the stored samples of the tail's span: every number
            // of the whirl equal (the ring holds exactly those samples). Its amplitude is
            // the tail's own: the whole window's peak is lower where the spin, and with it
            // the synchronous whirl, drifts over the window (0.74 relative at 400 000 steps).
            let t = &signals.t;
            let from = t.partition_point(|&x| x < w["t_start_s"].as_f64().unwrap());
            let spin_mean = stats(&t[from..], &signals.spin[from..]).unwrap().mean;
            let b = &signals.bearings[k];
            let mut by_hand = whirl(
                &t[from..],
                &b.xi[from..],
                &b.yi[from..],
                spin_mean,
                b.clearance_m,
                &opts.whirl,
            )
            .expect("a whirl over the tail");
            by_hand.samples = Some(t.len() - from);
            by_hand.t_start_s = Some(t[from]);
            same(
                &format!("steps {steps} bearing {k}: tail whirl"),
                w,
                &serde_json::to_value(by_hand).unwrap(),
            );
            eprintln!(
                "steps {steps} bearing {k}: stride {stride}, Nyquist ratio {nyquist:.3}, ratio {r} from {n} tail samples vs {r0} (diff {:.2e}, grid step {:.2e})",
                (r - r0).abs(),
                0.25 / revs
            );
        }
        // The variant's ratio is that of the bearing with the largest amplitude.
        let largest = got["bearings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b| &b["whirl"])
            .fold(None::<&Value>, |best, w| match best {
                Some(b) if b["amplitude_m"].as_f64() >= w["amplitude_m"].as_f64() => Some(b),
                _ => Some(w),
            })
            .unwrap();
        assert_eq!(got["whirl_ratio"], largest["ratio"]);
    }
    assert_eq!(held[0], held[1], "held samples grew with the run: {held:?}");
    assert!(held[0] <= 3 * 4096 + 2, "held {held:?}");
}

/// The oil-whirl scene (sweeps/oil-whirl.json) for `t_end` s with both bearings on the
/// finite film, 36 × 8, with `cavitation`.
fn finite_whirl(cavitation: &str, t_end: f64) -> Value {
    let mut s: Value = serde_json::from_str(include_str!("../sweeps/oil-whirl.json")).unwrap();
    s["integrator"]["t_end"] = json!(t_end);
    s["integrator"]["rtol"] = json!(1e-6);
    s["integrator"]["atol"] = json!(1e-9);
    for b in s["bearings"].as_array_mut().unwrap() {
        b["model"] = json!("finite");
        b["finite"] = json!({"n_theta": 36, "n_z": 8, "cavitation": cavitation});
    }
    s
}

#[test]
fn jfo_film_series_are_reduced_over_the_window() {
    // Issue 27: a JFO finite-film rotor's samples carry the film's friction and flows;
    // the reductions give their window statistics per bearing, streamed and stored alike
    // (bit for bit), equal to a hand reduction of the samples' series (trapezoidal mean
    // over the second half of the run, min and max over its samples).
    use bearing_sweep::rotor::{simulate_batch, Scene};
    let s = finite_whirl("jfo", 0.01);
    let opts = ReductionOptions::default();
    let streamed = run(std::slice::from_ref(&s), Some(&opts));
    let stored = run(std::slice::from_ref(&s), None);
    assert_eq!(streamed[0].status, "ok", "{:?}", streamed[0].message);
    let red = serde_json::to_value(&streamed[0].reduced.as_ref().unwrap().reductions).unwrap();
    let want = serde_json::to_value(reduce(stored[0].signals.as_ref().unwrap(), &opts)).unwrap();
    same("jfo reductions", &red, &want);
    // By hand, from the rotor's own samples.
    let scene: Scene = serde_json::from_value(s).unwrap();
    let accuracy = Accuracy::default();
    let backend = create_backend(BackendKind::Cpu, accuracy).unwrap().0;
    let r = simulate_batch(&[scene], &mut LoadEvaluator::new(backend), &mut |_, _| {}).remove(0);
    let t = &r.samples.t;
    let n = t.len();
    let ts = t[n - 1] - 0.5 * (t[n - 1] - t[0]);
    let w0 = t.iter().position(|&x| x >= ts).unwrap();
    for (k, b) in r.samples.bearings.iter().enumerate() {
        let film = b.film.as_ref().expect("JFO samples carry the film series");
        for (name, v) in [
            ("power_loss_w", &film.power_loss_w),
            ("side_flow_m3_per_s", &film.side_flow_m3_per_s),
            ("inlet_flow_m3_per_s", &film.inlet_flow_m3_per_s),
            ("friction_torque_nm", &film.friction_torque_nm),
        ] {
            let (mut area, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
            for i in w0..n {
                lo = lo.min(v[i]);
                hi = hi.max(v[i]);
                if i > w0 {
                    area += 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1]);
                }
            }
            let mean = area / (t[n - 1] - t[w0]);
            let got = &red["bearings"][k]["film"][name];
            let at = format!("bearing {k} film.{name}");
            // The same sums in the same order up to the mean's division: rounding only.
            let m = got["mean"]
                .as_f64()
                .unwrap_or_else(|| panic!("{at}: {got}"));
            assert!(
                (m - mean).abs() <= 1e-12 * mean.abs().max(1e-30),
                "{at}: mean {m}, by hand {mean}"
            );
            assert_eq!(got["min"].as_f64(), Some(lo), "{at}: min");
            assert_eq!(got["max"].as_f64(), Some(hi), "{at}: max");
        }
        // Power loss is positive and the side flow leaves the film.
        assert!(
            red["bearings"][k]["film"]["power_loss_w"]["min"]
                .as_f64()
                .unwrap()
                > 0.0
        );
    }
}

#[test]
fn swift_stieber_finite_film_has_no_film_series_to_reduce() {
    // A Swift-Stieber (reynolds) finite film's samples carry no film series (only JFO
    // films carry their history and fill the film outputs, docs/jfo.md): its reductions
    // have no `film` block, as for the short film.
    use bearing_sweep::rotor::{simulate_batch, Scene};
    let s = finite_whirl("reynolds", 0.005);
    let opts = ReductionOptions::default();
    let streamed = run(std::slice::from_ref(&s), Some(&opts));
    assert_eq!(streamed[0].status, "ok", "{:?}", streamed[0].message);
    let red = serde_json::to_value(&streamed[0].reduced.as_ref().unwrap().reductions).unwrap();
    for b in red["bearings"].as_array().unwrap() {
        assert!(b.get("film").is_none(), "{b}");
    }
    let scene: Scene = serde_json::from_value(s).unwrap();
    let accuracy = Accuracy::default();
    let backend = create_backend(BackendKind::Cpu, accuracy).unwrap().0;
    let r = simulate_batch(&[scene], &mut LoadEvaluator::new(backend), &mut |_, _| {}).remove(0);
    assert!(r.samples.bearings.iter().all(|b| b.film.is_none()));
}
