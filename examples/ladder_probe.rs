//! Probe of the accuracy ladder (issue 20): on the 12 states of tests/finite_accuracy.rs
//! (paper bearing, B/D = 0.5), the error of each ladder grid's loads and of the
//! Richardson-extrapolated loads against the 1024 × 128 extrapolated reference, and the
//! work (node updates) and algebraic error of the ladder at several per-grid tolerances.
//!
//! `cargo run --release --example ladder_probe [none]` (`none`: the free inlet).
use bearing_sweep::bearing::finite::{FiniteGrid, FiniteJob, FiniteSolver};
use bearing_sweep::bearing::{
    finish_loads, pack_state, BearingParams, BearingState, FilmModel, Packed,
};

#[path = "../tests/support/finite_states.rs"]
mod finite_states;

fn states(p: &BearingParams) -> Vec<(String, BearingState)> {
    finite_states::accuracy_states(p)
}

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn main() {
    let mut p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    if std::env::args().nth(1).is_some() {
        p.finite.inlet = bearing_sweep::bearing::finite::Inlet::None;
    }
    let g = FiniteGrid::for_bearing(&p);
    let tols = [1e-6, 1e-5, 1e-4];
    for (label, s) in states(&p) {
        let packed: Packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let lv =
            |ints: &[f64; 4]| finish_loads(&p, &s, ints, packed.rate_scale).load_vector(p.length);
        let mut solver = FiniteSolver::new();
        let tight = solver.ladder(&job, &g, 1e-10, false, 7);
        let v: Vec<[f64; 4]> = tight.iter().map(|t| lv(&t.integrals)).collect();
        let n = v.len();
        let truth: [f64; 4] = std::array::from_fn(|k| (4.0 * v[n - 1][k] - v[n - 2][k]) / 3.0);
        print!("{label:16} plain:");
        for x in &v[..n - 1] {
            print!(" {:.2e}", rel(x, &truth));
        }
        println!();
        let xs: Vec<[f64; 4]> = (1..n)
            .map(|l| std::array::from_fn(|k| (4.0 * v[l][k] - v[l - 1][k]) / 3.0))
            .collect();
        // xs[i] is the extrapolate at level i + 1.
        for l in 3..n - 1 {
            let x = &xs[l - 1];
            let dx = rel(x, &xs[l - 2]);
            let dxx = rel(&xs[l - 2], &xs[l - 3]);
            let err = rel(x, &truth);
            println!(
                "   {}x{}: extrap err {:.2e}  |X-X_-1| {:.2e} (ratio {:.2})  |X_-1-X_-2| {:.2e} plain err {:.2e} plain/extrap {:.0}",
                tight[l].n_theta, tight[l].n_z, err, dx, dx / err, dxx, rel(&v[l], &truth), rel(&v[l], &truth) / err
            );
        }
        for &tol in &tols {
            let steps = solver.ladder(&job, &g, tol, true, 6);
            print!("   tol {tol:.0e}: ");
            for (l, st) in steps.iter().enumerate() {
                print!(
                    " [{}x{} c{} alg {:.1e} upd {}k]",
                    st.n_theta,
                    st.n_z,
                    st.result.0,
                    rel(&lv(&st.integrals), &v[l]),
                    st.updates / 1000
                );
            }
            println!();
        }
    }
}
