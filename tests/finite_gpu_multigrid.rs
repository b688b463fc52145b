//! The finite film's projected multigrid on the GPU (shaders/finite_mg.wgsl, issue 20
//! item 2, issue 26 item 3) against the CPU solver: explicit grids beyond the PSOR
//! kernel's workgroup memory (128 × 32, 256 × 64) and accuracy mode (the ladder, its grids,
//! its Richardson estimate and stop rule). Runs on whatever f64 adapter wgpu finds
//! (lavapipe on CI); skips with a notice without one, fails with
//! `BEARING_SWEEP_REQUIRE_GPU=1`.
//!
//! Tolerances: on an explicit grid both solvers iterate to `tolerance` on the field (the
//! same fixed point: the GPU's truncated correction tests its neighbours before the
//! correction, the CPU's in node order, so the paths differ), so the load vectors agree
//! to a few times the tolerance. In accuracy mode the grid that ends the ladder stops when
//! its loads' estimated iteration error is below the rule's floor (the plain film:
//! `LADDER_FLOOR × accuracy`, src/bearing/finite/solver.rs `LadderRule`, on both backends
//! since session 37; grooves: `accuracy/10`, `ALGEBRAIC_FRACTION`): the loads agree to
//! twice that, and the Richardson estimate, `d₂ ρ/(1 − ρ)` with `ρ ≤ 0.8`, moves by at
//! most ~8× it (`d₂` changes by ≤ 2 stop tolerances, times ≤ 4) — the test allows 10×.
//! (tests/finite_gpu_ladder_rule.rs checks the kernel's ladder rule itself.)

mod common;

use bearing_sweep::backend::CpuBackend;
use bearing_sweep::backend::{FilmBackend, GpuBackend, LoadEvaluator, LoadRequest};
use bearing_sweep::bearing::finite::{
    FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, Inlet, SolveReport, LADDER_FLOOR,
};
use bearing_sweep::bearing::{
    pack_state, Accuracy, BearingParams, BearingState, FilmLayout, FilmModel, Groove, Grooves,
};

/// A failed comparison names the case, the state, both values and the tolerance.
fn check(label: &str, index: usize, actual: f64, expected: f64, tol: f64) {
    assert!(
        (actual - expected).abs() <= tol,
        "{label}: state {index}: actual {actual:e}, expected {expected:e}, tolerance {tol:e}"
    );
}

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The paper's bearing (B/D = 0.5) with `finite` settings.
fn paper(finite: FiniteSettings) -> BearingParams {
    BearingParams {
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    }
}

/// Aligned, tilted, whirling and squeezed states at 100 rad/s (ε 0.2-0.9).
fn states(p: &BearingParams) -> Vec<(&'static str, BearingState)> {
    let d = p.clearance;
    let at = |e: f64, t: f64, tilt: f64| BearingState {
        xi: e * d * t.cos(),
        yi: e * d * t.sin(),
        xj: e * d * (1.0 - tilt) * t.cos(),
        yj: e * d * (1.0 - tilt) * t.sin(),
        omega: 100.0,
        ..BearingState::default()
    };
    vec![
        ("aligned ε 0.3", at(0.3, 4.2, 0.0)),
        ("aligned ε 0.8", at(0.8, 1.0, 0.0)),
        ("aligned ε 0.9", at(0.9, -1.3, 0.0)),
        ("tilted in plane", at(0.6, 2.0, 0.5)),
        (
            "tilted about the mid-plane",
            BearingState {
                xi: 0.4 * d,
                yi: -0.2 * d,
                xj: -0.1 * d,
                yj: -0.5 * d,
                omega: 100.0,
                ..BearingState::default()
            },
        ),
        (
            "whirling",
            BearingState {
                vxi: 0.02 * d * 100.0,
                vxj: 0.02 * d * 100.0,
                ..at(0.5, 0.7, 0.0)
            },
        ),
        (
            "squeezed",
            BearingState {
                vyi: -0.3 * d * 100.0,
                vyj: -0.1 * d * 100.0,
                ..at(0.4, 4.0, 0.2)
            },
        ),
    ]
}

