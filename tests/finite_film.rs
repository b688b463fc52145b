//! Finite-length Reynolds film (issue 16, docs/finite-film.md): limits, grid convergence,
//! Raimondi–Boyd, the stored model-error map, the backends and the interfaces.

mod common;

use std::f64::consts::PI;

use bearing_sweep::bearing::finite::{
    compute_short_model_error, error_map_settings, finite_loads, finite_solution,
    short_model_error, FiniteSettings, Inlet, ERROR_MAP_ASPECTS, ERROR_MAP_ECC,
};
use bearing_sweep::bearing::{
    film_loads, Accuracy, BearingParams, BearingState, FilmModel, FilmRule, Loads,
};

/// A bearing of radius 0.5 m with `B/D = b_over_d`, δ = 1 mm, μ = 1 Pa·s.
fn bearing(b_over_d: f64, model: FilmModel, finite: FiniteSettings) -> BearingParams {
    BearingParams {
        radius: 0.5,
        length: b_over_d,
        clearance: 1e-3,
        viscosity: 1.0,
        model,
        finite,
        ..BearingParams::paper_table2()
    }
}

/// Aligned journal displaced by `ε δ` along +x, spinning at 1 rad/s.
fn aligned(p: &BearingParams, ecc: f64) -> BearingState {
    BearingState {
        xi: ecc * p.clearance,
        xj: ecc * p.clearance,
        omega: 1.0,
        ..BearingState::default()
    }
}

fn grid(n_theta: u32, n_z: u32) -> FiniteSettings {
    FiniteSettings {
        n_theta: Some(n_theta),
        n_z: Some(n_z),
        tolerance: 1e-11,
        // The free inlet these checks were written for (issue 16's default).
        inlet: Inlet::None,
        ..FiniteSettings::default()
    }
}

fn short(p: &BearingParams, s: &BearingState) -> Loads {
    let rule = FilmRule::new(Accuracy::new(1e-10).unwrap().settings());
    film_loads(p, s, &rule).unwrap()
}

/// The Richardson-extrapolated load vector `(W_x, W_y, M_x/B, M_y/B)`.
fn extrapolated(p: &BearingParams, s: &BearingState, g: FiniteSettings) -> [f64; 4] {
    finite_solution(p, s, &g, true)
        .unwrap()
        .extrapolated
        .unwrap()
}

fn magnitude(v: &[f64]) -> f64 {
    v[0].hypot(v[1])
}

/// Attitude angle, degrees: between the line of centres (+x) and the load line.
fn attitude(v: &[f64]) -> f64 {
    v[1].abs().atan2(-v[0]).to_degrees()
}

#[track_caller]
fn check(label: &str, index: usize, actual: f64, expected: f64, tol: f64) {
    assert!(
        (actual - expected).abs() <= tol,
        "{label} [{index}]: actual {actual:.6e}, expected {expected:.6e}, |diff| {:.3e} > \
         tolerance {tol:.3e}",
        (actual - expected).abs()
    );
}

/// Aligned journals, B/D → 0: `d = 1 − |W_finite|/|W_short|` → 0 like (B/D)². The finite
/// loads are Richardson-extrapolated from 512×8 and 256×4 (in this limit the z profile
/// is parabolic, which the 3-point stencil integrates exactly; the error is in θ).
#[test]
fn short_bearing_limit_aligned_order_two() {
    for (n, &ecc) in [0.3, 0.6, 0.8].iter().enumerate() {
        let mut defects = Vec::new();
        for &bd in &[0.025, 0.05, 0.1] {
            let p = bearing(bd, FilmModel::Finite, grid(512, 8));
            let s = aligned(&p, ecc);
            let f = extrapolated(&p, &s, grid(512, 8));
            let sh = short(&p, &s).load_vector(p.length);
            let d = 1.0 - magnitude(&f) / magnitude(&sh);
            println!(
                "ε {ecc} B/D {bd}: defect {d:.6e}, attitude finite {:.4} short {:.4}",
                attitude(&f),
                attitude(&sh)
            );
            defects.push(d);
        }
        for k in 0..2 {
            assert!(defects[k] > 0.0, "defect must be positive: {defects:?}");
            let order = (defects[k + 1] / defects[k]).log2();
            check("short-limit order", n * 2 + k, order, 2.0, 0.15);
        }
    }
}

