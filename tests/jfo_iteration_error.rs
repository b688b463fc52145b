//! The JFO solver's reported iteration error against the true one (issue 27, session 34;
//! docs/jfo.md "Iteration error"): `SolveReport::iteration_error` is the solver's estimate
//! of `max(max|P − P*|/max P*, max|φ − φ*|)` with `(P*, φ*)` the exact solution of the same
//! discrete problem. Here `(P*, φ*)` is the same problem solved on from the returned field
//! to tolerance 1e-13, and the reported error must be within a factor 3 of the true one
//! both ways wherever the true error is above the reference's own level (1e-11): steady
//! states (aligned, tilted and whirling, max-film feed, an ambient groove with the film
//! reforming in the land) and time steps of a whirl with the film history. The max-film
//! inlet with tilt and squeeze, where the film reforms in the land before the held column,
//! is listed apart (it read 0.15 before session 35's previous-change floor and 0.31 before
//! session 36's drift rule, `BlockStop` in src/bearing/finite/jfo.rs) and held to the same
//! factor 3. The squeeze
//! benchmark's steps through rupture and reformation are checked in `tests/jfo_squeeze.rs`
//! (`iteration_error_honest_through_rupture_and_reformation`).

use bearing_sweep::bearing::finite::{
    Cavitation, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, JfoHistory, JfoSolver,
};
use bearing_sweep::bearing::{pack_state, BearingParams, BearingState, FilmModel, Groove};

/// A bearing of radius 0.5 m with `B/D = 0.5`, δ = 1 mm, μ = 1 Pa·s, JFO finite film on
/// `nt × nz`.
fn bearing(nt: u32, nz: u32, grooves: &[Groove]) -> BearingParams {
    BearingParams {
        radius: 0.5,
        length: 0.5,
        clearance: 1e-3,
        viscosity: 1.0,
        model: FilmModel::Finite,
        finite: FiniteSettings {
            n_theta: Some(nt),
            n_z: Some(nz),
            cavitation: Cavitation::Jfo,
            ..FiniteSettings::default()
        },
        grooves: bearing_sweep::bearing::Grooves::new(grooves).unwrap(),
        ..BearingParams::paper_table2()
    }
}

/// A 20° ambient axial groove at 180° (the film reforms in the land before it).
fn side_groove() -> Groove {
    Groove {
        angle: 180.0,
        width: 20.0,
        supply_pressure: 0.0,
        length: None,
    }
}

/// `max(max|ΔP|/max P_ref, max|Δφ|)` between a field and the reference (pressure, then
/// film fraction).
fn distance(field: &[f64], reference: &[f64]) -> f64 {
    let n = reference.len() / 2;
    let pmax = reference[..n].iter().fold(0.0_f64, |a, &v| a.max(v));
    let dp = (0..n)
        .map(|k| (field[k] - reference[k]).abs())
        .fold(0.0, f64::max);
    let dphi = (n..2 * n)
        .map(|k| (field[k] - reference[k]).abs())
        .fold(0.0, f64::max);
    (dp / pmax).max(dphi)
}

/// Below this the true error is the reference's own level (its tolerance 1e-13 and the
/// rounding floor of the iteration, ~1e-13 at these grids), not judged.
const JUDGED_ABOVE: f64 = 1e-11;

/// Solves `job` at `tol` (from `start`), then on from that field to 1e-13; returns
/// `(reported, true)` and the converged field.
fn reported_and_true(
    job: &FiniteJob,
    g: &FiniteGrid,
    tol: f64,
    start: &[f64],
    history: Option<&JfoHistory>,
) -> (f64, f64, Vec<f64>) {
    let mut reynolds = FiniteSolver::new();
    let mut jfo = JfoSolver::new();
    let mut field = start.to_vec();
    let gt = FiniteGrid {
        tolerance: tol,
        ..*g
    };
    let (_, rep) = jfo.solve(&mut reynolds, job, &gt, &mut field, history);
    assert!(rep.converged, "{rep:?}");
    assert!(rep.iteration_error <= tol, "{rep:?}");
    let gr = FiniteGrid {
        tolerance: 1e-13,
        ..*g
    };
    let mut reference = field.clone();
    let (_, rr) = jfo.solve(&mut reynolds, job, &gr, &mut reference, history);
    assert!(rr.converged, "reference {rr:?}");
    (rep.iteration_error, distance(&field, &reference), reference)
}

