//! Issue 20: the finite film's accuracy knob. The Richardson estimate the solver reports
//! must be honest (within a factor 3 of the true error, both ways) on aligned, tilted and
//! squeezed states, the default accuracy must give loads within 1e-3 of the converged
//! solution up to ε = 0.95, and the multigrid must agree with projected SOR.

use bearing_sweep::bearing::finite::{
    finite_solution, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver,
};
use bearing_sweep::bearing::{finish_loads, pack_state, BearingParams, BearingState, FilmModel};

/// The paper's bearing (B/D = 0.5) with the finite film on `finite`.
fn bearing(finite: FiniteSettings) -> BearingParams {
    BearingParams {
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    }
}

#[path = "support/finite_states.rs"]
mod finite_states;

/// Test states: label, eccentricity ratio of the mid-plane, tilt (end offset over δ,
/// ±), squeeze velocity over δω.
fn states(p: &BearingParams) -> Vec<(String, BearingState)> {
    finite_states::accuracy_states(p)
}

use finite_states::rel;

/// The converged reference: the accuracy ladder's 1024 × 128 and 512 × 64 solutions
/// (same grids, same inlet line on a node, as the solutions tested), iterated to 1e-10,
/// their loads summed by the rectangle rule (independent of the Simpson sum the ladder
/// reports since issue 20 pass 4), Richardson-extrapolated `(4 v₁₀₂₄ − v₅₁₂)/3`
/// ([`FiniteSolver::reference`]; the rectangle-summed ladder converges at second order on
/// these states: error ×1/4 per grid, so the reference is good to ~1e-5).
fn truth(p: &BearingParams, s: &BearingState) -> [f64; 4] {
    let packed = pack_state(p, s).unwrap();
    let job = FiniteJob::new(p, &packed);
    let g = FiniteGrid::for_bearing(p);
    let ints = FiniteSolver::new().reference(&job, &g);
    finish_loads(p, s, &ints, packed.rate_scale).load_vector(p.length)
}

/// Loads and the reported estimate at `accuracy`.
fn at_accuracy(p: &BearingParams, s: &BearingState, accuracy: f64) -> ([f64; 4], f64, bool) {
    let g = FiniteSettings {
        accuracy,
        ..FiniteSettings::default()
    };
    let sol = finite_solution(p, s, &g, false).unwrap();
    (
        sol.loads.load_vector(p.length),
        sol.report.error_estimate,
        sol.report.accuracy_met,
    )
}

/// The ladder's own loads and reported estimate at `accuracy`: the accuracy-mode solve
/// without film outputs (no polish), as sweeps and `finite --bench` run it.
fn ladder_at_accuracy(p: &BearingParams, s: &BearingState, accuracy: f64) -> ([f64; 4], f64, bool) {
    let p = BearingParams {
        finite: FiniteSettings {
            accuracy,
            ..p.finite
        },
        ..*p
    };
    let packed = pack_state(&p, s).unwrap();
    let job = FiniteJob::new(&p, &packed);
    let g = FiniteGrid::for_bearing(&p);
    let (ints, r) = FiniteSolver::new().solve(&job, &g, &mut Vec::new());
    let v = finish_loads(&p, s, &ints, packed.rate_scale).load_vector(p.length);
    (v, r.error_estimate, r.accuracy_met)
}

/// The reported error estimate is within a factor 3 of the true error, both ways, at
/// four accuracies, on aligned (ε 0.1-0.95), tilted and squeezed states, both for the
/// film solution (polished loads, `finite_solution`) and for the ladder's own loads (the
/// solve without film outputs, as sweeps and the benchmark run it); and the default
/// accuracy is within 1e-3 of the converged solution for every state. Accuracy 1e-3 and
/// the ladder's own loads since issue 20 session 41 (s41-honest2): with session 41's
/// estimate the ε 0.7 squeezed state's ladder loads were 3.65× over at 1e-3 (its last
/// grid's iteration term 1.51e-4 against a true iteration error of 1.57e-5; the polished
/// solution, whose polish removes that error, was 1.69×).
#[test]
fn estimate_is_honest_and_default_within_1e3() {
    let p = bearing(FiniteSettings::default());
    for (index, (label, s)) in states(&p).into_iter().enumerate() {
        let want = truth(&p, &s);
        for (accuracy, ladder) in [1e-2, 2e-3, 1e-3, 5e-4]
            .into_iter()
            .flat_map(|a| [(a, false), (a, true)])
        {
            let (v, est, met) = if ladder {
                ladder_at_accuracy(&p, &s, accuracy)
            } else {
                at_accuracy(&p, &s, accuracy)
            };
            let err = rel(&v, &want);
            let what = if ladder { "ladder loads" } else { "solution" };
            println!("{label} accuracy {accuracy:.0e} {what}: estimate {est:.2e}, true {err:.2e}");
            assert!(met, "{label}: accuracy {accuracy} not met (estimate {est})");
            // No `est <= accuracy`: since session 40 the reported estimate counts the pair
            // one grid back and the last grid's iteration error, which the stop bound
            // does not, and may exceed the accuracy where the true error does (ε = 0.6
            // at 5e-4: estimate 6.1e-4); its honesty is what is checked.
            assert!(
                err <= 3.0 * est && est <= 3.0 * err,
                "index {index} ({label}) at accuracy {accuracy}, {what}: true error \
                 {err:.3e}, estimate {est:.3e}, tolerance factor 3 both ways"
            );
        }
        let (v, _, _) = at_accuracy(&p, &s, FiniteSettings::default().accuracy);
        let err = rel(&v, &want);
        assert!(
            err <= 1e-3,
            "index {index} ({label}) at the default accuracy: actual error {err:.3e}, expected \
             ≤ 1e-3 of the converged solution"
        );
    }
}

