//! Issue 20: coefficients and equilibria with the finite film. Reported coefficient
//! errors include the discretisation error (coefficients at a coarse accuracy agree with
//! a fine one within their reported errors; K's and C's are within a factor 3 of their
//! true error against a converged reference), coefficients along the equilibrium path are
//! smooth in speed (second differences within the reported errors), and the static
//! equilibrium Newton does not fail on the solver's noise.

// Index loops mirror the matrix subscripts.
#![allow(clippy::needless_range_loop)]

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::finite::FiniteSettings;
use bearing_sweep::bearing::{Accuracy, BearingParams, FilmModel};
use bearing_sweep::stability::{
    aligned_state, bearing_equilibria, coefficients_batch, equilibrium_state, pin_grid,
    CoefficientJob, DiffOptions,
};

fn evaluator() -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    LoadEvaluator::new(b)
}

/// The paper's bearing (B/D = 0.5) with the finite film at `accuracy`.
fn paper(accuracy: f64) -> BearingParams {
    BearingParams {
        model: FilmModel::Finite,
        finite: FiniteSettings {
            accuracy,
            ..FiniteSettings::default()
        },
        ..BearingParams::paper_table2()
    }
}

/// Coefficients at accuracy 1e-2 and 5e-4 at two states: each entry of the x-y block of
/// K and C differs by no more than 3 times the two reported errors together (the coarse
/// one carries the discretisation error, ~1e-2, which the old report, ~1e-7, left out).
/// A factor 3, the project's honesty bound: the grid error is an estimate, not a bound
/// (since session 34 taken from secants, within 0.7-2.6 of the true error per entry on
/// 64 × 8 … 1024 × 128 at the second state, `coef_convergence 1024 0.75 -0.6 450`), so
/// about half the entries of an honest estimate fall short of their true error; before,
/// with the kinks' irregular share in the tail, it was a conservative one and this
/// checked factor 1 (measured now: largest difference / reported errors 1.35).
#[test]
fn coefficient_errors_include_the_discretisation_error() {
    let mut ev = evaluator();
    for (k, &(ecc, angle)) in [(0.5_f64, 0.9_f64), (0.75, 0.6)].iter().enumerate() {
        let d = BearingParams::paper_table2().clearance;
        let state = aligned_state(ecc * d * angle.cos(), -ecc * d * angle.sin(), 450.0);
        let jobs: Vec<CoefficientJob> = [1e-2, 5e-4]
            .iter()
            .map(|&a| CoefficientJob {
                params: paper(a),
                state,
            })
            .collect();
        let c = coefficients_batch(&mut ev, &jobs, &DiffOptions::default());
        let (coarse, fine) = (c[0].as_ref().unwrap(), c[1].as_ref().unwrap());
        assert!(
            coarse.grid.is_some() && coarse.grid != fine.grid,
            "{:?}",
            coarse.grid
        );
        let mut worst: f64 = 0.0;
        for i in 0..2 {
            for j in 0..2 {
                for (name, a, ea, b, eb) in [
                    (
                        "K",
                        coarse.stiffness[i][j],
                        coarse.stiffness_error[i][j],
                        fine.stiffness[i][j],
                        fine.stiffness_error[i][j],
                    ),
                    (
                        "C",
                        coarse.damping[i][j],
                        coarse.damping_error[i][j],
                        fine.damping[i][j],
                        fine.damping_error[i][j],
                    ),
                ] {
                    let diff = (a - b).abs();
                    worst = worst.max(diff / (ea + eb));
                    assert!(
                        diff <= 3.0 * (ea + eb),
                        "state {k} {name}[{i}][{j}]: accuracy 1e-2 gives {a:.6e} ± {ea:.2e}, \
                         5e-4 gives {b:.6e} ± {eb:.2e}: difference {diff:.2e} beyond 3 times \
                         the reported errors"
                    );
                    // The coarse grid's reported error is not a rounding-level number.
                    assert!(ea >= 1e-4 * a.abs().max(b.abs()) || diff <= 1e-6 * b.abs());
                }
            }
        }
        println!("state {k}: largest |difference| / reported errors = {worst:.2}");
    }
}

