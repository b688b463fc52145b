//! The oil-whirl scene with both film cavitation models (BENCHMARKS.md "Issue 27",
//! docs/jfo.md): sweeps/oil-whirl.json (1 kg rotor, no gravity, 300 rad/s held, two
//! bearings B/D = 0.5) for `t_end` seconds, both bearings on the finite film at 36 × 8,
//! fed either on the maximum-film line (default inlet) or by two ambient axial grooves
//! at 0° and 180° (20° wide), `"reynolds"` against `"jfo"` (film fraction carried through
//! the run). Per run: largest orbit radius and smallest h_min of bearing 0, finite
//! states evaluated and their mean work in sweeps of the grid (counted, noise-free),
//! wall time (one evaluator, rayon over the two bearings' states).
//!
//! Second table: bearing 0's film friction power, side flow and inlet flow averaged over
//! the second half of the run (trapezoid over the samples). JFO: the samples' own `film`
//! series (the film fraction carried through the run). Swift–Stieber: its film has no
//! history, so each sampled state is solved again with `bearing_loads` (its steady film
//! is the model), the journal velocity from central differences of the sampled positions
//! (sample interval 1e-4 s, whirl ~150 rad/s: relative error ~(ω Δt)²/6 ≈ 4e-5).
//!
//! `cargo run --release --example jfo_whirl -- [t_end] [rtol]`
use std::time::Instant;

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::{bearing_loads, Accuracy, BearingState, FilmRule};
use bearing_sweep::rotor::{load_scene, simulate_batch, Scene};

fn main() {
    let arg = |k: usize, d: f64| {
        std::env::args()
            .nth(k)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (t_end, rtol) = (arg(1, 0.5), arg(2, 1e-6));
    println!("| feed | cavitation | max orbit radius / δ | min h_min µm | finite states | sweeps/state | wall s | states/s |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut flows = Vec::new();
    let rule = FilmRule::new(Accuracy::new(1e-9).unwrap().settings());
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
            let params = s.bearings[0].params();
            let clearance = params.clearance;
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
            let sweeps = ev.stats().finite_sweeps as f64 / n as f64;
            // Bearing 0's film power and flows per sample: (power W, side m³/s, inlet m³/s).
            let t = &r.samples.t;
            let per_sample: Vec<[f64; 3]> = match &b0.film {
                Some(f) => (0..t.len())
                    .map(|k| {
                        [
                            f.power_loss_w[k],
                            f.side_flow_m3_per_s[k],
                            f.inlet_flow_m3_per_s[k],
                        ]
                    })
                    .collect(),
                None => (0..t.len())
                    .map(|k| {
                        let (a, c) = (k.saturating_sub(1), (k + 1).min(t.len() - 1));
                        let d = |v: &[f64]| (v[c] - v[a]) / (t[c] - t[a]);
                        let st = BearingState {
                            xi: b0.xi[k],
                            yi: b0.yi[k],
                            xj: b0.xj[k],
                            yj: b0.yj[k],
                            vxi: d(&b0.xi),
                            vyi: d(&b0.yi),
                            vxj: d(&b0.xj),
                            vyj: d(&b0.yj),
                            omega: r.samples.spin[k],
                        };
                        let l = bearing_loads(&params, &st, &rule).expect("a film state");
                        [
                            l.film.power_loss_w,
                            l.film.side_flow_m3_per_s,
                            l.film.inlet_flow_m3_per_s,
                        ]
                    })
                    .collect(),
            };
            let (mut acc, mut span) = ([0.0; 3], 0.0);
            for k in 1..t.len() {
                if t[k - 1] >= 0.5 * t_end {
                    let w = t[k] - t[k - 1];
                    for m in 0..3 {
                        acc[m] += 0.5 * w * (per_sample[k][m] + per_sample[k - 1][m]);
                    }
                    span += w;
                }
            }
            flows.push((grooves, cav, acc.map(|v| v / span)));
            println!(
                "| {} | {cav} | {:.4} | {:.2} | {n} | {sweeps:.1} | {wall:.1} | {:.0} |",
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
    println!();
    println!(
        "| feed | cavitation | mean power loss W | mean side flow cm³/s | mean inlet flow cm³/s |"
    );
    println!("|---|---|---|---|---|");
    for (grooves, cav, m) in flows {
        println!(
            "| {} | {cav} | {:.4} | {:.4} | {:.4} |",
            if grooves {
                "grooves 0°, 180°"
            } else {
                "max-film line"
            },
            m[0],
            m[1] * 1e6,
            m[2] * 1e6
        );
    }
}