/// MODEL.md section 2: for a journal tilted about its mid-plane the B/D → 0 limit of the
/// full Reynolds equation carries about 0.42 of the slice model's end forces (the slice
/// model is not that limit). Checked at B/D = 0.025 and 0.05 (ratio within 0.38..0.46).
#[test]
fn tilted_journal_is_not_the_slice_model() {
    for (n, &bd) in [0.025, 0.05].iter().enumerate() {
        let p = bearing(bd, FilmModel::Finite, grid(256, 32));
        let s = BearingState {
            xi: 0.5e-3,
            xj: -0.5e-3,
            omega: 1.0,
            ..BearingState::default()
        };
        let f = finite_solution(&p, &s, &grid(256, 32), false)
            .unwrap()
            .loads;
        let sh = short(&p, &s);
        let (fi, _) = f.end_forces(p.length);
        let (si, _) = sh.end_forces(p.length);
        let ratio = magnitude(&fi) / magnitude(&si);
        println!("B/D {bd}: |F_i| finite/slice = {ratio:.4}");
        check("tilt end-force ratio", n, ratio, 0.42, 0.04);
    }
}

/// Infinitely long bearing, Reynolds condition, fed at the maximum film (ψ = 0 there,
/// `H = 1 + ε cos ψ`): `Π' = (H − H₂)/H³`, `Π(0) = Π(ψ₂) = Π'(ψ₂) = 0`. Returns the load
/// per unit length over `6 μ ω R³ / c²` and the attitude angle in degrees. Independent
/// of the 2-D code: bisection on ψ₂ and a 40 000-interval trapezoid rule.
fn long_bearing_reynolds(ecc: f64) -> (f64, f64) {
    let n = 40_000;
    let h = |psi: f64| 1.0 + ecc * psi.cos();
    let profile = |psi2: f64| -> Vec<f64> {
        let d = psi2 / n as f64;
        let h2 = h(psi2);
        let mut pi = vec![0.0; n + 1];
        let g = |k: usize| {
            let hk = h(k as f64 * d);
            (hk - h2) / (hk * hk * hk)
        };
        for k in 0..n {
            pi[k + 1] = pi[k] + 0.5 * d * (g(k) + g(k + 1));
        }
        pi
    };
    let (mut lo, mut hi) = (PI, 2.0 * PI);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if profile(mid)[n] > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let psi2 = 0.5 * (lo + hi);
    let pi = profile(psi2);
    let d = psi2 / n as f64;
    let (mut ir, mut it) = (0.0, 0.0);
    for (k, v) in pi.iter().enumerate() {
        let w = if k == 0 || k == n { 0.5 } else { 1.0 } * d;
        let psi = k as f64 * d;
        ir += w * v * psi.cos();
        it += w * v * psi.sin();
    }
    (ir.hypot(it), it.abs().atan2(ir.abs()).to_degrees())
}

/// Large B/D tends to the long-bearing (Sommerfeld) solution with the Reynolds condition,
/// for the bearing fed at the maximum film: the load per unit length and the attitude
/// angle approach the 1-D solution as B/D grows, the load defect falling like D/B (end
/// leakage): `B/D × (1 − |W|/|W_long|)` settles (within 25 % from B/D = 4 to 16), and at
/// B/D = 16 the defect is below 10 % and the attitude within 1°.
#[test]
fn long_bearing_limit() {
    for (n, &ecc) in [0.3, 0.6].iter().enumerate() {
        let (w1, att1) = long_bearing_reynolds(ecc);
        let mut errs = Vec::new();
        let aspects = [2.0, 4.0, 8.0, 16.0];
        for &bd in &aspects {
            let g = FiniteSettings {
                inlet: Inlet::MaxFilm,
                ..grid(128, (8.0 * bd) as u32 + 8)
            };
            let p = bearing(bd, FilmModel::Finite, g);
            let s = aligned(&p, ecc);
            let f = finite_solution(&p, &s, &g, false).unwrap().loads;
            let v = f.load_vector(p.length);
            let scale = 6.0 * p.viscosity * 1.0 * p.radius.powi(3) / (p.clearance * p.clearance);
            let ratio = magnitude(&v) / (p.length * scale * w1);
            let datt = attitude(&v) - att1;
            println!(
                "ε {ecc} B/D {bd}: |W|/|W_long| {ratio:.5}, attitude {:.3} vs {att1:.3}",
                attitude(&v)
            );
            errs.push(((1.0 - ratio).abs(), datt.abs()));
        }
        for k in 0..3 {
            assert!(
                errs[k + 1].0 < errs[k].0 && errs[k + 1].1 < errs[k].1,
                "long limit [{n}]: load and attitude errors must fall with B/D: {errs:?}"
            );
        }
        let c4 = aspects[1] * errs[1].0;
        let c16 = aspects[3] * errs[3].0;
        check("long-limit (B/D)·defect, 16 vs 4", n, c16, c4, 0.25 * c4);
        check(
            "long-limit load defect at B/D = 16",
            n,
            errs[3].0,
            0.0,
            0.10,
        );
        check(
            "long-limit attitude at B/D = 16, deg",
            n,
            errs[3].1,
            0.0,
            1.0,
        );
    }
}

