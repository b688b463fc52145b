//! Cost probe of the JFO (mass-conserving) finite film against Swift–Stieber at equal grid
//! (BENCHMARKS.md "Issue 27"): one thread, cold starts, the 32 states of the finite
//! benchmark (B/D = 0.5, ε 0.1-0.9, tilted, whirling; fed on the maximum-film line, where
//! both models give the same field) and the same states with an ambient axial groove at
//! 180° instead (the film reforms inside the land: JFO departs from Swift–Stieber), fixed
//! grids, tolerance 1e-8. Per setting: ms/state (minimum over `reps` repetitions, the
//! machine is shared), states/s, counted work (sweeps of the grid: node updates over the
//! interior nodes; the JFO count includes its Swift–Stieber multigrid start) and the
//! largest relative difference of the load vectors JFO vs Swift–Stieber.
//!
//! `cargo run --release --example jfo_cost -- [reps]`
use std::time::Instant;

use bearing_sweep::bearing::finite::{
    Cavitation, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver,
};
use bearing_sweep::bearing::{finish_loads, pack_state, Groove, Grooves};
use bearing_sweep::bench::finite::bench_states;

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let (p0, states) = bench_states(32);
    println!("| feed | grid | model | ms/state | states/s | sweeps/state | max rel. difference JFO vs SS |");
    println!("|---|---|---|---|---|---|---|");
    for groove in [false, true] {
        let mut p = p0;
        if groove {
            p.grooves = Grooves::new(&[Groove {
                angle: 180.0,
                width: 20.0,
                supply_pressure: 0.0,
                length: None,
            }])
            .expect("one groove");
        }
        let jobs: Vec<_> = states
            .iter()
            .map(|s| {
                let packed = pack_state(&p, s).expect("valid state");
                (
                    FiniteJob::of_state(&p, &packed, s.omega),
                    packed.rate_scale,
                    *s,
                )
            })
            .collect();
        for (t, z) in [(64, 16), (128, 32), (256, 64)] {
            let mut loads: Vec<Vec<[f64; 4]>> = Vec::new();
            let mut rows = Vec::new();
            for cav in [Cavitation::Reynolds, Cavitation::Jfo] {
                let settings = FiniteSettings {
                    cavitation: cav,
                    ..FiniteSettings::with_grid(t, z)
                };
                let mut params = p;
                params.finite = settings;
                let g = FiniteGrid::for_bearing(&params);
                let mut solver = FiniteSolver::new();
                let mut best = f64::INFINITY;
                let mut sweeps = 0u64;
                let mut out = Vec::new();
                for _ in 0..reps {
                    sweeps = 0;
                    out.clear();
                    let start = Instant::now();
                    for (job, scale, s) in &jobs {
                        let mut field = Vec::new();
                        let (ints, rep) = solver.solve(job, &g, &mut field);
                        sweeps += rep.sweeps as u64;
                        out.push(
                            finish_loads(&params, s, &ints, *scale).load_vector(params.length),
                        );
                    }
                    best = best.min(start.elapsed().as_secs_f64());
                }
                let per = best / jobs.len() as f64;
                rows.push((cav, per, sweeps as f64 / jobs.len() as f64));
                loads.push(out);
            }
            let diff = loads[0]
                .iter()
                .zip(&loads[1])
                .map(|(a, b)| {
                    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
                    d / a.iter().map(|x| x * x).sum::<f64>().sqrt()
                })
                .fold(0.0, f64::max);
            for (cav, per, sw) in rows {
                println!(
                    "| {} | {t} × {z} | {} | {:.3} | {:.0} | {:.0} | {} |",
                    if groove {
                        "groove at 180°"
                    } else {
                        "max-film line"
                    },
                    cav.name(),
                    per * 1e3,
                    1.0 / per,
                    sw,
                    if cav == Cavitation::Jfo {
                        format!("{diff:.1e}")
                    } else {
                        "—".into()
                    }
                );
            }
        }
    }
}