/// Jobs and the bearing's grid for `states`.
fn jobs(p: &BearingParams, states: &[(&str, BearingState)]) -> (Vec<FiniteJob>, FiniteGrid) {
    let jobs = states
        .iter()
        .map(|(_, s)| FiniteJob::of_state(p, &pack_state(p, s).unwrap(), s.omega))
        .collect();
    (jobs, FiniteGrid::for_bearing(p))
}

/// CPU solves (cold start) of `jobs` on `grid`.
fn cpu(jobs: &[FiniteJob], grid: &FiniteGrid) -> Vec<([f64; 4], SolveReport, Vec<f64>)> {
    let mut solver = FiniteSolver::new();
    jobs.iter()
        .map(|j| {
            let mut f = Vec::new();
            let (v, r) = solver.solve(j, grid, &mut f);
            (v, r, f)
        })
        .collect()
}

/// GPU solves of `jobs` on `grid` (cold unless `fields` carry starts).
fn gpu(
    backend: &mut GpuBackend,
    jobs: &[FiniteJob],
    grid: &FiniteGrid,
    fields: &mut [Vec<f64>],
) -> (Vec<[f64; 4]>, Vec<SolveReport>) {
    let (mut out, mut reports) = (Vec::new(), Vec::new());
    backend
        .integrate_finite(jobs, grid, fields, &mut out, &mut reports)
        .expect("the multigrid kernel runs");
    (out, reports)
}

fn grooved(finite: FiniteSettings) -> BearingParams {
    BearingParams {
        grooves: Grooves::new(&[
            Groove {
                angle: 90.0,
                width: 20.0,
                supply_pressure: 2e4,
                length: None,
            },
            Groove {
                angle: 270.0,
                width: 20.0,
                supply_pressure: 2e4,
                length: None,
            },
        ])
        .unwrap(),
        ..paper(finite)
    }
}

/// Explicit grids beyond the PSOR kernel's workgroup memory: GPU and CPU multigrid agree
/// on the loads to the tolerance, with both inlets and with grooves; the returned field is
/// the grid's; a warm start from the converged field agrees too and needs fewer cycles.
#[test]
fn multigrid_kernel_matches_cpu_on_large_explicit_grids() {
    let Some(mut backend) = common::gpu_f64_or_skip("finite-film multigrid GPU") else {
        return;
    };
    let tol = 1e-10;
    for (nt, nz) in [(128u32, 32u32), (256, 64)] {
        let base = FiniteSettings {
            n_theta: Some(nt),
            n_z: Some(nz),
            tolerance: tol,
            ..FiniteSettings::default()
        };
        for (label, p) in [
            ("max-film inlet", paper(base)),
            (
                "free inlet",
                paper(FiniteSettings {
                    inlet: Inlet::None,
                    ..base
                }),
            ),
            ("two supplied grooves", grooved(base)),
        ] {
            let st = states(&p);
            let (jobs, grid) = jobs(&p, &st);
            assert_eq!(grid.layout.is_empty(), !label.contains("groove"));
            let want = cpu(&jobs, &grid);
            let mut fields = vec![Vec::new(); jobs.len()];
            let (got, reports) = gpu(&mut backend, &jobs, &grid, &mut fields);
            for (k, ((w, _, wf), (g, r))) in want.iter().zip(got.iter().zip(&reports)).enumerate() {
                let name = format!("{nt}×{nz} {label}, {}", st[k].0);
                check(&name, k, rel(g, w), 0.0, 20.0 * tol);
                assert!(r.converged, "{name}: {r:?}");
                assert_eq!((r.n_theta, r.n_z), (nt, nz), "{name}");
                assert_eq!(fields[k].len(), wf.len(), "{name}: field length");
                let fmax = wf.iter().fold(0.0_f64, |m, v| m.max(*v));
                let fdiff = fields[k]
                    .iter()
                    .zip(wf)
                    .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
                check(&format!("{name} field"), k, fdiff / fmax, 0.0, 20.0 * tol);
            }
            if nt == 128 {
                // Warm start from the converged field: the same loads, fewer cycles.
                let cold_sweeps: Vec<u32> = reports.iter().map(|r| r.sweeps).collect();
                let (again, warm) = gpu(&mut backend, &jobs, &grid, &mut fields);
                for (k, (a, w)) in again.iter().zip(&want).enumerate() {
                    check(&format!("{label} warm"), k, rel(a, &w.0), 0.0, 20.0 * tol);
                    assert!(
                        warm[k].sweeps < cold_sweeps[k],
                        "{label}: state {k}: warm {} sweeps, cold {}",
                        warm[k].sweeps,
                        cold_sweeps[k]
                    );
                }
            }
        }
    }
}