/// Grid convergence of order 2 (refinement table printed with `--nocapture`): successive
/// differences of the load vector on grids 16×4 … 256×64 fall by 4 per halving. Two
/// states at B/D = 0.5: aligned ε = 0.6, and tilted + whirling + squeezing.
#[test]
fn grid_convergence_order_two() {
    let states = [
        BearingState {
            xi: 0.6e-3,
            xj: 0.6e-3,
            omega: 1.0,
            ..BearingState::default()
        },
        BearingState {
            xi: 0.5e-3,
            yi: 0.2e-3,
            xj: 0.2e-3,
            yj: -0.4e-3,
            vxi: 1e-4,
            vyi: 2e-4,
            vxj: -1e-4,
            vyj: 3e-4,
            omega: 1.0,
        },
    ];
    let grids = [(16, 4), (32, 8), (64, 16), (128, 32), (256, 64)];
    for (n, s) in states.iter().enumerate() {
        let p = bearing(0.5, FilmModel::Finite, grid(16, 4));
        let v: Vec<[f64; 4]> = grids
            .iter()
            .map(|&(a, b)| {
                finite_solution(&p, s, &grid(a, b), false)
                    .unwrap()
                    .loads
                    .load_vector(p.length)
            })
            .collect();
        let diffs: Vec<f64> = (0..v.len() - 1)
            .map(|k| {
                (0..4)
                    .map(|c| (v[k + 1][c] - v[k][c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / magnitude(&v[v.len() - 1])
            })
            .collect();
        println!("state {n}: grid | |W| N | attitude deg | |v_h − v_2h|/|v| | order");
        for (k, &(a, b)) in grids.iter().enumerate() {
            let d = if k > 0 { diffs[k - 1] } else { f64::NAN };
            let order = if k > 1 {
                (diffs[k - 2] / diffs[k - 1]).log2()
            } else {
                f64::NAN
            };
            println!(
                "  {a}×{b} | {:.6} | {:.4} | {d:.3e} | {order:.3}",
                magnitude(&v[k]),
                attitude(&v[k])
            );
        }
        // The cavitation boundary crosses grid lines as the grid is refined, so single
        // steps scatter about 2 (1.5..2.5); the mean over the table is held to 2 ± 0.2.
        for k in 1..diffs.len() - 1 {
            let order = (diffs[k - 1] / diffs[k]).log2();
            check("observed order, one step", n * 10 + k, order, 2.0, 0.5);
        }
        let mean = (diffs[0] / diffs[diffs.len() - 1]).log2() / (diffs.len() - 1) as f64;
        check("observed order, mean", n, mean, 2.0, 0.2);
    }
}

/// Raimondi & Boyd (1958), full (360°) journal bearing, Reynolds condition, as reprinted
/// in Shigley's design text: Sommerfeld number `S = (μN/P)(R/c)²` (N rev/s, `P = W/(LD)`)
/// and attitude angle φ (deg) against ε = 1 − h0/c:
///
/// ```text
///   ε      L/D = 1/4         L/D = 1/2         L/D = 1
///  0.1   16.2    82.31     4.31    81.62     1.33    79.5
///  0.2    7.57   75.18     2.03    74.94     0.631   74.02
///  0.4    2.83   60.86     0.779   61.45     0.264   63.10
///  0.6    1.07   46.72     0.319   48.14     0.121   50.58
///  0.8    0.261  31.04     0.0923  33.31     0.0446  36.24
///  0.9    0.0736 21.30     0.0313  23.66     0.0188  26.45
///  0.97     —      —       0.00609 13.75     0.00474 15.47
/// ```
///
/// The tables give 3 significant figures from coarse-mesh relaxation solutions of 1958;
/// we take their accuracy as 3 % in S and 1.5° in φ (the printed φ columns are not smooth
/// to better than ~1° across L/D). Compared with `inlet: "max_film"` (Raimondi and Boyd
/// hold ambient pressure at the maximum film, the bearing's feed) on 128×32,
/// Richardson-extrapolated from 64×16. The pure Swift–Stieber film (`inlet: "none"`, the
/// default) lets the pressure zone start upstream of the maximum film: same S within
/// 3 %, attitude within 1.5° for ε ≥ 0.6 but up to 4.5° larger below (at L/D = 1,
/// ε = 0.1: 83.8° against 79.5°), checked with those bounds.
#[test]
fn raimondi_boyd_full_bearing() {
    #[rustfmt::skip]
    let table: [(f64, f64, f64, f64); 20] = [
        (0.25, 0.1, 16.2, 82.31), (0.25, 0.2, 7.57, 75.18), (0.25, 0.4, 2.83, 60.86),
        (0.25, 0.6, 1.07, 46.72), (0.25, 0.8, 0.261, 31.04), (0.25, 0.9, 0.0736, 21.30),
        (0.5, 0.1, 4.31, 81.62), (0.5, 0.2, 2.03, 74.94), (0.5, 0.4, 0.779, 61.45),
        (0.5, 0.6, 0.319, 48.14), (0.5, 0.8, 0.0923, 33.31), (0.5, 0.9, 0.0313, 23.66),
        (0.5, 0.97, 0.00609, 13.75),
        (1.0, 0.1, 1.33, 79.5), (1.0, 0.2, 0.631, 74.02), (1.0, 0.4, 0.264, 63.10),
        (1.0, 0.6, 0.121, 50.58), (1.0, 0.8, 0.0446, 36.24), (1.0, 0.9, 0.0188, 26.45),
        (1.0, 0.97, 0.00474, 15.47),
    ];
    for (inlet, att_tol_low) in [(Inlet::MaxFilm, 1.5), (Inlet::None, 4.5)] {
        for (k, &(ld, ecc, s_rb, phi_rb)) in table.iter().enumerate() {
            let g = FiniteSettings {
                inlet,
                ..grid(128, 32)
            };
            let p = bearing(ld, FilmModel::Finite, g);
            let s = aligned(&p, ecc);
            let v = extrapolated(&p, &s, g);
            // S = μ (ω/2π) L D R² / (W c²).
            let som =
                p.viscosity * (1.0 / (2.0 * PI)) * p.length * 2.0 * p.radius * p.radius * p.radius
                    / (magnitude(&v) * p.clearance * p.clearance);
            let phi = attitude(&v);
            println!(
                "{inlet:?} L/D {ld} ε {ecc}: S {som:.5} (RB {s_rb}), φ {phi:.2} (RB {phi_rb})"
            );
            check("Raimondi-Boyd S (relative)", k, som / s_rb, 1.0, 0.03);
            let tol = if inlet == Inlet::None && ecc < 0.6 {
                att_tol_low
            } else {
                1.5
            };
            check("Raimondi-Boyd attitude, deg", k, phi, phi_rb, tol);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Backends and interfaces.

use bearing_sweep::backend::{CpuBackend, LoadEvaluator, LoadRequest};

/// States over the film's range: aligned, tilted, whirling, squeezing, near the wall.
fn mixed_states(p: &BearingParams, n: usize) -> Vec<BearingState> {
    let d = p.clearance;
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.7;
            let e = 0.05 + 0.9 * ((k * 37 % 101) as f64 / 100.0);
            let tilt = if k % 3 == 0 { 0.0 } else { 0.3 };
            BearingState {
                xi: e * d * t.cos(),
                yi: e * d * t.sin(),
                xj: e * d * (1.0 - tilt) * (t + 0.2).cos(),
                yj: e * d * (1.0 - tilt) * (t + 0.2).sin(),
                vxi: if k % 4 == 1 { 0.2 * d } else { 0.0 },
                vyi: if k % 4 == 2 { -0.3 * d } else { 0.0 },
                vxj: 0.0,
                vyj: if k % 5 == 0 { 0.1 * d } else { 0.0 },
                omega: if k % 7 == 3 { 0.0 } else { 1.0 },
            }
        })
        .collect()
}

fn eval_all(ev: &mut LoadEvaluator, p: &BearingParams, states: &[BearingState]) -> Vec<Loads> {
    let req: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut out = Vec::new();
    ev.evaluate(&[*p], &req, &mut out);
    out.into_iter()
        .enumerate()
        .map(|(k, r)| r.unwrap_or_else(|e| panic!("state {k}: {e}")))
        .collect()
}

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    let n = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    // A state without pressure (no spin, no squeeze): both zero.
    if n > 0.0 {
        d / n
    } else {
        d
    }
}

/// The evaluator's finite path (CPU backend, threads over states) equals the single-state
/// solver bit for bit (same sweeps, same order), for both inlets.
#[test]
fn evaluator_cpu_path_equals_the_direct_solver() {
    for inlet in [Inlet::None, Inlet::MaxFilm] {
        let g = FiniteSettings {
            inlet,
            ..grid(32, 8)
        };
        let p = bearing(0.5, FilmModel::Finite, g);
        let states = mixed_states(&p, 40);
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
        ev.set_warm_start(false);
        let got = eval_all(&mut ev, &p, &states);
        for (k, (s, l)) in states.iter().zip(&got).enumerate() {
            let want = finite_loads(&p, s, &g).unwrap();
            assert_eq!(
                l.load_vector(p.length),
                want.load_vector(p.length),
                "{inlet:?} state {k}: evaluator vs direct solver"
            );
        }
        let loaded = states
            .iter()
            .filter(|s| {
                bearing_sweep::bearing::pack_state(&p, s)
                    .unwrap()
                    .rate_scale
                    > 0.0
            })
            .count();
        assert_eq!(ev.stats().finite_states, loaded as u64);
    }
}

/// Warm start: re-evaluating slightly moved states (1e-4 relative, a time step's worth)
/// from the previous fields gives the cold result to the solver tolerance (checked at
/// 1e-6 relative with tolerance 1e-9) in fewer sweeps (SOR converges linearly, so a start
/// 1e-4 off saves about log(1e-4)/log(1e-9) of the sweeps).
#[test]
fn warm_start_agrees_with_cold_start_in_fewer_sweeps() {
    let g = FiniteSettings {
        tolerance: 1e-9,
        ..grid(64, 16)
    };
    let p = bearing(0.5, FilmModel::Finite, g);
    let states = mixed_states(&p, 24);
    let moved: Vec<BearingState> = states
        .iter()
        .map(|s| BearingState {
            xi: s.xi * (1.0 + 1e-4),
            yj: s.yj * (1.0 - 1e-4) + 1e-6 * p.clearance,
            ..*s
        })
        .collect();
    let mut warm = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    eval_all(&mut warm, &p, &states);
    let before = warm.stats();
    let w = eval_all(&mut warm, &p, &moved);
    let after = warm.stats();
    let mut cold = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    cold.set_warm_start(false);
    eval_all(&mut cold, &p, &states);
    let c0 = cold.stats();
    let c = eval_all(&mut cold, &p, &moved);
    let c1 = cold.stats();
    for (k, (a, b)) in w.iter().zip(&c).enumerate() {
        let e = rel(&a.load_vector(p.length), &b.load_vector(p.length));
        check("warm vs cold", k, e, 0.0, 1e-6);
    }
    let warm_sweeps = after.finite_sweeps - before.finite_sweeps;
    let cold_sweeps = c1.finite_sweeps - c0.finite_sweeps;
    println!("sweeps for 24 moved states: warm {warm_sweeps}, cold {cold_sweeps}");
    let solved = after.finite_states - before.finite_states;
    assert_eq!(after.finite_warm_starts - before.finite_warm_starts, solved);
    assert!(
        (warm_sweeps as f64) < 0.7 * cold_sweeps as f64,
        "warm start must save sweeps: warm {warm_sweeps}, cold {cold_sweeps}"
    );
}

/// CPU and the WGSL kernel agree to the solver tolerance (tolerance 1e-10: load vectors
/// within 1e-8 relative), cold and warm, both inlets; lavapipe here.
#[test]
fn cpu_and_gpu_agree() {
    let Some(gpu) = common::gpu_f64_or_skip("finite-film GPU") else {
        return;
    };
    let mut gpu_ev = LoadEvaluator::new(Box::new(gpu));
    for inlet in [Inlet::None, Inlet::MaxFilm] {
        let g = FiniteSettings {
            inlet,
            tolerance: 1e-10,
            ..grid(64, 16)
        };
        let p = bearing(0.5, FilmModel::Finite, g);
        let states = mixed_states(&p, 48);
        let mut cpu_ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
        for pass in 0..2 {
            let c = eval_all(&mut cpu_ev, &p, &states);
            let gl = eval_all(&mut gpu_ev, &p, &states);
            for (k, (a, b)) in gl.iter().zip(&c).enumerate() {
                let e = rel(&a.load_vector(p.length), &b.load_vector(p.length));
                check(
                    &format!("GPU vs CPU ({inlet:?}, pass {pass})"),
                    k,
                    e,
                    0.0,
                    1e-8,
                );
            }
        }
        assert!(gpu_ev.take_notices().is_empty(), "no CPU fallback expected");
    }
    let st = gpu_ev.stats();
    assert!(
        st.finite_warm_starts > 0 && st.cpu_recomputed == 0,
        "{st:?}"
    );
}

/// A grid beyond the GPU kernels' range (the PSOR kernel's workgroup memory, then the
/// multigrid kernel's 270 000 nodes, src/backend/finite_mg.rs "Range") is recomputed on
/// the CPU with a notice, not lost.
#[test]
fn gpu_grid_beyond_workgroup_memory_falls_back_to_cpu() {
    let Some(gpu) = common::gpu_f64_or_skip("finite-film GPU") else {
        return;
    };
    let g = grid(1024, 320);
    let p = bearing(0.5, FilmModel::Finite, g);
    let states = mixed_states(&p, 3);
    let mut ev = LoadEvaluator::new(Box::new(gpu));
    let got = eval_all(&mut ev, &p, &states);
    let notices = ev.take_notices();
    assert!(
        notices.iter().any(|n| n.contains("kernel's range")),
        "{notices:?}"
    );
    for (k, (s, l)) in states.iter().zip(&got).enumerate() {
        let want = finite_loads(&p, s, &g).unwrap();
        let e = rel(&l.load_vector(p.length), &want.load_vector(p.length));
        check("fallback vs direct", k, e, 0.0, 1e-12);
    }
}

/// The stored model-error map is what the code computes: entries recomputed on the map's
/// grid match to the stored rounding (5 decimals in load, 3 in attitude degrees); an
/// interpolated point between nodes is within 10 % (load) of a direct computation.
#[test]
fn stored_error_map_matches_recomputation() {
    let g = error_map_settings();
    for (n, &(bi, ei)) in [(0usize, 6usize), (4, 6), (9, 10), (2, 0), (6, 3)]
        .iter()
        .enumerate()
    {
        let (bd, ecc) = (ERROR_MAP_ASPECTS[bi], ERROR_MAP_ECC[ei]);
        let direct = compute_short_model_error(bd, ecc, &g);
        let stored = short_model_error(bd, ecc);
        check("map load", n, stored.load, direct.load, 1e-5);
        check(
            "map attitude, deg",
            n,
            stored.attitude_deg,
            direct.attitude_deg,
            1e-3,
        );
        assert!(!stored.extrapolated);
    }
    let (bd, ecc) = (0.45, 0.65);
    let direct = compute_short_model_error(bd, ecc, &g);
    let interp = short_model_error(bd, ecc);
    check(
        "map interpolation (relative)",
        0,
        interp.load / direct.load,
        1.0,
        0.10,
    );
    // Outside: below B/D = 0.1 the (B/D)² law, beyond the edges flagged.
    let small = short_model_error(0.05, 0.6);
    check(
        "map (B/D)² below 0.1",
        0,
        small.load,
        short_model_error(0.1, 0.6).load / 4.0,
        1e-12,
    );
    assert!(short_model_error(1.5, 0.5).extrapolated && short_model_error(0.5, 0.97).extrapolated);
}

/// `"model": "auto"` evaluates a state with the short model where the map's error at its
/// eccentricity is under `finite.auto_tolerance`, else with the finite one, and the loads
/// are exactly those of the chosen model.
#[test]
fn auto_model_switches_on_the_mapped_error() {
    let g = FiniteSettings {
        auto_tolerance: 0.05,
        ..grid(64, 16)
    };
    let p = bearing(0.1, FilmModel::Auto, g);
    // B/D = 0.1: 1.4 % at ε = 0.6 (short), 14 % at ε = 0.95 (finite).
    let states = [aligned(&p, 0.6), aligned(&p, 0.95)];
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let got = eval_all(&mut ev, &p, &states);
    assert_eq!(ev.stats().finite_states, 1);
    let rule = FilmRule::new(Accuracy::default().settings());
    let want_short = film_loads(&p, &states[0], &rule).unwrap();
    assert_eq!(
        got[0].load_vector(p.length),
        want_short.load_vector(p.length)
    );
    let want_finite = finite_loads(&p, &states[1], &g).unwrap();
    assert_eq!(
        got[1].load_vector(p.length),
        want_finite.load_vector(p.length)
    );
}

/// The bearing object takes `model` and `finite` wherever a bearing is given; bad values
/// are rejected naming the field.
#[test]
fn bearing_json_takes_model_and_rejects_bad_settings() {
    let p: BearingParams = serde_json::from_value(serde_json::json!({
        "radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.0242,
        "model": "finite", "finite": {"n_theta": 48, "n_z": 12, "inlet": "max_film"}
    }))
    .unwrap();
    assert_eq!(p.model, FilmModel::Finite);
    assert_eq!(
        (p.finite.n_theta, p.finite.n_z, p.finite.inlet),
        (Some(48), Some(12), Inlet::MaxFilm)
    );
    assert_eq!(p.finite.tolerance, FiniteSettings::default().tolerance);
    let default: BearingParams = serde_json::from_value(serde_json::json!({
        "radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.0242
    }))
    .unwrap();
    assert_eq!(default.model, FilmModel::Short);
    for (finite, field) in [
        (
            serde_json::json!({"n_theta": 51, "n_z": 8}),
            "finite.n_theta",
        ),
        (serde_json::json!({"n_theta": 64, "n_z": 1}), "finite.n_z"),
        (serde_json::json!({"tolerance": 0.0}), "finite.tolerance"),
        (
            serde_json::json!({"auto_tolerance": -1.0}),
            "finite.auto_tolerance",
        ),
    ] {
        let p = BearingParams {
            finite: serde_json::from_value(finite.clone()).unwrap(),
            ..BearingParams::paper_table2()
        };
        let e = p.validate().expect_err("must be rejected");
        assert_eq!(e.field, field, "{finite}: {e}");
    }
    let bad: Result<BearingParams, _> = serde_json::from_value(serde_json::json!({
        "radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.0242, "model": "long"
    }));
    assert!(bad.unwrap_err().to_string().contains("unknown variant"));
}

/// A rotor scene runs with either model (the paper rotor, 0.05 s): both finish, the
/// finite film carries the rotor at a larger eccentricity (the short model overestimates
/// the load at B/D = 0.5 by ~30 %), and the run reports the short model's mapped error.
#[test]
fn rotor_scene_runs_with_either_model() {
    use bearing_sweep::rotor::{load_scene, simulate_batch, SimStatus};
    let base: serde_json::Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    let mut results = Vec::new();
    for model in ["short", "finite"] {
        let mut s = base.clone();
        s["compare_ideal"] = serde_json::json!(false);
        s["integrator"]["t_end"] = serde_json::json!(0.05);
        for b in s["bearings"].as_array_mut().unwrap() {
            b["model"] = serde_json::json!(model);
            // 128×16-class grids: the run's point is the model switch, not 5e-4.
            b["finite"] = serde_json::json!({"accuracy": 1e-2});
        }
        let scenes = load_scene(&s.to_string()).unwrap();
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
        let r = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
        assert!(
            matches!(r.status, SimStatus::Finished),
            "{model}: {:?}",
            r.status
        );
        let fe = r
            .model_reductions
            .film_model_error
            .clone()
            .expect("film model report");
        if model == "short" {
            assert_eq!(fe.applied_to, fe.of);
            assert!(fe.error.unwrap() > 0.05, "{fe:?}");
            assert_eq!(ev.stats().finite_states, 0);
        } else {
            assert_eq!(fe.applied_to, Some(0));
            assert!(ev.stats().finite_states > 0);
        }
        results.push(r);
    }
    let ecc_max = |r: &bearing_sweep::rotor::SimResult| {
        r.samples
            .bearings
            .iter()
            .flat_map(|b| b.eccentricity_max.iter().copied())
            .fold(0.0, f64::max)
    };
    let (es, ef) = (ecc_max(&results[0]), ecc_max(&results[1]));
    println!("ε_max short {es:.4}, finite {ef:.4}");
    assert!(ef > es, "finite film is softer: ε_max {ef} vs {es}");
}

/// `eval` with a finite bearing reports the model and a Richardson error estimate per
/// state, and the estimate tracks the true discretisation error at accuracy 2e-3
/// (against 1024×128 extrapolated): within a factor 3 either way.
#[test]
fn eval_reports_model_and_a_truthful_error_estimate() {
    use bearing_sweep::app::{eval_json, EvalOptions};
    let input = serde_json::json!({
        "bearing": {"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.0242,
                    "model": "finite", "finite": {"accuracy": 2e-3, "inlet": "none"}},
        "states": [
            {"xi": 1.8e-4, "yi": 0.0, "xj": 1.8e-4, "yj": 0.0, "vxi": 0.0, "vyi": 0.0,
             "vxj": 0.0, "vyj": 0.0, "omega": 100.0},
            {"xi": 1.5e-4, "yi": 6e-5, "xj": 6e-5, "yj": -1.2e-4, "vxi": 3e-3, "vyi": 6e-3,
             "vxj": -3e-3, "vyj": 9e-3, "omega": 100.0}
        ]
    });
    let (out, _) = eval_json(&input.to_string(), EvalOptions::default()).unwrap();
    assert_eq!(out["film_model"], "finite");
    let p: BearingParams = serde_json::from_value(input["bearing"].clone()).unwrap();
    for k in 0..2 {
        let l = &out["loads"][k];
        assert_eq!(l["film_model"], "finite");
        let est = l["finite_error_estimate"].as_f64().unwrap();
        let s: BearingState = serde_json::from_value(input["states"][k].clone()).unwrap();
        let reference = extrapolated(&p, &s, grid(1024, 128));
        let got = [
            l["wx"].as_f64().unwrap(),
            l["wy"].as_f64().unwrap(),
            l["mx"].as_f64().unwrap() / p.length,
            l["my"].as_f64().unwrap() / p.length,
        ];
        let actual = rel(&got, &reference);
        println!("state {k}: estimate {est:.3e}, actual {actual:.3e}");
        check(
            "estimate / actual (log10)",
            k,
            (est / actual).log10(),
            0.0,
            3f64.log10(),
        );
    }
}

/// A sweep axis varies the film model (`bearings[*].model`): the CLI runs both variants of
/// the paper rotor (0.02 s), both finish, the finite one reaches the larger eccentricity,
/// and only the short one reports a mapped short-model error.
#[test]
fn a_sweep_axis_varies_the_film_model() {
    let dir = std::env::temp_dir().join(format!("bearing-sweep-finite-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut base: serde_json::Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    base.as_object_mut().unwrap().remove("compare_ideal");
    base["integrator"]["t_end"] = serde_json::json!(0.02);
    for b in base["bearings"].as_array_mut().unwrap() {
        b["model"] = serde_json::json!("short");
        b["finite"] = serde_json::json!({"accuracy": 1e-2});
    }
    let spec = serde_json::json!({
        "kind": "rotor", "name": "film model axis", "base": base,
        "axes": [{"path": "bearings[*].model", "values": ["short", "finite"]}]
    });
    let path = dir.join("model-axis.json");
    std::fs::write(&path, spec.to_string()).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
        .args(["run", "--quiet", "--out"])
        .arg(&dir)
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("model-axis").join("result.json")).unwrap(),
    )
    .unwrap();
    let v = r["variants"].as_array().unwrap();
    assert_eq!(v.len(), 2);
    let mut ecc = [0.0; 2];
    for (k, model) in ["short", "finite"].iter().enumerate() {
        let x = v
            .iter()
            .find(|x| x["params"]["bearings[*].model"] == *model)
            .unwrap();
        assert_eq!(x["status"], "ok", "{model}: {}", x["status"]);
        ecc[k] = x["reductions"]["bearings"][0]["eccentricity_max"]["value"]
            .as_f64()
            .unwrap();
        let fe = &x["sim"]["model_reductions"]["film_model_error"];
        assert_eq!(fe["error"].is_number(), *model == "short", "{model}: {fe}");
    }
    assert!(ecc[1] > ecc[0], "finite film softer: {ecc:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
