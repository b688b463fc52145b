//! Cost of K and C per speed with the finite film (issue 20): what `bearing-sweep
//! coefficients` does for the paper bearing under 14.53 N at 400-580 rad/s every 20
//! (static equilibria by Newton, then the coefficients with their error estimates), with
//! the counted work (finite-film solves and their sweeps, from the evaluator's counters)
//! besides the wall time, one thread or the default pool.
//!
//! `cargo run --release --example coef_cost [accuracy]` (default: the default accuracy).

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::finite::FiniteSettings;
use bearing_sweep::bearing::{Accuracy, BearingParams, FilmModel};
use bearing_sweep::stability::{
    bearing_equilibria, coefficients_batch, equilibrium_state, CoefficientJob, DiffOptions,
};

fn main() {
    let accuracy: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(FiniteSettings::default().accuracy);
    let p = BearingParams {
        model: FilmModel::Finite,
        finite: FiniteSettings {
            accuracy,
            ..FiniteSettings::default()
        },
        radius: 0.02,
        length: 0.02,
        clearance: 3e-4,
        viscosity: 0.0242,
        ..BearingParams::paper_table2()
    };
    let speeds: Vec<f64> = (0..10).map(|k| 400.0 + 20.0 * k as f64).collect();
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    let mut ev = LoadEvaluator::new(b);
    let t = std::time::Instant::now();
    let cases: Vec<(BearingParams, f64, [f64; 2])> =
        speeds.iter().map(|&w| (p, w, [0.0, -14.53])).collect();
    let eqs = bearing_equilibria(&mut ev, &cases);
    let t_eq = t.elapsed().as_secs_f64();
    let s_eq = ev.stats();
    let jobs: Vec<CoefficientJob> = eqs
        .iter()
        .zip(&speeds)
        .map(|(e, &w)| CoefficientJob {
            params: p,
            state: equilibrium_state(e.as_ref().expect("an equilibrium"), w),
        })
        .collect();
    let c = coefficients_batch(&mut ev, &jobs, &DiffOptions::default());
    let wall = t.elapsed().as_secs_f64();
    let s = ev.stats();
    let iters: Vec<u32> = eqs.iter().map(|e| e.as_ref().unwrap().iterations).collect();
    println!(
        "accuracy {accuracy:e}, {} speeds: equilibria {t_eq:.2} s ({} finite solves, {} sweeps, \
         Newton iterations {iters:?}); total {wall:.2} s, {:.3} s per speed ({} finite \
         solves, {} sweeps; the ladder choices at the states are outside the evaluator's \
         counters); grids {:?}",
        speeds.len(),
        s_eq.finite_states,
        s_eq.finite_sweeps,
        wall / speeds.len() as f64,
        s.finite_states,
        s.finite_sweeps,
        c.iter()
            .map(|c| c.as_ref().unwrap().grid)
            .collect::<Vec<_>>()
    );
}
