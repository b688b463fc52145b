//! The oil-whirl scene with both film cavitation models (BENCHMARKS.md "Issue 27",
//! docs/jfo.md): sweeps/oil-whirl.json (1 kg rotor, no gravity, 300 rad/s held, two
//! bearings B/D = 0.5) for `t_end` seconds, both bearings on the finite film at 36 × 8,
//! fed either on the maximum-film line (default inlet) or by two ambient axial grooves
//! at 0° and 180° (20° wide), `"reynolds"` against `"jfo"` (film fraction carried through
//! the run). Per run: largest orbit radius and smallest h_min of bearing 0, finite
//! states evaluated, wall time (one evaluator, rayon over the two bearings' states).
//!
//! `cargo run --release --example jfo_whirl -- [t_end] [rtol]`
use std::time::Instant;

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::rotor::{load_scene, simulate_batch, Scene};

fn main() {
    let arg = |k: usize, d: f64| {
        std::env::args()
            .nth(k)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (t_end, rtol) = (arg(1, 0.5), arg(2, 1e-6));
    println!("| feed | cavitation | max orbit radius / δ | min h_min µm | finite states | wall s | states/s |");
    println!("|---|---|---|---|---|---|---|");
    for grooves in [false, true] {
        for cav in ["reynolds", "jfo"] {
            let mut s = load_scene(include_str!("../sweeps/oil-whirl.json"))
                .expect("the whirl scene loads")
                .remove(0);
            s.integrator.t_end = t_end;
            s.integrator.rtol = rtol;
            s.integrator.atol = rtol * 1e-3;
            let mut v = serde_json::to_value(&s).expect("scene to JSON");
            for b in v["bearings"].as_array_mut().expect("bearings") {
                b["model"] = "finite".into();
                b["finite"] = serde_json::json!({"n_theta": 36, "n_z": 8, "cavitation": cav});
                if grooves {
                    b["grooves"] = serde_json::json!([
                        {"angle": 0.0, "width": 20.0},
                        {"angle": 180.0, "width": 20.0}
                    ]);
                }
            }
            let s: Scene = serde_json::from_value(v).expect("scene from JSON");
            let clearance = s.bearings[0].params().clearance;
            let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(1e-9).unwrap()).unwrap();
            let mut ev = LoadEvaluator::new(b);
            let start = Instant::now();
            let r = simulate_batch(&[s], &mut ev, &mut |_, _| {}).remove(0);
            let wall = start.elapsed().as_secs_f64();
            let b0 = &r.samples.bearings[0];
            let radius = b0
                .xi
                .iter()
                .zip(&b0.yi)
                .map(|(x, y)| x.hypot(*y))
                .fold(0.0, f64::max);
            let h_min = b0.h_min.iter().cloned().fold(f64::INFINITY, f64::min);
            let n = ev.stats().finite_states;
            println!(
                "| {} | {cav} | {:.4} | {:.2} | {n} | {wall:.1} | {:.0} |",
                if grooves {
                    "grooves 0°, 180°"
                } else {
                    "max-film line"
                },
                radius / clearance,
                h_min * 1e6,
                n as f64 / wall
            );
        }
    }
}