/// Along the static equilibrium path of the paper bearing under 14.53 N (−y), speeds
/// 400-460 rad/s every 10: every equilibrium converges, and the second differences of
/// the x-y blocks of K and C stay within the reported errors of the three coefficients
/// plus the curvature a smooth coefficient may have, `4 (Δω/ω)² |K|`.
#[test]
fn finite_coefficients_are_smooth_in_speed() {
    smooth_in_speed(
        paper(2e-3),
        (0..7).map(|k| 400.0 + 10.0 * k as f64).collect(),
    );
}

/// The same at the default accuracy (5e-4) over 480-580 rad/s every 20, through 500 and
/// 560 rad/s, where the explicit grid pinned before the held ladder grid found no
/// equilibrium (500: Newton stopped at a residual of 4.66e-4) and reported K_yy with a 51 %
/// error (560): the snapped inlet column jumped between differenced states.
#[test]
fn finite_coefficients_are_smooth_in_speed_at_the_default_accuracy() {
    smooth_in_speed(
        paper(FiniteSettings::default().accuracy),
        (0..6).map(|k| 480.0 + 20.0 * k as f64).collect(),
    );
}

/// Equilibria under 14.53 N at `speeds` (equally spaced), then K and C there: every
/// equilibrium converges, and the second differences of the x-y blocks stay within the
/// reported errors plus the curvature a smooth coefficient may have, `4 (Δω/ω)² |K|`.
fn smooth_in_speed(p: BearingParams, speeds: Vec<f64>) {
    let mut ev = evaluator();
    let step = speeds[1] - speeds[0];
    let cases: Vec<(BearingParams, f64, [f64; 2])> =
        speeds.iter().map(|&w| (p, w, [0.0, -14.53])).collect();
    let eqs = bearing_equilibria(&mut ev, &cases);
    let jobs: Vec<CoefficientJob> = eqs
        .iter()
        .zip(&speeds)
        .map(|(e, &w)| {
            let e = e
                .as_ref()
                .unwrap_or_else(|err| panic!("equilibrium at {w} rad/s failed: {err}"));
            CoefficientJob {
                params: p,
                state: equilibrium_state(e, w),
            }
        })
        .collect();
    let c: Vec<_> = coefficients_batch(&mut ev, &jobs, &DiffOptions::default())
        .into_iter()
        .map(|c| c.unwrap())
        .collect();
    // The errors are small, so that "within the reported errors" says something (the
    // 51 % of the old pinned grid would pass any smoothness test): each at most 40 times
    // the accuracy of the block's largest entry (2 % at the default; C's reported errors,
    // up to 4× its grid-to-grid change where that is erratic, reach 1.1 %).
    for (n, ck) in c.iter().enumerate() {
        for (name, m, e) in [
            ("K", ck.stiffness, ck.stiffness_error),
            ("C", ck.damping, ck.damping_error),
        ] {
            let big = (0..2)
                .flat_map(|i| (0..2).map(move |j| (i, j)))
                .fold(0.0_f64, |a, (i, j)| a.max(m[i][j].abs()));
            for i in 0..2 {
                for j in 0..2 {
                    assert!(
                        e[i][j] <= 40.0 * p.finite.accuracy * big,
                        "{name}[{i}][{j}] at {} rad/s: reported error {:.3e} of {:.3e}, \
                         bound {:.3e}",
                        speeds[n],
                        e[i][j],
                        m[i][j],
                        40.0 * p.finite.accuracy * big
                    );
                }
            }
        }
    }
    for n in 1..speeds.len() - 1 {
        let curv = 4.0 * (step / speeds[n]).powi(2);
        for i in 0..2 {
            for j in 0..2 {
                for (name, v, e) in [
                    (
                        "K",
                        [
                            c[n - 1].stiffness[i][j],
                            c[n].stiffness[i][j],
                            c[n + 1].stiffness[i][j],
                        ],
                        [
                            c[n - 1].stiffness_error[i][j],
                            c[n].stiffness_error[i][j],
                            c[n + 1].stiffness_error[i][j],
                        ],
                    ),
                    (
                        "C",
                        [
                            c[n - 1].damping[i][j],
                            c[n].damping[i][j],
                            c[n + 1].damping[i][j],
                        ],
                        [
                            c[n - 1].damping_error[i][j],
                            c[n].damping_error[i][j],
                            c[n + 1].damping_error[i][j],
                        ],
                    ),
                ] {
                    let second = v[0] - 2.0 * v[1] + v[2];
                    let allowed = e[0] + 2.0 * e[1] + e[2] + curv * v[1].abs();
                    assert!(
                        second.abs() <= allowed,
                        "{name}[{i}][{j}] at {} rad/s: second difference {second:.3e}, \
                         allowed {allowed:.3e} (values {v:?}, errors {e:?})",
                        speeds[n]
                    );
                }
            }
        }
    }
}