/// The ladder's largest grid, 1024 × 128 (132 096 nodes), as an explicit grid with the
/// max-film inlet: before the kernel was resumable, lavapipe's loop limit (65 535
/// iterations per invocation and dispatch) stopped these solves after about a third of
/// their work with loads 100 % off; now GPU and CPU agree to the tolerance, with the same
/// work and verdict, and the returned field is the grid's. Two states (aligned ε 0.8 and
/// tilted about the mid-plane) keep it cheap on lavapipe. (The tilted state does not reach
/// 1e-10 on the field in 200 V-cycles on either backend at this grid — 799 sweeps,
/// estimated iteration error 2e-3 on the GPU — while its loads agree to 2e-9: the CPU
/// multigrid's behaviour, mirrored.)
#[test]
fn multigrid_kernel_matches_cpu_at_1024x128() {
    let Some(mut backend) = common::gpu_f64_or_skip("finite-film multigrid GPU") else {
        return;
    };
    let tol = 1e-10;
    let p = paper(FiniteSettings {
        n_theta: Some(1024),
        n_z: Some(128),
        tolerance: tol,
        ..FiniteSettings::default()
    });
    let st: Vec<_> = states(&p)
        .into_iter()
        .filter(|(name, _)| *name == "aligned ε 0.8" || name.contains("mid-plane"))
        .collect();
    assert_eq!(st.len(), 2);
    let (jobs, grid) = jobs(&p, &st);
    let want = cpu(&jobs, &grid);
    let mut fields = vec![Vec::new(); jobs.len()];
    let (got, reports) = gpu(&mut backend, &jobs, &grid, &mut fields);
    for (k, ((w, wr, wf), (g, r))) in want.iter().zip(got.iter().zip(&reports)).enumerate() {
        let name = format!("1024×128 max-film inlet, {}", st[k].0);
        check(&name, k, rel(g, w), 0.0, 20.0 * tol);
        assert_eq!(r.converged, wr.converged, "{name}: GPU {r:?}, CPU {wr:?}");
        assert_eq!((r.n_theta, r.n_z), (1024, 128), "{name}");
        // The same V-cycles: the work differs by at most a cycle (the paths of the
        // truncated correction differ, module docs of the test).
        let (a, b) = (r.sweeps as f64, wr.sweeps as f64);
        check(&format!("{name} sweeps"), k, a, b, 0.1 * b);
        assert_eq!(fields[k].len(), wf.len(), "{name}: field length");
    }
}