fn job_of(p: &BearingParams, s: &BearingState) -> (FiniteJob, FiniteGrid) {
    let packed = pack_state(p, s).unwrap();
    (
        FiniteJob::of_state(p, &packed, s.omega),
        FiniteGrid::for_bearing(p),
    )
}

/// One ratio reported/true (None when the true error is below the judged level).
fn judge(what: &str, reported: f64, truth: f64) -> Option<f64> {
    eprintln!(
        "{what}: reported {reported:.3e}, true {truth:.3e}, ratio {:.2}",
        reported / truth
    );
    (truth > JUDGED_ABOVE).then_some(reported / truth)
}

/// All judged ratios within a factor 3 both ways.
fn assert_within_3x(ratios: &[f64], at_least: usize) {
    let lo = ratios.iter().fold(f64::INFINITY, |a, &v| a.min(v));
    let hi = ratios.iter().fold(0.0_f64, |a, &v| a.max(v));
    eprintln!("{} judged, ratios {lo:.2} ... {hi:.2}", ratios.len());
    assert!(ratios.len() >= at_least, "{} judged", ratios.len());
    assert!(
        lo >= 1.0 / 3.0 && hi <= 3.0,
        "reported/true {lo:.2} ... {hi:.2}"
    );
}

/// Steady states from cold starts (the Swift–Stieber start) and from warm starts (the
/// field of a nearby state), at tolerances 1e-5 ... 1e-9.
#[test]
fn reported_iteration_error_is_within_3x_on_steady_states() {
    let states = [
        (
            "aligned 0.6",
            BearingState {
                xi: 0.6e-3,
                xj: 0.6e-3,
                omega: 1.0,
                ..BearingState::default()
            },
        ),
        (
            "aligned 0.9",
            BearingState {
                xi: 0.9e-3,
                xj: 0.9e-3,
                omega: 1.0,
                ..BearingState::default()
            },
        ),
        (
            "tilted, whirling",
            BearingState {
                xi: 0.3e-3,
                yi: -0.2e-3,
                xj: 0.45e-3,
                yj: -0.1e-3,
                vxi: 1e-4,
                vyj: -2e-4,
                omega: 1.0,
                ..BearingState::default()
            },
        ),
        (
            "down 0.6",
            BearingState {
                yi: -0.6e-3,
                yj: -0.6e-3,
                omega: 1.0,
                ..BearingState::default()
            },
        ),
    ];
    let mut ratios = Vec::new();
    // The max-film inlet with tilt and squeeze: some rows' cavitated zones end before the
    // held column and the film reforms in the land (docs/jfo.md "When the two models
    // agree"). Session 35 (jfo2): 0.15 (72 × 16, 1e-5) was a rotation through zero at the
    // max-error node (a φ node next to the reformation) that the fit read as dead modes,
    // caught by the least error a mode of block multiplier >= r leaves after its previous
    // change (`BlockStop`): 0.75 there. Session 36: 0.31 at 128 × 32, 1e-5 cold, a slower
    // mode emerging at one front node (the fit's slowest multiplier grew 0.145 -> 0.374 in
    // the block of the stop), caught by deferring a stop while that multiplier grows by
    // more than `DRIFT` (1.5): 1.52 there. Listed apart, held to the same factor 3 (the
    // bound was 1/4 below before session 36, 1/8 before session 35).
    let mut reforming = Vec::new();
    for (nt, nz) in [(72, 16), (128, 32)] {
        for grooved in [false, true] {
            let g: &[Groove] = if grooved { &[side_groove()] } else { &[] };
            let mut p = bearing(nt, nz, g);
            if grooved {
                p.finite.inlet = bearing_sweep::bearing::finite::Inlet::None;
            }
            for (name, s) in &states {
                let (job, grid) = job_of(&p, s);
                let mut warm = Vec::new();
                for tol in [1e-5, 1e-7, 1e-9] {
                    let what = format!(
                        "{nt}x{nz} {} {name} tol {tol:.0e} cold",
                        if grooved { "groove" } else { "max-film" }
                    );
                    let (rep, truth, reference) = reported_and_true(&job, &grid, tol, &[], None);
                    let r = judge(&what, rep, truth);
                    if *name == "tilted, whirling" && !grooved {
                        reforming.extend(r);
                    } else {
                        ratios.extend(r);
                    }
                    warm = reference;
                }
                // Warm: the converged field of this state for a state moved by 2 % of δ.
                let moved = BearingState {
                    xi: s.xi + 0.02e-3,
                    yj: s.yj - 0.02e-3,
                    ..*s
                };
                let (job2, _) = job_of(&p, &moved);
                for tol in [1e-6, 1e-8] {
                    let what = format!(
                        "{nt}x{nz} {} {name} tol {tol:.0e} warm",
                        if grooved { "groove" } else { "max-film" }
                    );
                    let (rep, truth, _) = reported_and_true(&job2, &grid, tol, &warm, None);
                    let r = judge(&what, rep, truth);
                    if *name == "tilted, whirling" && !grooved {
                        reforming.extend(r);
                    } else {
                        ratios.extend(r);
                    }
                }
            }
        }
    }
    assert_within_3x(&ratios, 40);
    let lo = reforming.iter().fold(f64::INFINITY, |a: f64, &v| a.min(v));
    let hi = reforming.iter().fold(0.0_f64, |a, &v| a.max(v));
    eprintln!(
        "reforming in the land: {} judged, ratios {lo:.2} ... {hi:.2}",
        reforming.len()
    );
    assert!(
        reforming.len() >= 6 && lo >= 1.0 / 3.0 && hi <= 3.0,
        "reforming in the land: reported/true {lo:.2} ... {hi:.2}"
    );
}

