//! Probe of the finite film's bearing coefficients under grid refinement (issue 20): on
//! a few aligned states of the paper bearing (B/D = 0.5), K and C (x-y blocks) on the
//! held ladder grids 64 × 8 … 1024 × 128, their change per refinement, and the errors
//! `coefficients` reports on each grid against the 1024 × 128 / 512 × 64
//! Richardson-extrapolated reference.
//!
//! `cargo run --release --example coef_convergence [finest_n_theta [ε angle ω]]` (default
//! 1024 and four states).

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::{Accuracy, BearingParams, FilmModel};
use bearing_sweep::stability::{
    aligned_state, coefficients_batch, pin_grid, BearingCoefficients, CoefficientJob, DiffOptions,
};

fn block(c: &BearingCoefficients) -> ([f64; 8], [f64; 8]) {
    let mut v = [0.0; 8];
    let mut e = [0.0; 8];
    for i in 0..2 {
        for j in 0..2 {
            v[2 * i + j] = c.stiffness[i][j];
            e[2 * i + j] = c.stiffness_error[i][j];
            v[4 + 2 * i + j] = c.damping[i][j];
            e[4 + 2 * i + j] = c.damping_error[i][j];
        }
    }
    (v, e)
}

fn main() {
    let finest: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1024);
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    let mut ev = LoadEvaluator::new(b);
    let p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let d = p.clearance;
    let names = ["Kxx", "Kxy", "Kyx", "Kyy", "Cxx", "Cxy", "Cyx", "Cyy"];
    // One state from the command line (`ε angle ω`), else the four of BENCHMARKS.md.
    let args: Vec<f64> = std::env::args()
        .skip(2)
        .filter_map(|s| s.parse().ok())
        .collect();
    let states: Vec<(f64, f64, f64)> = if args.len() >= 3 {
        vec![(args[0], args[1], args[2])]
    } else {
        vec![
            (0.517, -0.6, 500.0),
            (0.3, 0.9, 450.0),
            (0.7, 0.5, 450.0),
            (0.85, 2.0, 450.0),
        ]
    };
    for &(eps, angle, w) in &states {
        let state = aligned_state(eps * d * angle.cos(), eps * d * angle.sin(), w);
        let mut grids = Vec::new();
        let mut nt = 32;
        while nt <= finest {
            grids.push([nt, nt / 8]);
            nt *= 2;
        }
        let jobs: Vec<CoefficientJob> = grids
            .iter()
            .map(|&g| CoefficientJob {
                params: pin_grid(&p, Some(g)),
                state,
            })
            .collect();
        let t = std::time::Instant::now();
        let c: Vec<BearingCoefficients> =
            coefficients_batch(&mut ev, &jobs, &DiffOptions::default())
                .into_iter()
                .map(|c| c.unwrap())
                .collect();
        // The default accuracy's own choice, for comparison.
        let dflt = coefficients_batch(
            &mut ev,
            &[CoefficientJob { params: p, state }],
            &DiffOptions::default(),
        )
        .remove(0)
        .unwrap();
        println!(
            "state ε {eps} angle {angle} ω {w}: {:.1} s; default accuracy grid {:?}",
            t.elapsed().as_secs_f64(),
            dflt.grid
        );
        let n = c.len();
        let vals: Vec<([f64; 8], [f64; 8])> = c.iter().map(block).collect();
        let reference: [f64; 8] =
            std::array::from_fn(|k| (4.0 * vals[n - 1].0[k] - vals[n - 2].0[k]) / 3.0);
        let scale = reference
            .iter()
            .take(4)
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        let cscale = reference
            .iter()
            .skip(4)
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        for k in 0..8 {
            let s = if k < 4 { scale } else { cscale };
            print!("  {:>3} ref {:>11.5e}:", names[k], reference[k]);
            for (g, (v, e)) in grids.iter().zip(&vals) {
                let true_err = (v[k] - reference[k]).abs();
                print!(
                    " {}×{} err {:.1e} rep {:.1e} ({:.2})",
                    g[0],
                    g[1],
                    true_err / s,
                    e[k] / s,
                    e[k] / true_err.max(1e-300)
                );
            }
            println!();
            print!("      values:");
            for v in &vals {
                print!(" {:.7e}", v.0[k]);
            }
            println!();
        }
        // x-y block norms of the reported and the true error per grid, and the
        // successive-grid ratio of the block's change (what the tests check).
        for (name, r) in [("K", 0..4), ("C", 4..8)] {
            print!("  {name} block reported/true:");
            for (g, (v, e)) in grids.iter().zip(&vals) {
                let rep: f64 = r.clone().map(|k| e[k] * e[k]).sum::<f64>().sqrt();
                let tru: f64 = r
                    .clone()
                    .map(|k| (v[k] - reference[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                print!(" {}×{} {:.2}", g[0], g[1], rep / tru);
            }
            print!("; successive ratios:");
            for w in vals.windows(3) {
                let d = |a: &[f64; 8], b: &[f64; 8]| {
                    r.clone().map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
                };
                print!(" {:.2}", d(&w[2].0, &w[1].0) / d(&w[1].0, &w[0].0));
            }
            println!();
        }
        let (v, e) = block(&dflt);
        print!("  default:");
        for k in 0..8 {
            let s = if k < 4 { scale } else { cscale };
            print!(
                " {} {:.1e}/{:.1e}",
                names[k],
                (v[k] - reference[k]).abs() / s,
                e[k] / s
            );
        }
        println!();
    }
}
