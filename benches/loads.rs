//! Criterion micro-benchmarks of the film-load quadrature: one state per call
//! (`film_loads`: pack, graded rule, finish loads) on the calling thread, at each
//! accuracy level, for four state families of the paper's Table 2 bearing.
//!
//! Errors (norm-wise relative error of `(W_x, W_y, M_x/B, M_y/B)` against
//! `reference_loads` at 1e-14, measured on these exact states; the bench prints them again
//! when it starts, so the figures below can be checked with
//! `cargo bench --bench loads -- --list`):
//!
//! | family | 1e-3 | 1e-6 | 1e-9 | 1e-12 | slices per state at the four levels |
//! | --- | ---: | ---: | ---: | ---: | --- |
//! | aligned | 0 | 0 | 0 | 0 | 1, 1, 1, 1 |
//! | tilted | 2.0e-7 | 1.7e-10 | 1.4e-13 | 3.2e-16 | 15, 21, 27, 36 |
//! | near-wall 0.99 | 1.6e-7 | 2.1e-10 | 2.4e-13 | 4.5e-16 | 25, 35, 45, 60 |
//! | kink | 1.7e-6 | 2.2e-9 | 2.6e-12 | 4.5e-16 | 20, 28, 36, 48 |
//!
//! (An aligned state's film is `z`-independent: the closed-form slice is exact, and the
//! reference integrates the same slice, hence 0.) The benchmark states of `bench loads`
//! (2000 random tilted states) give max errors 1.4e-5, 2.2e-8, 2.9e-11, 4.7e-15.
//!
//! Run: `cargo bench --bench loads` (compile only: `cargo bench --no-run`).

use std::hint::black_box;

use bearing_sweep::bearing::reference::reference_loads;
use bearing_sweep::bearing::{
    film_loads, pack_state, Accuracy, BearingParams, BearingState, FilmRule, ACCURACY_LEVELS,
};
use criterion::{BenchmarkId, Criterion};

/// The four families, all at spin 100 rad/s.
fn families(p: &BearingParams) -> Vec<(&'static str, BearingState)> {
    let d = p.clearance;
    let w = 100.0;
    vec![
        // Both ends at the same eccentricity (0.58), a small squeeze.
        (
            "aligned",
            BearingState {
                xi: 0.5 * d,
                yi: 0.3 * d,
                xj: 0.5 * d,
                yj: 0.3 * d,
                vxi: 0.05 * d * w,
                vyi: -0.02 * d * w,
                vxj: 0.05 * d * w,
                vyj: -0.02 * d * w,
                omega: w,
            },
        ),
        // Tilted and squeezed, end ratios 0.58 and 0.73.
        (
            "tilted",
            BearingState {
                xi: 0.3 * d,
                yi: -0.5 * d,
                xj: 0.7 * d,
                yj: 0.2 * d,
                vxi: 0.1 * d * w,
                vyi: 0.05 * d * w,
                vxj: -0.08 * d * w,
                vyj: 0.1 * d * w,
                omega: w,
            },
        ),
        // End i at eccentricity ratio 0.99 (thin film), end j at 0.8.
        (
            "near-wall-0.99",
            BearingState {
                xi: 0.99 * d,
                yi: 0.0,
                xj: 0.8 * d * 0.3f64.cos(),
                yj: 0.8 * d * 0.3f64.sin(),
                omega: w,
                ..BearingState::default()
            },
        ),
        // The axis crosses the bearing centre at mid-length: the rate vector `ω ε`
        // vanishes there (an interior kink of the loaded arc).
        (
            "kink",
            BearingState {
                xi: -0.6 * d,
                yi: -0.3 * d,
                xj: 0.6 * d,
                yj: 0.3 * d,
                omega: w,
                ..BearingState::default()
            },
        ),
    ]
}

fn rel_error(a: [f64; 4], e: [f64; 4]) -> f64 {
    let num: f64 = a.iter().zip(&e).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = e.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

/// Prints the error and the slices (closed-form arc evaluations, the cost measure) of every
/// family at every level (the table in the doc comment).
fn print_errors(p: &BearingParams) {
    for (name, s) in families(p) {
        let r = reference_loads(p, &s, 1e-14).expect("valid state");
        let e = [r[0], r[1], r[2] / p.length, r[3] / p.length];
        let errs: Vec<String> = ACCURACY_LEVELS
            .iter()
            .map(|&level| {
                let rule = FilmRule::new(Accuracy::new(level).unwrap().settings());
                let l = film_loads(p, &s, &rule).expect("valid state");
                let slices = rule.integrate(&pack_state(p, &s).expect("valid").state).1;
                format!(
                    "{level:e}: {:.1e} ({slices} slices)",
                    rel_error(l.load_vector(p.length), e)
                )
            })
            .collect();
        eprintln!("error of {name}: {}", errs.join(", "));
    }
}

fn bench_loads(c: &mut Criterion) {
    let p = BearingParams::paper_table2();
    let mut group = c.benchmark_group("film_loads");
    for (name, s) in families(&p) {
        for &level in ACCURACY_LEVELS.iter() {
            let rule = FilmRule::new(Accuracy::new(level).unwrap().settings());
            group.bench_with_input(BenchmarkId::new(name, format!("{level:e}")), &s, |b, s| {
                b.iter(|| film_loads(black_box(&p), black_box(s), &rule))
            });
        }
    }
    group.finish();
}

fn main() {
    print_errors(&BearingParams::paper_table2());
    let mut c = Criterion::default().configure_from_args();
    bench_loads(&mut c);
    c.final_summary();
}
