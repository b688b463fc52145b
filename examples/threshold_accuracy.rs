//! Threshold speed of issue 20's rotor with the finite film against the film's accuracy
//! (issue 20): 2.963 kg rigid rotor on two paper bearings at ±0.1 m, gravity −y, spin
//! held, max-film inlet; the scan 450-480 rad/s every 10 and the bracketing, at each
//! accuracy given (default: 2e-3 5e-4 1.25e-4), with the wall time and the grid of the
//! coefficients at the threshold's stable end.
//!
//! `cargo run --release --example threshold_accuracy [accuracy ...]`

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::rotor::load_scene;
use bearing_sweep::stability::{analyse_points, thresholds, RotorDescription};

fn rotor(accuracy: f64) -> RotorDescription {
    let bearing = |z: f64| {
        serde_json::json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4,
            "viscosity": 0.0242, "axial_position": z, "model": "finite",
            "finite": {"accuracy": accuracy}})
    };
    let json = serde_json::json!({
        "name": "issue-20 rotor",
        "rotor": {"mass": 2.963, "inertia": [0.01174, 0.01174, 0.008393]},
        "bearings": [bearing(0.1), bearing(-0.1)],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": 450.0},
        "integrator": {"t_end": 0.1}
    });
    RotorDescription::from_scene(&load_scene(&json.to_string()).unwrap().remove(0)).unwrap()
}

fn main() {
    let mut acc: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    if acc.is_empty() {
        acc = vec![2e-3, 5e-4, 1.25e-4];
    }
    let grid: Vec<f64> = (0..4).map(|k| 450.0 + 10.0 * k as f64).collect();
    for a in acc {
        let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
        let mut ev = LoadEvaluator::new(b);
        let r = rotor(a);
        let t = std::time::Instant::now();
        let th = thresholds(&mut ev, &[&r], std::slice::from_ref(&grid)).remove(0);
        let wall = t.elapsed().as_secs_f64();
        let grid_used = th
            .speed_rad_s
            .and_then(|w| analyse_points(&mut ev, &[(&r, w)]).remove(0).ok())
            .map(|s| s.linear.bearings[0].coefficients.grid);
        println!(
            "accuracy {a:e}: threshold {:?} rad/s, whirl ratio {:?}, failed {:?}, growth {:?}, \
             {wall:.1} s, grid {grid_used:?}, finite states {}",
            th.speed_rad_s,
            th.whirl_ratio,
            th.failed,
            th.grid_growth_1_s,
            ev.stats().finite_states
        );
    }
}
