//! Issue 13: rotor samples are decimated to a cap so peak memory does not grow with
//! `t_end`. A long run with a small cap keeps at most `cap` samples, uniform on its
//! stride with the last sample at the true end, and its sweep reductions match the
//! full-resolution run within the tolerances stated in BENCHMARKS.md "Limits and memory".

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::budget::MemoryBudget;
use bearing_sweep::rotor::{load_scene, simulate_batch_capped, Scene, SimResult};
use bearing_sweep::sweep::reduce::{reduce, ReductionOptions};
use bearing_sweep::sweep::rotor_sim::signals_of;
use serde_json::Value;

const PAPER: &str = include_str!("../sweeps/paper-example.json");

fn cpu() -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(1e-6).unwrap()).unwrap();
    LoadEvaluator::new(b)
}

fn run(scene: &Scene, cap: usize) -> SimResult {
    simulate_batch_capped(
        std::slice::from_ref(scene),
        &mut cpu(),
        &mut |_, _| {},
        cap,
        MemoryBudget::default(),
    )
    .remove(0)
}

/// Every numeric leaf of `a` with its path and its relative difference from `b`'s,
/// scaled by the larger magnitude, at least `floor` (lengths, `*_m`: at least 10 µm, 1 %
/// of the 1 mm orbit of G, so near-zero orbit centres compare).
fn leaves(a: &Value, b: &Value, path: String, floor: f64, out: &mut Vec<(String, f64)>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                leaves(v, &y[k], format!("{path}.{k}"), floor, out);
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{path}");
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                leaves(v, w, format!("{path}[{i}]"), floor, out);
            }
        }
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            let floor = if path.ends_with("_m") { 1e-5 } else { floor };
            let scale = x.abs().max(y.abs()).max(floor);
            out.push((path, (x - y).abs() / scale));
        }
        _ => assert_eq!(a, b, "{path}"),
    }
}

#[test]
fn long_ideal_run_keeps_at_most_cap_samples_and_its_reductions() {
    let mut scene = load_scene(PAPER).unwrap().remove(1);
    // 40 001 sample times (~64 revolutions at 100 rad/s), cap 1024: stride 64.
    scene.integrator.t_end = 4.0;
    let cap = 1024;
    let full = run(&scene, usize::MAX / 2);
    let kept = run(&scene, cap);
    assert!(full.status.is_finished() && kept.status.is_finished());
    let (f, k) = (&full.samples, &kept.samples);
    assert_eq!((f.len(), f.sample_stride), (40_001, 1));
    assert!(k.len() <= cap && k.len() >= cap / 2, "{} kept", k.len());
    assert_eq!(k.sample_stride, 64);
    // The kept samples are the full run's at every stride-th time, the last at the end.
    let stride = k.sample_stride as usize;
    for (p, &t) in k.t[..k.len() - 1].iter().enumerate() {
        assert_eq!(t, f.t[p * stride]);
        assert_eq!(k.x_g[p], f.x_g[p * stride]);
    }
    assert_eq!(k.t.last(), f.t.last());
    assert_eq!(k.spin.last(), f.spin.last());
    // Reductions over the default window: means, extremes and orbits of a smooth
    // synchronous orbit sampled 98 times a revolution differ by < 1 % of each quantity.
    let opts = ReductionOptions::default();
    let a = serde_json::to_value(reduce(&signals_of(&full, &scene), &opts)).unwrap();
    let b = serde_json::to_value(reduce(&signals_of(&kept, &scene), &opts)).unwrap();
    let mut d = Vec::new();
    leaves(&a, &b, String::new(), 1e-12, &mut d);
    assert!(d.len() > 20, "{a}");
    for (path, rel) in &d {
        // Window start, sample counts and the times of extremes differ by up to a
        // stride by construction; the rest are physics.
        if path.contains("window") || path.ends_with("t_s") {
            continue;
        }
        assert!(
            *rel < 1e-2,
            "{path}: relative difference {rel:e}\nfull {a}\nkept {b}"
        );
    }
}