/// The default accuracy's promise between the test set's eccentricities (issue 20, session
/// 39): a dense scan of aligned journals, ε 0.80-0.875 every 0.005 and 0.90-0.95 every
/// 0.01, each still, whirling (0.02 δω) and squeezed (−0.03 δω), the velocities at both
/// ends, every one within 1e-3 of the converged solution. The H200 run's `finite --bench
/// --states 1024` found aligned states at ε 0.83-0.86 1.1-1.45e-3 off at the old default
/// 5e-4: they stop on 128 × 16 with an estimate of 4.7-5.0e-4 while the ladder's error is
/// irregular there (estimates 0.37-0.44 × the true error; examples/bench_worst.rs). On the
/// old stop rule this test fails at ε 0.83-0.84 still (1.09-1.27e-3) and ε 0.91 squeezed
/// (2.42e-3).
#[test]
fn default_within_1e3_on_a_dense_eccentricity_scan() {
    use rayon::prelude::*;
    let p = bearing(FiniteSettings::default());
    let d = p.clearance;
    let (c, s) = (finite_states::ANGLE.cos(), finite_states::ANGLE.sin());
    let w = finite_states::OMEGA;
    let mut eccs: Vec<f64> = (0..16).map(|k| 0.80 + 0.005 * k as f64).collect();
    eccs.extend((0..6).map(|k| 0.90 + 0.01 * k as f64));
    let cases: Vec<(f64, f64, f64)> = eccs
        .iter()
        .flat_map(|&e| [(e, 0.0, 0.0), (e, 0.02, 0.0), (e, 0.0, -0.03)])
        .collect();
    let errors: Vec<f64> = cases
        .par_iter()
        .map(|&(e, vx, vy)| {
            let st = BearingState {
                xi: e * d * c,
                yi: e * d * s,
                xj: e * d * c,
                yj: e * d * s,
                vxi: vx * d * w,
                vyi: vy * d * w,
                vxj: vx * d * w,
                vyj: vy * d * w,
                omega: w,
            };
            let (v, _, _) = at_accuracy(&p, &st, FiniteSettings::default().accuracy);
            rel(&v, &truth(&p, &st))
        })
        .collect();
    let bad: Vec<String> = cases
        .iter()
        .zip(&errors)
        .enumerate()
        .filter(|(_, (_, &err))| err > 1e-3)
        .map(|(i, ((e, vx, vy), err))| {
            format!("index {i} (ε {e:.3}, v ({vx}, {vy}) δω): actual {err:.3e}, expected ≤ 1e-3")
        })
        .collect();
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    println!("{} states, largest error {worst:.3e}", cases.len());
    assert!(
        bad.is_empty(),
        "default accuracy {}: {} of {} states off the converged solution by more than 1e-3:\n{}",
        FiniteSettings::default().accuracy,
        bad.len(),
        cases.len(),
        bad.join("\n")
    );
}