/// Accuracy mode on the GPU: the same ladder grid as the CPU for every state, loads within
/// twice the last grid's stop tolerance, the same Richardson estimate (within 10× the stop
/// tolerance) and the same verdict, at the default accuracy, 2e-3 and 1e-4 (short bearing
/// B/D = 0.25 too: another ladder shape), with grooves (the banded estimate).
#[test]
fn accuracy_mode_on_gpu_matches_cpu() {
    let Some(mut backend) = common::gpu_f64_or_skip("finite-film multigrid GPU") else {
        return;
    };
    let default = FiniteSettings::default().accuracy;
    let mut cases: Vec<(String, BearingParams)> = Vec::new();
    for accuracy in [default, 2e-3, 1e-4] {
        let s = FiniteSettings {
            accuracy,
            ..FiniteSettings::default()
        };
        cases.push((format!("accuracy {accuracy:e}"), paper(s)));
    }
    let s = FiniteSettings::default();
    cases.push((
        "B/D 0.25, free inlet".into(),
        BearingParams {
            length: 0.25 * 2.0 * BearingParams::paper_table2().radius,
            ..paper(FiniteSettings {
                inlet: Inlet::None,
                ..s
            })
        },
    ));
    cases.push((
        "grooves, accuracy 2e-3".into(),
        grooved(FiniteSettings {
            accuracy: 2e-3,
            ..s
        }),
    ));
    let mut top_grids = 0;
    for (label, p) in &cases {
        let st = states(p);
        let (jobs, grid) = jobs(p, &st);
        let target = grid.accuracy.expect("accuracy mode");
        // The last grid's stop: the plain film's `LadderRule` floor; with grooves 0.1,
        // ALGEBRAIC_FRACTION of src/bearing/finite/solver.rs (crate-private).
        let fraction = if grid.layout.is_empty() {
            LADDER_FLOOR
        } else {
            0.1
        };
        let stop = (fraction * target).max(grid.tolerance);
        let want = cpu(&jobs, &grid);
        let mut fields = vec![Vec::new(); jobs.len()];
        let (got, reports) = gpu(&mut backend, &jobs, &grid, &mut fields);
        for (k, ((w, wr, wf), (g, r))) in want.iter().zip(got.iter().zip(&reports)).enumerate() {
            let name = format!("{label}, {}", st[k].0);
            assert_eq!(
                (r.n_theta, r.n_z),
                (wr.n_theta, wr.n_z),
                "{name}: GPU grid vs CPU grid (estimates {:e} / {:e})",
                r.error_estimate,
                wr.error_estimate
            );
            check(&format!("{name} loads"), k, rel(g, w), 0.0, 2.0 * stop);
            check(
                &format!("{name} error estimate"),
                k,
                r.error_estimate,
                wr.error_estimate,
                10.0 * stop,
            );
            assert_eq!(r.accuracy_met, wr.accuracy_met, "{name}");
            assert_eq!(fields[k].len(), wf.len(), "{name}: field length");
            if r.n_theta == 1024 {
                top_grids += 1;
            }
        }
    }
    // At 1e-4 states reach the ladder's 1024 × 128 grid, solved on the device since the
    // kernel is resumable (src/backend/finite_mg.rs "Range").
    assert!(top_grids > 0, "no state reached 1024 × 128");
}

/// Through the evaluator: accuracy mode and 128 × 32 run on the GPU without a CPU
/// fallback notice, and the loads (with their film flows from the returned field) agree
/// with the CPU backend's.
#[test]
fn evaluator_runs_large_grids_on_the_gpu_and_polished_accuracy_mode_on_the_cpu() {
    let Some(backend) = common::gpu_f64_or_skip("finite-film multigrid GPU") else {
        return;
    };
    let mut gpu_ev = LoadEvaluator::new(Box::new(backend));
    let mut cpu_ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let mut accuracy_states = 0u64;
    for finite in [
        FiniteSettings::default(),
        FiniteSettings {
            n_theta: Some(128),
            n_z: Some(32),
            ..FiniteSettings::default()
        },
    ] {
        let p = paper(finite);
        let st = states(&p);
        let req: Vec<LoadRequest> = st
            .iter()
            .map(|&(_, state)| LoadRequest { bearing: 0, state })
            .collect();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        gpu_ev.evaluate(&[p], &req, &mut a);
        cpu_ev.evaluate(&[p], &req, &mut b);
        // Accuracy mode through the plain evaluator asks for the film friction and flow, so
        // its last grid is polished to the tolerance (issue 20), which the kernel does not
        // do: those states run on the CPU (said once in a notice), equal to the CPU's. The
        // kernel's own accuracy mode is checked against the CPU in the tests above.
        let tol = match finite.fixed_grid() {
            Some(_) => 20.0 * finite.tolerance,
            None => 0.0,
        };
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            let (x, y) = (x.as_ref().unwrap(), y.as_ref().unwrap());
            let (vx, vy) = (x.load_vector(p.length), y.load_vector(p.length));
            check(
                &format!("{finite:?} {}", st[k].0),
                k,
                rel(&vx, &vy),
                0.0,
                tol,
            );
            let (fx, fy) = (x.film.side_flow_m3_per_s, y.film.side_flow_m3_per_s);
            check(
                &format!("{} side flow", st[k].0),
                k,
                fx,
                fy,
                1e-3 * fy.abs().max(1e-12),
            );
        }
        let notices = gpu_ev.take_notices();
        if finite.fixed_grid().is_some() {
            assert!(notices.is_empty(), "no CPU fallback expected: {notices:?}");
        } else {
            assert!(
                notices.len() == 1 && notices[0].contains("accuracy ladder only"),
                "accuracy mode with film outputs: one notice naming why: {notices:?}"
            );
            accuracy_states += req.len() as u64;
        }
    }
    assert_eq!(gpu_ev.stats().cpu_recomputed, accuracy_states);
    let _ = FilmLayout::default();
}