/// Time steps of a circular whirl (ε = 0.5 about the bore centre, whirl at 0.3 ω, the
/// ambient groove at 180°, 72 × 16) with the film fraction carried from step to step
/// (the conservative step, [`JfoHistory::prev_ecc`]): each step solved at 1e-7 from the
/// previous step's field, judged against the same step solved on to 1e-13.
#[test]
fn reported_iteration_error_is_within_3x_on_whirl_time_steps() {
    let p = {
        let mut p = bearing(72, 16, &[side_groove()]);
        p.finite.inlet = bearing_sweep::bearing::finite::Inlet::None;
        p
    };
    let eps = 0.5e-3;
    let whirl = 0.3;
    let steps_per_period = 64;
    let dt = 2.0 * std::f64::consts::PI / whirl / steps_per_period as f64;
    let state = |t: f64| {
        let (c, s) = ((whirl * t).cos(), (whirl * t).sin());
        BearingState {
            xi: eps * c,
            yi: eps * s,
            xj: eps * c,
            yj: eps * s,
            vxi: -eps * whirl * s,
            vyi: eps * whirl * c,
            vxj: -eps * whirl * s,
            vyj: eps * whirl * c,
            omega: 1.0,
        }
    };
    let mut reynolds = FiniteSolver::new();
    let mut jfo = JfoSolver::new();
    let (job0, grid) = job_of(&p, &state(0.0));
    let mut field = Vec::new();
    jfo.solve(&mut reynolds, &job0, &grid, &mut field, None);
    let n = field.len() / 2;
    let packed_ecc = |t: f64| pack_state(&p, &state(t)).unwrap();
    let mut ratios = Vec::new();
    for step in 1..=steps_per_period {
        let t = step as f64 * dt;
        let phi_old = field[n..].to_vec();
        let prev = packed_ecc(t - dt);
        let cur = packed_ecc(t);
        let hist = JfoHistory {
            phi: &phi_old,
            dtau: dt * cur.rate_scale,
            prev_ecc: Some(prev.state.ecc),
        };
        let (job, _) = job_of(&p, &state(t));
        let (rep, truth, reference) = reported_and_true(&job, &grid, 1e-7, &field, Some(&hist));
        if step % 4 == 0 {
            ratios.extend(judge(&format!("step {step}"), rep, truth));
        }
        field = reference;
    }
    assert_within_3x(&ratios, 12);
}