/// The reported estimate is honest at high eccentricity (issue 20, session 40): within a
/// factor 3 of the true error, both ways, at the default accuracy, on aligned journals at
/// ε 0.9075-0.9375 (still, whirling, squeezed at both ends) and tilted ones at ε 0.9 and
/// 0.95, against a reference finer than the one above where the multigrid gets there: the
/// ladder carried to 2048 × 256 ([`FiniteSolver::ladder_beyond`]), the rectangle sums of
/// its finest grid whose grids all iterated to an estimated field error ≤ 1e-7
/// extrapolated with the grid below's, and the reference's own step (its distance from
/// the extrapolate one grid down) below 1/10 of the error judged (asserted, so a
/// reference that is not converged fails the test rather than judging).
/// The aligned states are those where session 39's `√(bound × d₀/3)` was 0.09-0.24 × the
/// true error (examples/bench_worst.rs `truth`, BENCHMARKS.md "Issue 20: an honest
/// estimate at high eccentricity, session 40"): this test fails on it. The last two
/// (session 41) are aligned journals squeezed at both ends at ε 0.93 and 0.9325 of the
/// dense scan (`BW_SCAN=0.8,0.95,0.0025`, states 627 and 639, ε summed in steps as there:
/// their last grid's iteration error depends on the bits), where session 40's estimate was
/// 3.6× and 8.2× the true error (the grid before the last an unlucky one, `d₀ > d₋₁`):
/// now the ladder goes on one grid ([`bearing_sweep::bearing::finite::ladder_extends`]).
/// The next three (session 42) are the dense scan's states 603 (ε 0.925, squeezed at both
/// ends), 626 (ε 0.93) and 638 (ε 0.9325), squeezed at one end: with the ladder's V(2,1)
/// cycles the ladder's own loads of 603 and 638 were 4.20× and 3.14× their true errors
/// (5.1e-5, 5.3e-5) against 4096 × 512 (3.62×, 3.30× against 1024 × 128); with V(2,0)
/// ([`bearing_sweep::bearing::finite::LADDER_POST_SWEEPS`]) 1.10×, 2.80× (626, whose
/// 1024 × 128 reference's own step, 9.7e-5, is above its error: 3.51× against that one)
/// and 1.87×. Every case is judged on the polished solution and on the ladder's own loads
/// (the solve without film outputs, as sweeps and benchmarks run it): with V(2,1) the
/// test fails (index 2 at 4.20×, index 4 at 3.14×, and index 9's reference step above a
/// tenth of its smaller ladder error; checked once).
#[test]
fn estimate_is_honest_at_high_eccentricity() {
    use rayon::prelude::*;
    let p = bearing(FiniteSettings::default());
    let d = p.clearance;
    let (c, s) = (finite_states::ANGLE.cos(), finite_states::ANGLE.sin());
    let w = finite_states::OMEGA;
    // ε of the dense scan's `n`-th step: 0.8 + 0.0025 + … summed as bench_worst sums it.
    let dense = |n: usize| (0..n).fold(0.8, |e, _| e + 0.0025);
    // (ε of end i, tilt: 1 − ε_j/ε_i, (vx, vy)/δω at end i, the same at end j too, grids
    // past 1024 × 128 for the reference: 4096 × 512 for the dense scan's two, whose errors
    // are 1.3e-5-2e-5 on 1024 × 128).
    type Case = (f64, f64, (f64, f64), bool, usize);
    let cases: [Case; 13] = [
        (dense(52), 0.0, (0.0, -0.03), true, 2),
        (dense(53), 0.0, (0.0, -0.03), true, 2),
        (dense(50), 0.0, (0.0, -0.03), true, 2),
        (dense(52), 0.0, (0.0, -0.03), false, 2),
        (dense(53), 0.0, (0.0, -0.03), false, 2),
        (0.9325, 0.0, (0.0, 0.0), false, 1),
        (0.915, 0.0, (0.0, -0.03), true, 1),
        (0.9375, 0.0, (0.02, 0.0), false, 1),
        (0.93, 0.0, (0.0, 0.0), false, 1),
        (0.945, 0.0, (0.0, -0.03), true, 1),
        (0.95, 0.25, (0.0, 0.0), false, 1),
        (0.90, 0.25, (0.02, 0.0), true, 1),
        (0.95, 0.25, (0.0, -0.03), true, 1),
    ];
    let g = FiniteGrid::for_bearing(&p);
    type Row = (f64, f64, f64, f64, f64, f64);
    let rows: Vec<Row> = cases
        .par_iter()
        .map(|&(e, tilt, (vx, vy), both, extra)| {
            let j = if both { 1.0 } else { 0.0 };
            let st = BearingState {
                xi: e * d * c,
                yi: e * d * s,
                xj: e * (1.0 - tilt) * d * c,
                yj: e * (1.0 - tilt) * d * s,
                vxi: vx * d * w,
                vyi: vy * d * w,
                vxj: j * vx * d * w,
                vyj: j * vy * d * w,
                omega: w,
            };
            let (v, est, _) = at_accuracy(&p, &st, FiniteSettings::default().accuracy);
            let (lv_own, est_own, _) =
                ladder_at_accuracy(&p, &st, FiniteSettings::default().accuracy);
            let packed = pack_state(&p, &st).unwrap();
            let job = FiniteJob::new(&p, &packed);
            let steps = FiniteSolver::new().ladder_beyond(&job, &g, 1e-10, extra);
            let lv =
                |i: &[f64; 4]| finish_loads(&p, &st, i, packed.rate_scale).load_vector(p.length);
            let x = |a: usize| -> [f64; 4] {
                let (f, c) = (lv(&steps[a].rectangle), lv(&steps[a - 1].rectangle));
                std::array::from_fn(|q| (4.0 * f[q] - c[q]) / 3.0)
            };
            // The finest grid up to which every grid iterated to 1e-7 (the multigrid's
            // 200 V-cycles leave some states' 2048 × 256 above it: tilted ε 0.95).
            let top = (1..steps.len())
                .rev()
                .find(|&a| steps[..=a].iter().all(|t| t.result.1 <= 1e-7))
                .unwrap_or(steps.len() - 1);
            let worst_iteration = steps[..=top].iter().map(|t| t.result.1).fold(0.0, f64::max);
            let reference = x(top);
            (
                rel(&v, &reference),
                est,
                rel(&x(top - 1), &reference),
                worst_iteration,
                rel(&lv_own, &reference),
                est_own,
            )
        })
        .collect();
    let mut bad = Vec::new();
    for (index, (case, &(err, est, ref_step, it, err_own, est_own))) in
        cases.iter().zip(&rows).enumerate()
    {
        println!(
            "{case:?}: true error {err:.3e}, estimate {est:.3e} ({:.2}x); ladder's own loads \
             {err_own:.3e}, {est_own:.3e} ({:.2}x); reference step {ref_step:.2e}, largest \
             iteration error {it:.1e}",
            est / err,
            est_own / err_own
        );
        for (what, err, est) in [("polished", err, est), ("ladder", err_own, est_own)] {
            assert!(
                it <= 1e-7 && ref_step <= 0.1 * err,
                "index {index} {case:?} ({what}): the reference is not converged enough to \
                 judge: iteration error {it:.2e} (tolerance 1e-7), its own step {ref_step:.2e} \
                 against the error judged {err:.2e} (tolerance 1/10)"
            );
            if !(err <= 3.0 * est && est <= 3.0 * err) {
                bad.push(format!(
                    "index {index} {case:?} ({what}): estimate {est:.3e}, true error {err:.3e}, \
                     tolerance factor 3 both ways"
                ));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// A solve that does not reach its tolerance says so (issue 20, session 41): on an
/// explicit 2048 × 256 grid at ε 0.88 (aligned, whirling at both ends) the V-cycle stalls
/// in a limit cycle of the free boundary (examples/bench_worst.rs `stall 2048 256`: the
/// field changes ~1e-3 of its maximum per cycle, 36-74 nodes flipping between the active
/// and free sets), so the report says `converged: false` with an iteration error above
/// the tolerance; with the coarse side of the correction truncated too
/// ([`FiniteSolver::coarse_truncation`]) the same grid converges, and its loads are within
/// the stalled estimate of the stalled solve's.
#[test]
fn stalled_explicit_grid_says_so() {
    let tol = 1e-10;
    let p = bearing(FiniteSettings {
        n_theta: Some(2048),
        n_z: Some(256),
        tolerance: tol,
        ..FiniteSettings::default()
    });
    let (d, w, e) = (p.clearance, finite_states::OMEGA, 0.88);
    let (c, s) = (finite_states::ANGLE.cos(), finite_states::ANGLE.sin());
    let st = BearingState {
        xi: e * d * c,
        yi: e * d * s,
        xj: e * d * c,
        yj: e * d * s,
        vxi: 0.02 * d * w,
        vyi: 0.0,
        vxj: 0.02 * d * w,
        vyj: 0.0,
        omega: w,
    };
    let packed = pack_state(&p, &st).unwrap();
    let job = FiniteJob::new(&p, &packed);
    let g = FiniteGrid::for_bearing(&p);
    assert_eq!((g.n_theta, g.n_z, g.accuracy), (2048, 256, None));
    let (stalled, r) = FiniteSolver::new().solve(&job, &g, &mut Vec::new());
    println!("without the coarse truncation: {r:?}");
    assert!(
        !r.converged && r.iteration_error > tol,
        "the stalled solve reports converged {} with iteration error {:.3e} (tolerance {tol:e})",
        r.converged,
        r.iteration_error
    );
    let mut solver = FiniteSolver::new();
    solver.coarse_truncation = true;
    let (ints, rc) = solver.solve(&job, &g, &mut Vec::new());
    println!("with it: {rc:?}");
    assert!(
        rc.converged && rc.iteration_error <= tol,
        "with the coarse truncation: converged {}, iteration error {:.3e}, tolerance {tol:e}",
        rc.converged,
        rc.iteration_error
    );
    let diff = rel(&ints, &stalled);
    assert!(
        diff <= r.iteration_error,
        "the converged loads are {diff:.3e} from the stalled ones, above the stalled solve's \
         own iteration error estimate {:.3e}",
        r.iteration_error
    );
}

/// Projected multigrid and projected SOR solve the same complementarity problem: on
/// fixed grids (both inlets) their load vectors agree to the solver tolerance.
#[test]
fn multigrid_matches_psor() {
    use bearing_sweep::bearing::finite::Inlet;
    let p = bearing(FiniteSettings::default());
    for (label, s) in states(&p).into_iter().step_by(2) {
        let packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        for inlet in [Inlet::None, Inlet::MaxFilm] {
            for (nt, nz) in [(32, 8), (64, 16), (96, 12), (128, 32)] {
                let g = FiniteGrid::from(&FiniteSettings {
                    tolerance: 1e-11,
                    inlet,
                    ..FiniteSettings::with_grid(nt, nz)
                });
                let mut solver = FiniteSolver::new();
                let (a, ra) = solver.solve(&job, &g, &mut Vec::new());
                let (b, rb) = solver.solve_psor(&job, &g, &mut Vec::new());
                assert!(ra.converged && rb.converged, "{label} {nt}x{nz}");
                let d = rel(&a, &b);
                assert!(
                    d <= 1e-8,
                    "{label} {inlet:?} {nt}x{nz}: multigrid {a:?} vs PSOR {b:?}, relative \
                     difference {d:.2e}, tolerance 1e-8"
                );
                // A warm start from the solution stays there.
                let mut field = Vec::new();
                let _ = solver.solve(&job, &g, &mut field);
                let (c, rc) = solver.solve(&job, &g, &mut field);
                assert!(
                    rel(&c, &a) <= 1e-9 && rc.sweeps <= 12,
                    "{label}: warm {rc:?}"
                );
            }
        }
    }
}

/// Explicit grids with the max-film inlet (the default inlet): the held column, at a
/// column that changes with the state's direction and, tilted, with the row, costs the
/// multigrid no more than a free boundary does. On the 32 states of the finite benchmark
/// (ε 0.1-0.9 in golden-angle directions, half tilted, a third squeezed) at 128 × 32 and
/// 256 × 64, tolerance 1e-8: at most 64 sweeps per state and 48 on average (measured
/// 34-50 / 42.4 and 34-58 / 42.6; before issue 20 pass 3 froze one coarse node per row for
/// the inlet line, 34-131 / 82.9 and 34-169 / 97.9), loads as projected SOR's to 1e-7.
#[test]
fn held_inlet_column_keeps_the_multigrid_cycle_count() {
    let (p, states) = bearing_sweep::bench::finite::bench_states(32);
    for (nt, nz) in [(128, 32), (256, 64)] {
        let g = FiniteGrid::from(&FiniteSettings::with_grid(nt, nz));
        let tight = FiniteGrid {
            tolerance: 1e-12,
            ..g
        };
        let mut total = 0u32;
        for (k, s) in states.iter().enumerate() {
            let packed = pack_state(&p, s).unwrap();
            let job = FiniteJob::new(&p, &packed);
            let (got, r) = FiniteSolver::new().solve(&job, &g, &mut Vec::new());
            assert!(
                r.converged && r.sweeps <= 64,
                "{nt}x{nz} state {k}: multigrid work {} sweeps, expected ≤ 64",
                r.sweeps
            );
            total += r.sweeps;
            if nt == 128 {
                let (want, _) = FiniteSolver::new().solve_psor(&job, &tight, &mut Vec::new());
                let d = rel(&got, &want);
                assert!(d <= 1e-7, "{nt}x{nz} state {k}: multigrid vs PSOR {d:e}");
            }
        }
        let mean = total as f64 / states.len() as f64;
        println!("{nt}x{nz}: mean {mean:.1} sweeps");
        assert!(mean <= 48.0, "{nt}x{nz}: mean multigrid work {mean} sweeps");
    }
}

/// Work grows linearly with the node count: the multigrid's work in sweeps of the final
/// grid (all grids' relaxation updates over its node count) stays ≤ 160 from 64 × 8 to
/// 512 × 64 at tolerance 1e-10, where projected SOR's sweeps grow with the grid.
#[test]
fn multigrid_work_is_linear_in_nodes() {
    let p = bearing(FiniteSettings::default());
    for (label, s) in states(&p) {
        let packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let mut psor = Vec::new();
        for (nt, nz) in [(64, 8), (128, 16), (256, 32), (512, 64)] {
            let g = FiniteGrid::from(&FiniteSettings {
                tolerance: 1e-10,
                ..FiniteSettings::with_grid(nt, nz)
            });
            let (_, r) = FiniteSolver::new().solve(&job, &g, &mut Vec::new());
            println!("{label} {nt}x{nz}: {} sweeps", r.sweeps);
            assert!(
                r.converged && r.sweeps <= 160,
                "{label} {nt}x{nz}: multigrid work {} sweeps, expected ≤ 160",
                r.sweeps
            );
            if nt <= 128 {
                psor.push(
                    FiniteSolver::new()
                        .solve_psor(&job, &g, &mut Vec::new())
                        .1
                        .sweeps,
                );
            }
        }
        assert!(
            psor[1] as f64 >= 1.6 * psor[0] as f64,
            "{label}: PSOR {psor:?}"
        );
    }
}

/// Butenschoen (1976), full 360° bearing, B/d = 1/2, pure rotation (../shared/
/// reference-tables/butenschoen-1976.md): ε, Raimondi–Boyd Sommerfeld number
/// `S = (r/c)² μ N / P`, attitude angle β (deg).
const BUTENSCHOEN: [(f64, f64, f64); 9] = [
    (0.1, 4.325, 81.767),
    (0.2, 2.033, 75.142),
    (0.3, 1.2205, 68.493),
    (0.4, 0.7856, 61.778),
    (0.5, 0.5095, 54.993),
    (0.6, 0.3195, 48.049),
    (0.7, 0.1852, 40.803),
    (0.8, 0.0918, 32.938),
    (0.9, 0.0313, 23.566),
];

/// S and β of an aligned journal at `ε` on a bearing with r = 0.5 m, B = 0.5 m,
/// δ = 1 mm, μ = 1 Pa·s, ω = 1 rad/s.
fn sommerfeld_attitude(finite: FiniteSettings, ecc: f64) -> (f64, f64, f64) {
    let p = BearingParams {
        radius: 0.5,
        length: 0.5,
        clearance: 1e-3,
        viscosity: 1.0,
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    };
    let s = BearingState {
        xi: ecc * p.clearance,
        xj: ecc * p.clearance,
        omega: 1.0,
        ..BearingState::default()
    };
    let sol = finite_solution(&p, &s, &p.finite, false).unwrap();
    let (wx, wy) = (sol.loads.wx, sol.loads.wy);
    let load = wx.hypot(wy);
    let pressure = load / (p.length * 2.0 * p.radius);
    let n_rev = s.omega / (2.0 * std::f64::consts::PI);
    let sommerfeld = (p.radius / p.clearance).powi(2) * p.viscosity * n_rev / pressure;
    let attitude = (-wy).atan2(-wx).to_degrees().abs();
    (sommerfeld, attitude, sol.report.error_estimate)
}

/// The Butenschoen table at the default accuracy: S within 1.5 %, β within 0.6°.
#[test]
fn butenschoen_table_at_default_accuracy() {
    let mut worst = (0.0_f64, 0.0_f64);
    for (k, &(ecc, s_want, beta_want)) in BUTENSCHOEN.iter().enumerate() {
        let (s, beta, est) = sommerfeld_attitude(FiniteSettings::default(), ecc);
        let ds = s / s_want - 1.0;
        let db = beta - beta_want;
        println!(
            "ε={ecc}: S {s:.4} (table {s_want}, {:+.2} %), β {beta:.3}° (table {beta_want}, {db:+.3}°), estimate {est:.1e}",
            100.0 * ds
        );
        worst = (worst.0.max(ds.abs()), worst.1.max(db.abs()));
        assert!(
            ds.abs() <= 0.015,
            "Butenschoen S at index {k} (ε={ecc}): actual {s}, expected {s_want}, tolerance 1.5 %"
        );
        assert!(
            db.abs() <= 0.6,
            "Butenschoen β at index {k} (ε={ecc}): actual {beta}°, expected {beta_want}°, tolerance 0.6°"
        );
    }
    println!("worst: S {:.2} %, β {:.3}°", 100.0 * worst.0, worst.1);
}

/// Accuracy mode iterates each grid of the ladder only until its load vector's iteration
/// error is a fraction of the requested accuracy (issue 20, cost; 1/50 until session 35,
/// 1/10 in session 35; since session 36 1/5 for the grid that ends the ladder and a
/// fraction of the load difference to the grid below for the others): the
/// loads it returns are those of the same ladder iterated to 1e-10 (field) within 25 % of
/// the accuracy (2.5 × the fraction, as 5 % was at 1/50; measured ≤ 8.5 % on the test and
/// benchmark states, `zeta_probe work`), on the same grid, and the work stays ≤ 25 sweeps of the final grid (all grids' node updates
/// over its node count) at the default accuracy (measured 12-22; 35-75 when every grid was
/// iterated to 1e-8).
#[test]
fn accuracy_mode_iterates_only_to_a_fraction_of_the_accuracy() {
    let p = bearing(FiniteSettings::default());
    let g = FiniteGrid::for_bearing(&p);
    let accuracy = FiniteSettings::default().accuracy;
    for (label, s) in states(&p) {
        let packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let mut solver = FiniteSolver::new();
        let (ints, report) = solver.solve(&job, &g, &mut Vec::new());
        assert!(report.accuracy_met, "{label}: {report:?}");
        let tight = solver.ladder(&job, &g, 1e-10, false, usize::MAX);
        let same = tight
            .iter()
            .find(|t| t.n_theta == report.n_theta as usize)
            .expect("the grid is on the ladder");
        let d = rel(&ints, &same.integrals);
        let updates = report.sweeps as u64 * (report.n_theta as u64 * (report.n_z as u64 - 1));
        println!(
            "{label}: {}x{}, {updates} updates, loads {d:.1e} from the tightly iterated ones",
            report.n_theta, report.n_z
        );
        assert!(
            d <= 0.25 * accuracy,
            "{label}: accuracy-mode loads {d:.2e} from the tightly iterated ladder's, expected \
             ≤ 25 % of the accuracy {accuracy}"
        );
        assert!(
            report.sweeps <= 25,
            "{label}: {} sweeps of the final grid ({updates} node updates) at the default \
             accuracy, expected ≤ 25",
            report.sweeps
        );
    }
}

/// The default state's mean work against the old 64 × 16 PSOR state's (session 42: issue
/// 20 asks "no more than"; 0.9 leaves the measured 0.833× a margin of 8 %, below the 0.95×
/// asked of the session).
const MEAN_WORK_BUDGET: f64 = 0.9;

/// Issue 20 item 2's cost goal, in counted work (relaxation node updates on all grids,
/// machine-independent): at the default accuracy, on the 32 states of the finite benchmark
/// (ε 0.1-0.9 in golden-angle directions, half tilted, a third squeezed), the median state
/// costs no more than the old default did on average (64 × 16 projected SOR at tolerance
/// 1e-8, counted here), and every state is within 1e-3 of the converged solution with its
/// estimate within a factor 3. Measured (issue 20 pass 4, Simpson's rule in ζ): median
/// 32,640 updates against 54,150, largest 548,352 (one state on 512 × 64), largest error
/// 8.3e-4; before pass 4 every state ended on 512 × 64 (~476,000 on average). Session 35
/// (each grid to accuracy/10): median 30,720, mean 69,024, largest 387,072, same grids.
/// Session 36 (role-dependent per-grid stop, cubic start in ζ): 21,120 / 57,356 / 354,816
/// counted as here (whole sweeps of the final grid), same grids, largest error 8.5e-4.
/// The mean too (session 42), counted exactly (the solver's own tally of node updates on
/// every grid, `LadderStep::updates`; deterministic, not a timing): at most
/// [`MEAN_WORK_BUDGET`] × the old state's. Measured: 55,311 with the ladder's V(2,1)
/// cycles (1.02×, fails), 45,109 with V(2,0) (0.833×).
#[test]
fn default_accuracy_median_state_costs_no_more_than_old_default() {
    let (p, states) = bearing_sweep::bench::finite::bench_states(32);
    let p = BearingParams {
        model: FilmModel::Finite,
        finite: FiniteSettings::default(),
        ..p
    };
    let g = FiniteGrid::for_bearing(&p);
    let old = FiniteGrid::from(&FiniteSettings::with_grid(64, 16));
    let (mut old_total, mut new, mut exact) = (0u64, Vec::new(), 0u64);
    for (k, s) in states.iter().enumerate() {
        let packed = pack_state(&p, s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let (_, r) = FiniteSolver::new().solve_psor(&job, &old, &mut Vec::new());
        old_total += r.sweeps as u64 * 64 * 15;
        let mut solver = FiniteSolver::new();
        let (ints, r) = solver.solve(&job, &g, &mut Vec::new());
        new.push(r.sweeps as u64 * (r.n_theta as u64 * (r.n_z as u64 - 1)));
        exact += solver.trace.last().map_or(0, |t| t.updates);
        let lv = |i: &[f64; 4]| finish_loads(&p, s, i, packed.rate_scale).load_vector(p.length);
        let want = lv(&solver.reference(&job, &g));
        let err = rel(&lv(&ints), &want);
        let est = r.error_estimate;
        assert!(
            r.accuracy_met && err <= 1e-3 && err <= 3.0 * est && est <= 3.0 * err,
            "state {k}: {}x{}, true error {err:.3e}, estimate {est:.3e}",
            r.n_theta,
            r.n_z
        );
    }
    new.sort_unstable();
    let old_mean = old_total / states.len() as u64;
    let median = new[new.len() / 2];
    let mean_exact = exact as f64 / states.len() as f64;
    println!(
        "node updates per state: old default {old_mean} (mean), default accuracy median \
         {median}, largest {}, mean (exact) {mean_exact:.0} ({:.3}x the old)",
        new[new.len() - 1],
        mean_exact / old_mean as f64
    );
    assert!(
        mean_exact <= MEAN_WORK_BUDGET * old_mean as f64,
        "default accuracy: mean {mean_exact:.0} node updates per state (exact), expected ≤ \
         {MEAN_WORK_BUDGET} × the old 64 × 16 PSOR state's {old_mean} = {:.0}",
        MEAN_WORK_BUDGET * old_mean as f64
    );
    assert!(
        median <= old_mean,
        "default accuracy: median {median} node updates per state, expected ≤ the old 64 × 16 \
         PSOR state's {old_mean}"
    );
}

/// The accuracy ladder's load sum (issue 20 pass 4): Simpson's rule in ζ, the rectangle
/// rule in θ, on fields given in closed form. `P = ζ(1 − ζ)(1 + cos θ)` (zero on the end
/// rows, as every film): exact, `−⅓ (π/6, 0, π/12, 0)`, where the rectangle rule in ζ is
/// off by `Δζ²` relative; `P = ζ²(1 − ζ)²(1 + cos θ)`: fourth order (error ×1/16 per
/// halving of Δζ; Simpson's `Δζ⁴/180 (f‴(1) − f‴(0))` = `2Δζ⁴/15` on `∫ζ²(1−ζ)² = 1/30`).
#[test]
fn ladder_load_sum_is_simpson_in_zeta() {
    use bearing_sweep::bearing::finite::ladder_integrals_on;
    use std::f64::consts::PI;
    let field = |nt: usize, nz: usize, theta0: f64, f: &dyn Fn(f64) -> f64| {
        let mut p = vec![0.0; nt * (nz + 1)];
        for j in 0..=nz {
            for i in 0..nt {
                let th = theta0 + 2.0 * PI * i as f64 / nt as f64;
                p[j * nt + i] = f(j as f64 / nz as f64) * (1.0 + th.cos());
            }
        }
        p
    };
    let quad = |z: f64| z * (1.0 - z);
    let want = [-PI / 18.0, 0.0, -PI / 36.0, 0.0];
    for nz in [2, 4, 16] {
        let got = ladder_integrals_on(&field(32, nz, 0.3, &quad), 32, nz, 0.3);
        for k in 0..4 {
            assert!(
                (got[k] - want[k]).abs() <= 1e-13,
                "quadratic profile, n_z {nz}, integral {k}: actual {}, expected {}",
                got[k],
                want[k]
            );
        }
    }
    let quartic = |z: f64| z * z * (1.0 - z) * (1.0 - z);
    let exact = -PI / 3.0 / 30.0;
    let err =
        |nz: usize| ladder_integrals_on(&field(32, nz, 0.0, &quartic), 32, nz, 0.0)[0] - exact;
    for nz in [8, 16] {
        let want = -PI / 3.0 * 2.0 / 15.0 / (nz as f64).powi(4);
        assert!(
            (err(nz) / want - 1.0).abs() <= 1e-6,
            "quartic profile, n_z {nz}: error {:e}, expected Simpson's {want:e}",
            err(nz)
        );
    }
}
