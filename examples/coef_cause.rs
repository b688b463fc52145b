//! Diagnosis of the finite film's damping convergence (issue 20): the x-y blocks of K and
//! C at one state on held ladder grids, differenced at one step (central, no Richardson)
//! with a chosen relative step and held-grid iteration tolerance, so that the step's and
//! the iteration's shares of C's grid-to-grid scatter can be told apart. Session 34 used
//! it for K at high eccentricity: at ε 0.85 K's grid convergence is irregular at the step
//! 1e-3 and regular at 0.4 (`-- 0.85 2.0 450 0.4 1e-8 64 128 256 512 1024`), the reason
//! the grid error is taken from secants over the largest steps (BENCHMARKS.md "Issue 20:
//! coefficients at high eccentricity (session 34)").
//!
//! `cargo run --release --example coef_cause -- EPS ANGLE OMEGA REL_STEP TOL NT...`: the
//! state `ε (cos angle, sin angle) δ` at `OMEGA` rad/s, central differences at the
//! relative step `REL_STEP` (positions and rates alike), the held grids `NT × NT/8`
//! iterated to `TOL` (BENCHMARKS.md "C's error honest").

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::{Accuracy, BearingParams, FilmModel};
use bearing_sweep::stability::{
    aligned_state, coefficients_batch, pin_grid, CoefficientJob, DiffOptions,
};

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    if a.len() < 6 {
        eprintln!(
            "usage: coef_cause EPS ANGLE OMEGA REL_STEP TOL NT... \
             (e.g. 0.517 -0.6 500 1e-3 1e-8 128 256 512 1024)"
        );
        std::process::exit(2);
    }
    let (eps, angle, w, rel, tol) = (a[0], a[1], a[2], a[3], a[4]);
    let grids: Vec<u32> = a[5..].iter().map(|&v| v as u32).collect();
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    let mut ev = LoadEvaluator::new(b);
    let mut p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    p.finite.tolerance = tol;
    let d = p.clearance;
    let state = aligned_state(eps * d * angle.cos(), eps * d * angle.sin(), w);
    let jobs: Vec<CoefficientJob> = grids
        .iter()
        .map(|&nt| CoefficientJob {
            params: pin_grid(&p, Some([nt, nt / 8])),
            state,
        })
        .collect();
    let opts = DiffOptions {
        relative_step: rel,
        richardson: false,
        coordinates: 8,
    };
    let c = coefficients_batch(&mut ev, &jobs, &opts);
    for (nt, c) in grids.iter().zip(c) {
        let c = c.unwrap();
        println!(
            "{nt:>5}: K {:+.8e} {:+.8e} {:+.8e} {:+.8e}  C {:+.8e} {:+.8e} {:+.8e} {:+.8e}",
            c.stiffness[0][0],
            c.stiffness[0][1],
            c.stiffness[1][0],
            c.stiffness[1][1],
            c.damping[0][0],
            c.damping[0][1],
            c.damping[1][0],
            c.damping[1][1]
        );
    }
}