/// The reported coefficient errors at the default accuracy against a converged reference
/// (the held 1024 × 128 and 512 × 64 grids, Richardson-extrapolated), on five
/// equilibrium-like states of the paper bearing (ε 0.517, 0.3, 0.7, 0.85, 0.9): for the
/// x-y blocks of K and of C, the norm of the reported errors is within a factor 3 of the
/// norm of the true errors, both ways (per entry a true error may cross zero between
/// grids, so the block norm is checked). Before the damping's rates were differenced over
/// steps that average the discrete cavitation boundary's kinks (`HELD_RATE_FACTOR` in
/// src/stability/coefficients.rs), C converged erratically (ratios 0.02-3.5) and its
/// ratio here was 0.6-20, unchecked. Before the grid error was taken from the secants
/// over the largest steps (session 34, `add_grid_error`), the kinks' irregular share of
/// the small-step derivative on 128 × 16 and 256 × 32 made the ratio 14.6 (K) and 4.6 (C)
/// at ε 0.85, unchecked. At ε ≥ 0.8 the reference's own error is less certain: K's
/// successive-grid ratio between 256 × 32, 512 × 64 and 1024 × 128 is 0.1-1.2 there
/// (BENCHMARKS.md "Issue 20: coefficients at high eccentricity (session 34)").
#[test]
fn reported_coefficient_errors_are_honest_against_a_converged_reference() {
    let mut ev = evaluator();
    let p = paper(FiniteSettings::default().accuracy);
    let d = p.clearance;
    let states = [
        (0.517_f64, -0.6_f64, 500.0),
        (0.3, 0.9, 450.0),
        (0.7, 0.5, 450.0),
        (0.85, 2.0, 450.0),
        (0.9, 2.0, 450.0),
    ];
    let mut jobs = Vec::new();
    for &(eps, angle, w) in &states {
        let state = aligned_state(eps * d * angle.cos(), eps * d * angle.sin(), w);
        jobs.push(CoefficientJob { params: p, state });
        jobs.push(CoefficientJob {
            params: pin_grid(&p, Some([1024, 128])),
            state,
        });
    }
    let c: Vec<_> = coefficients_batch(&mut ev, &jobs, &DiffOptions::default())
        .into_iter()
        .map(|c| c.unwrap())
        .collect();
    for (n, &(eps, _, w)) in states.iter().enumerate() {
        let (dflt, fine) = (&c[2 * n], &c[2 * n + 1]);
        assert_eq!(dflt.grid, Some([512, 64]), "state {n}: the default's grid");
        let norm = |f: &dyn Fn(usize, usize) -> f64| {
            (0..2)
                .flat_map(|i| (0..2).map(move |j| (i, j)))
                .map(|(i, j)| f(i, j).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        for (name, m, e, mf) in [
            ("K", dflt.stiffness, dflt.stiffness_error, fine.stiffness),
            ("C", dflt.damping, dflt.damping_error, fine.damping),
        ] {
            let reference = |i: usize, j: usize| (4.0 * mf[i][j] - m[i][j]) / 3.0;
            let truth = norm(&|i, j| m[i][j] - reference(i, j));
            let reported = norm(&|i, j| e[i][j]);
            let ratio = reported / truth;
            println!(
                "ε {eps}, {w} rad/s, {name}: reported {reported:.3e}, true {truth:.3e}, \
                 ratio {ratio:.2} (relative to the block: {:.2e})",
                truth / norm(&|i, j| reference(i, j))
            );
            assert!(
                (1.0 / 3.0..=3.0).contains(&ratio),
                "ε {eps}: {name} block error reported {reported:.3e}, true {truth:.3e}: \
                 ratio {ratio:.2} outside [1/3, 3]"
            );
        }
    }
}
