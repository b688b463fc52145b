//! Numerical stress tests (issue 6): the film kernel and the rotor at the edges of the
//! parameter space. Nothing panics, every output is finite or carries a documented
//! status, the kernel converges (and keeps its promises up to ε = 0.99) near the wall,
//! and the CPU and GPU backends give the same statuses and figures.
//!
//! Kernel level: end eccentricity ratios up to 0.999 at one or both ends, tilt up to
//! contact at one end (ε_j = 1 − 1e-9), viscosity 1e-4 .. 10 Pa·s, clearance 5 µm ..
//! 2 mm, spin 0, reversed and 2e4 rad/s, zero load. Rotor level: unbalance driving the
//! journal into the wall (with and without the contact model), the same extreme
//! parameters, and a long run (energy balance, quaternion norm and attitude drift).
//!
//! GPU cases skip with a printed notice when no adapter exists, unless
//! `BEARING_SWEEP_REQUIRE_GPU=1`, where a missing adapter fails the test.

use bearing_sweep::backend::{
    create_backend, BackendKind, CpuBackend, FilmBackend, GpuBackend, GpuOptions, LoadEvaluator,
    LoadRequest, LoadResult, Precision,
};
use bearing_sweep::bearing::reference::reference_loads;
use bearing_sweep::bearing::{Accuracy, BearingParams, BearingState, ClearanceConvention};
use bearing_sweep::integrate::Method;
use bearing_sweep::rotor::{
    load_scene, simulate_batch, ContactSpec, ModelKind, Scene, SimResult, SimStatus, SpinMode,
};

const PAPER: &str = include_str!("../sweeps/paper-example.json");

fn gpu_required() -> bool {
    std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

fn bearing(clearance: f64, viscosity: f64) -> BearingParams {
    BearingParams {
        radius: 0.02,
        length: 0.02,
        clearance,
        viscosity,
        clearance_convention: ClearanceConvention::Paper,
        ..BearingParams::paper_table2()
    }
}

/// A state with end eccentricity ratios `ei, ej` at angles `ai, aj` (rad), squeeze
/// velocities `v` (m/s, the same at both ends along x) and spin `omega` (rad/s).
fn state(d: f64, ei: f64, ai: f64, ej: f64, aj: f64, v: f64, omega: f64) -> BearingState {
    BearingState {
        xi: ei * d * ai.cos(),
        yi: ei * d * ai.sin(),
        xj: ej * d * aj.cos(),
        yj: ej * d * aj.sin(),
        vxi: v,
        vyi: 0.5 * v,
        vxj: -v,
        vyj: 0.0,
        omega,
    }
}

/// Kernel stress states in the paper's bearing, with their larger end ratio: aligned,
/// parallel, tilted and crossed journals at one or both ends near the wall, with and
/// without squeeze, every spin sign.
fn near_wall_states(d: f64) -> Vec<(BearingState, f64)> {
    let mut v = Vec::new();
    for &eps in &[0.9, 0.95, 0.99, 0.995, 0.999] {
        for &omega in &[100.0, -100.0, 0.0] {
            for &sq in &[0.0, d * 50.0] {
                if omega == 0.0 && sq == 0.0 {
                    continue;
                }
                // both ends at eps, aligned
                v.push((state(d, eps, 0.3, eps, 0.3, sq, omega), eps));
                // both ends at eps, crossed (tilt about the mid-plane)
                v.push((state(d, eps, 0.3, eps, 0.3 + 2.5, sq, omega), eps));
                // one end at eps (tilted journal), the other moderate
                v.push((state(d, eps, 1.0, 0.4, 1.3, sq, omega), eps));
                v.push((state(d, 0.2, -2.0, eps, -1.9, sq, omega), eps));
            }
        }
    }
    v
}

/// Relative Euclidean error of the load vector `(W_x, W_y, M_x/B, M_y/B)`.
fn rel_err(got: [f64; 4], want: [f64; 4]) -> f64 {
    let d: f64 = got.iter().zip(&want).map(|(a, b)| (a - b) * (a - b)).sum();
    let n: f64 = want.iter().map(|a| a * a).sum();
    if n == 0.0 {
        d.sqrt()
    } else {
        (d / n).sqrt()
    }
}

fn vector(l: &bearing_sweep::bearing::Loads, b: &BearingParams) -> [f64; 4] {
    let m = |x: f64| x / b.length;
    [l.wx, l.wy, m(l.mx), m(l.my)]
}

fn evaluate(
    backend: Box<dyn FilmBackend>,
    b: &BearingParams,
    states: &[BearingState],
) -> Vec<LoadResult> {
    let requests: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut ev = LoadEvaluator::new(backend);
    let mut out = Vec::new();
    ev.evaluate(std::slice::from_ref(b), &requests, &mut out);
    out
}

fn cpu_loads(accuracy: f64, b: &BearingParams, states: &[BearingState]) -> Vec<LoadResult> {
    let acc = Accuracy::new(accuracy).unwrap();
    evaluate(Box::new(CpuBackend::new(acc, Some(1))), b, states)
}

/// Every number of a result finite (`friction_coefficient`/`sommerfeld` may be `None`).
fn assert_loads_finite(r: &LoadResult, what: &str) {
    if let Ok(l) = r {
        for (name, x) in [
            ("wx", l.wx),
            ("wy", l.wy),
            ("mx", l.mx),
            ("my", l.my),
            ("mz", l.mz),
            ("h_min", l.h_min),
            ("power_loss", l.power_loss),
            (
                "friction_coefficient",
                l.friction_coefficient.unwrap_or(0.0),
            ),
            ("sommerfeld", l.sommerfeld.unwrap_or(0.0)),
        ] {
            assert!(x.is_finite(), "{what}: {name} = {x}");
        }
    }
}

#[test]
fn near_wall_states_converge_and_keep_the_promise_up_to_0_99() {
    let b = bearing(3e-4, 0.0242);
    let cases = near_wall_states(b.clearance);
    let states: Vec<BearingState> = cases.iter().map(|c| c.0).collect();
    let levels = [1e-3, 1e-6, 1e-9, 1e-12];
    let results: Vec<Vec<LoadResult>> = levels.iter().map(|&a| cpu_loads(a, &b, &states)).collect();
    // Worst error per level and per eccentricity band (0.95, 0.99, 0.995, 0.999).
    let bands = [0.95, 0.99, 0.995, 0.999];
    let mut worst = [[0.0f64; 4]; 4];
    for (k, (s, eps)) in cases.iter().enumerate() {
        let want = reference_loads(&b, s, 1e-14).expect("inside the bore");
        for (li, &level) in levels.iter().enumerate() {
            let r = &results[li][k];
            assert_loads_finite(r, &format!("state {k} (eps {eps}) level {level:e}"));
            let got = vector(r.as_ref().expect("inside the bore: loads"), &b);
            let err = rel_err(
                got,
                [want[0], want[1], want[2] / b.length, want[3] / b.length],
            );
            let band = bands.iter().position(|&e| *eps <= e + 1e-12).unwrap();
            worst[li][band] = worst[li][band].max(err);
            let acc = Accuracy::new(level).unwrap();
            let promise = if *eps <= 0.95 {
                Some(acc.rtol())
            } else if *eps <= 0.99 {
                Some(acc.promise_near_wall())
            } else {
                None // beyond the promise: measured and reported below, bounded loosely
            };
            if let Some(p) = promise {
                assert!(
                    err <= p,
                    "state {k} (eps {eps}), level {level:e}: relative error {err:.3e} > promise {p:.0e}; got {got:?}, want {want:?}"
                );
            } else {
                // Not promised, but it must still be a usable, converging answer.
                let bound = 1e2 * acc.promise_near_wall();
                assert!(
                    err <= bound,
                    "state {k} (eps {eps}), level {level:e}: relative error {err:.3e} > {bound:.0e}"
                );
            }
        }
    }
    for (li, level) in levels.iter().enumerate() {
        eprintln!(
            "level {level:e}: worst relative error at eps <= 0.95 {:.2e}, <= 0.99 {:.2e}, <= 0.995 {:.2e}, <= 0.999 {:.2e}",
            worst[li][0], worst[li][1], worst[li][2], worst[li][3]
        );
    }
    // Converging: the tightest level beats the loosest in every band.
    for (band, (tight, loose)) in worst[3].iter().zip(&worst[0]).enumerate() {
        assert!(
            tight < loose,
            "band {band}: level 1e-12 error {tight:.2e} not below level 1e-3 error {loose:.2e}"
        );
    }
}

#[test]
fn tilt_up_to_contact_at_one_end_gives_finite_loads_or_through_wall() {
    // The journal tilted until one end face touches the wall: ε_j → 1 − 1e-9 with the
    // other end centred or moderate; ε_j = 1 exactly and beyond are `through_wall`.
    let b = bearing(3e-4, 0.0242);
    let d = b.clearance;
    let mut states = Vec::new();
    for &ej in &[1.0 - 1e-6, 1.0 - 1e-7, 1.0 - 1e-8, 1.0 - 1e-9] {
        for &ei in &[0.0, 0.3, 0.9] {
            for &omega in &[100.0, -100.0, 2e4] {
                states.push(state(d, ei, 0.7, ej, 0.7, 0.0, omega));
                states.push(state(d, ei, 0.7, ej, 2.0, d * 10.0, omega));
            }
        }
    }
    let n_inside = states.len();
    states.push(state(d, 0.3, 0.7, 1.0, 0.7, 0.0, 100.0));
    states.push(state(d, 0.3, 0.7, 1.0 + 1e-9, 0.7, 0.0, 100.0));
    for level in [1e-3, 1e-6, 1e-12] {
        let rs = cpu_loads(level, &b, &states);
        for (k, r) in rs.iter().enumerate() {
            assert_loads_finite(r, &format!("state {k} level {level:e}"));
            if k < n_inside {
                let l = r
                    .as_ref()
                    .unwrap_or_else(|e| panic!("state {k} ({:?}) inside the bore: {e}", states[k]));
                assert!(l.h_min > 0.0 && l.h_min < 1e-9 * d * 1.01 + 1e-6 * d);
            } else {
                assert_eq!(
                    r.as_ref().map(|_| "ok").unwrap_or_else(|e| e.code()),
                    "through_wall",
                    "state {k}"
                );
            }
        }
    }
    // Converging to the reference at the touching end (no promise there: reported).
    let rs = cpu_loads(1e-12, &b, &states[..n_inside]);
    let mut worst = 0.0f64;
    for (k, s) in states[..n_inside].iter().enumerate() {
        let w = reference_loads(&b, s, 1e-13).unwrap();
        let want = [w[0], w[1], w[2] / b.length, w[3] / b.length];
        let err = rel_err(vector(rs[k].as_ref().unwrap(), &b), want);
        worst = worst.max(err);
        assert!(err < 1e-3, "state {k}: relative error {err:.2e} at contact");
    }
    eprintln!("tilt to contact: worst relative error at level 1e-12: {worst:.2e}");
}

#[test]
fn extreme_viscosity_clearance_and_speed_scale_exactly() {
    // The short-bearing loads are linear in μ, scale as 1/δ² at fixed ratios and
    // velocities per clearance, are linear in ω without squeeze, and mirror under
    // ω → −ω (y → −y): checked at 1e-4 .. 10 Pa·s, 5 µm .. 2 mm, 0 .. 2e4 rad/s.
    let base = bearing(3e-4, 0.0242);
    let states_for = |d: f64, omega: f64| {
        vec![
            state(d, 0.5, 0.3, 0.5, 0.3, 0.0, omega),
            state(d, 0.9, 0.3, 0.7, 1.3, 0.0, omega),
            state(d, 0.99, -1.0, 0.2, -0.5, 0.0, omega),
        ]
    };
    let tol = 1e-9; // two evaluations at 1e-12 plus rounding of the scaled inputs
    let reference = cpu_loads(1e-12, &base, &states_for(base.clearance, 100.0));
    let check = |what: &str, got: &[LoadResult], scale: f64, mirror: bool| {
        for (k, (g, w)) in got.iter().zip(&reference).enumerate() {
            assert_loads_finite(g, what);
            let g = vector(g.as_ref().unwrap(), &base);
            let w = vector(w.as_ref().unwrap(), &base);
            // Mirror y → −y: W_y, M_x/B change sign (M_x = -∫ y-moment), W_x, M_y/B do
            // not... plus the spin reversal maps the pressure field onto its mirror.
            let want = if mirror {
                [w[0] * scale, -w[1] * scale, -w[2] * scale, w[3] * scale]
            } else {
                [w[0] * scale, w[1] * scale, w[2] * scale, w[3] * scale]
            };
            let err = rel_err(g, want);
            assert!(
                err < tol,
                "{what}: state {k}: {g:?} vs {want:?}: {err:.2e} > {tol:e}"
            );
        }
    };
    for mu in [1e-4, 1e-2, 1.0, 10.0] {
        let b = bearing(base.clearance, mu);
        let got = cpu_loads(1e-12, &b, &states_for(b.clearance, 100.0));
        check(&format!("viscosity {mu}"), &got, mu / base.viscosity, false);
    }
    for d in [5e-6, 2e-5, 1e-3, 2e-3] {
        let b = bearing(d, base.viscosity);
        let got = cpu_loads(1e-12, &b, &states_for(d, 100.0));
        let s = (base.clearance / d).powi(2);
        check(&format!("clearance {d}"), &got, s, false);
    }
    for omega in [1e-3, 1.0, 2e4] {
        let got = cpu_loads(1e-12, &base, &states_for(base.clearance, omega));
        check(&format!("spin {omega}"), &got, omega / 100.0, false);
    }
    // Reversed spin of the mirrored state.
    let mirrored: Vec<BearingState> = states_for(base.clearance, -100.0)
        .into_iter()
        .map(|mut s| {
            s.yi = -s.yi;
            s.yj = -s.yj;
            s
        })
        .collect();
    let got = cpu_loads(1e-12, &base, &mirrored);
    check("reversed spin, mirrored", &got, 1.0, true);
}

#[test]
fn zero_load_and_zero_spin_states_are_finite_with_documented_nulls() {
    let b = bearing(3e-4, 0.0242);
    let centred = |omega: f64| BearingState {
        omega,
        ..BearingState::default()
    };
    let states = vec![
        centred(0.0),                                     // nothing moves: no pressure
        centred(100.0), // centred spinning journal: zero load, finite torque
        centred(-2e4),  // reversed, fast
        state(b.clearance, 0.5, 0.0, 0.5, 0.0, 0.0, 0.0), // off centre, still: no pressure
    ];
    let rs = cpu_loads(1e-6, &b, &states);
    for (k, r) in rs.iter().enumerate() {
        assert_loads_finite(r, &format!("state {k}"));
        let l = r.as_ref().unwrap();
        assert_eq!([l.wx, l.wy, l.mx, l.my], [0.0; 4], "state {k}: no load");
        if states[k].omega == 0.0 {
            assert_eq!(l.sommerfeld, None, "state {k}: S infinite at ω = 0");
            assert_eq!(l.mz, 0.0, "state {k}");
        } else {
            // W = 0 with spin: S = 0, f infinite -> null; the torque is finite and opposes ω.
            assert_eq!(l.friction_coefficient, None, "state {k}");
            assert!(l.mz * states[k].omega < 0.0, "state {k}: torque {}", l.mz);
        }
    }
}

/// The GPU backend at the adapter's best precision, or `None` (skip) without an adapter.
fn gpu(accuracy: f64) -> Option<GpuBackend> {
    match GpuBackend::new(Accuracy::new(accuracy).unwrap(), GpuOptions::default()) {
        Ok(g) => Some(g),
        Err(e) if gpu_required() => panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}"),
        Err(e) => {
            eprintln!("notice: skipping the GPU cases: {e}");
            None
        }
    }
}

#[test]
fn cpu_and_gpu_agree_on_the_stress_states() {
    let Some(g) = gpu(1e-6) else { return };
    let f64_kernel = g.precision() == Precision::F64;
    let g: Box<dyn FilmBackend> = Box::new(g);
    // The same states in bearings spanning the parameter ranges, plus contact and
    // through-the-wall states.
    let mut all = Vec::new();
    for (d, mu) in [(3e-4, 0.0242), (5e-6, 1e-4), (2e-3, 10.0)] {
        let b = bearing(d, mu);
        let mut states: Vec<(BearingState, f64)> = near_wall_states(d);
        for &omega in &[0.0, -2e4, 2e4] {
            states.push((state(d, 0.3, 0.7, 1.0 - 1e-9, 0.7, 0.0, omega), 1.0));
            states.push((state(d, 0.0, 0.0, 0.0, 0.0, 0.0, omega), 0.0));
            states.push((state(d, 0.3, 0.7, 1.0, 0.7, 0.0, omega), 1.0));
        }
        all.push((b, states));
    }
    let (mut worst95, mut worst99, mut worst999, mut worst_contact) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    // Every bearing's states in ONE evaluator call (requests name their bearing).
    let bearings: Vec<BearingParams> = all.iter().map(|a| a.0).collect();
    let requests: Vec<LoadRequest> = all
        .iter()
        .enumerate()
        .flat_map(|(bi, (_, cases))| {
            cases.iter().map(move |c| LoadRequest {
                bearing: bi as u32,
                state: c.0,
            })
        })
        .collect();
    let mut ev = LoadEvaluator::new(g);
    let mut got_all = Vec::new();
    ev.evaluate(&bearings, &requests, &mut got_all);
    let mut offset = 0;
    for (bi, (b, cases)) in all.iter().enumerate() {
        let states: Vec<BearingState> = cases.iter().map(|c| c.0).collect();
        let want = cpu_loads(1e-6, b, &states);
        let got = &got_all[offset..offset + states.len()];
        offset += states.len();
        for (k, (gr, wr)) in got.iter().zip(&want).enumerate() {
            let eps = cases[k].1;
            assert_loads_finite(gr, &format!("bearing {bi} state {k}"));
            match (gr, wr) {
                (Ok(gl), Ok(wl)) => {
                    let err = rel_err(vector(gl, b), vector(wl, b));
                    let tol = if f64_kernel { 1e-9 } else { 1e-5 };
                    if eps <= 0.95 {
                        assert!(
                            err <= tol,
                            "bearing {bi} state {k} (eps {eps}): {err:.2e} > {tol:e}"
                        );
                        worst95 = worst95.max(err);
                    } else if eps <= 0.99 {
                        worst99 = worst99.max(err);
                    } else if eps <= 0.999 {
                        worst999 = worst999.max(err);
                    } else {
                        worst_contact = worst_contact.max(err);
                    }
                    // Beyond 0.95: not promised; bounded so a wrong answer still fails.
                    let loose = if f64_kernel { 1e-6 } else { 1e-2 };
                    assert!(
                        err <= loose,
                        "bearing {bi} state {k} (eps {eps}): {err:.2e} > {loose:e}"
                    );
                }
                (Err(a), Err(b)) => assert_eq!(a.code(), b.code(), "bearing {bi} state {k}"),
                _ => panic!(
                    "bearing {bi} state {k}: GPU {} but CPU {}",
                    gr.as_ref().map_or_else(|e| e.code(), |_| "ok"),
                    wr.as_ref().map_or_else(|e| e.code(), |_| "ok")
                ),
            }
        }
    }
    eprintln!(
        "GPU ({}) vs CPU: worst relative difference eps <= 0.95 {worst95:.2e}, <= 0.99 {worst99:.2e}, <= 0.999 {worst999:.2e}, contact (1 - 1e-9) {worst_contact:.2e}",
        if f64_kernel { "f64" } else { "f32" }
    );
}

// ---------------------------------------------------------------------------------------
// Rotor level
// ---------------------------------------------------------------------------------------

fn paper_bearing_scene() -> Scene {
    load_scene(PAPER).unwrap().remove(0)
}

fn cpu_evaluator(accuracy: f64) -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(accuracy).unwrap()).unwrap();
    LoadEvaluator::new(b)
}

fn simulate(scenes: &[Scene]) -> Vec<SimResult> {
    simulate_batch(scenes, &mut cpu_evaluator(1e-6), &mut |_, _| {})
}

/// Every number in the result's JSON is finite; `null` only where documented (the
/// friction coefficient where infinite or undefined). NaN would serialise as `null`, so
/// the raw samples are scanned too.
fn assert_all_finite(r: &SimResult) {
    fn walk(v: &serde_json::Value, path: &str, name: &str) {
        match v {
            serde_json::Value::Number(n) => {
                assert!(
                    n.as_f64().is_some_and(f64::is_finite),
                    "{name}: {path} = {n}"
                )
            }
            serde_json::Value::Null => assert!(
                path.contains("friction_coefficient"),
                "{name}: {path} is null (NaN?)"
            ),
            serde_json::Value::Array(a) => {
                for (k, x) in a.iter().enumerate() {
                    walk(x, &format!("{path}[{k}]"), name);
                }
            }
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    walk(x, &format!("{path}.{k}"), name);
                }
            }
            _ => {}
        }
    }
    walk(&serde_json::to_value(r).unwrap(), "", &r.name);
    let s = &r.samples;
    for v in [&s.t, &s.x_g, &s.y_g, &s.spin, &s.kinetic_energy, &s.work] {
        assert!(
            v.iter().all(|x| x.is_finite()),
            "{}: non-finite sample",
            r.name
        );
    }
    for b in &s.bearings {
        for v in [
            &b.xi,
            &b.yi,
            &b.xj,
            &b.yj,
            &b.h_min,
            &b.eccentricity_max,
            &b.wx,
            &b.wy,
            &b.mz,
        ] {
            assert!(
                v.iter().all(|x| x.is_finite()),
                "{}: non-finite bearing sample",
                r.name
            );
        }
        assert!(b
            .friction_coefficient
            .iter()
            .flatten()
            .all(|x| x.is_finite()));
    }
}

/// The documented end statuses of MODEL.md / README "Scenes and run".
fn status_code(s: &SimStatus) -> &'static str {
    match s {
        SimStatus::Finished => "finished",
        SimStatus::FilmBreakdown { .. } => "film_breakdown",
        SimStatus::ThroughWall { .. } => "through_wall",
        SimStatus::StepSizeTooSmall { .. } => "step_size_too_small",
        SimStatus::NonFinite { .. } => "non_finite",
        SimStatus::MaxSteps { .. } => "max_steps",
        SimStatus::LoadFailure { .. } => "load_failure",
        SimStatus::InvalidScene { .. } => "invalid_scene",
    }
}

fn named(mut s: Scene, name: &str, f: impl FnOnce(&mut Scene)) -> Scene {
    s.name = name.into();
    f(&mut s);
    s
}

#[test]
fn unbalance_into_the_wall_ends_in_film_breakdown_and_contact_carries_on() {
    let mut base = paper_bearing_scene();
    base.integrator.t_end = 0.05;
    // 50 mm of unbalance: 500 N at 100 rad/s. Pushing the short-bearing film below 1 µm
    // (ε = 0.9967) at 100 rad/s takes ~1e5 N, so the wall is a 30 µm design limit here
    // (ε = 0.9), as in tests/rotor.rs.
    base.rotor.static_unbalance = [0.05, 0.0];
    base.film.threshold = 3e-5;
    let contact = Some(ContactSpec {
        stiffness: 1e8,
        damping: 100.0,
    });
    let scenes = vec![
        named(base.clone(), "dopri5", |_| {}),
        named(base.clone(), "radau5", |s| {
            s.integrator.method = Method::Radau5
        }),
        named(base.clone(), "rk4", |s| {
            s.integrator.method = Method::Rk4;
            s.integrator.fixed_step = Some(1e-5)
        }),
        // Thrown at the wall at 5 m/s (δ in 60 µs) with a 1 nm threshold: the squeeze
        // film stops it or a step crosses the wall; either way a documented status.
        named(base.clone(), "impact", |s| {
            s.initial.velocity = [5.0, 0.0];
            s.film.threshold = 1e-9
        }),
        named(base.clone(), "contact-dopri5", |s| {
            s.film.contact = contact.clone()
        }),
        named(base.clone(), "contact-radau5", |s| {
            s.film.contact = contact.clone();
            s.integrator.method = Method::Radau5
        }),
    ];
    let rs = simulate(&scenes);
    for r in &rs {
        assert_all_finite(r);
        let h = r
            .samples
            .bearings
            .iter()
            .flat_map(|b| b.h_min.iter())
            .fold(f64::INFINITY, |a, &b| a.min(b));
        eprintln!(
            "{}: {} ({} steps, thinnest sampled film {h:.3e} m, {} film events)",
            r.name,
            r.status,
            r.stats.steps,
            r.film_events.len()
        );
    }
    for r in &rs[..3] {
        match r.status {
            SimStatus::FilmBreakdown {
                time,
                bearing,
                h_min,
            } => {
                assert!(time > 0.0 && time < 0.05, "{}: time {time}", r.name);
                assert!(
                    bearing < 2 && h_min < 3e-5 && h_min > 0.0,
                    "{}: {h_min}",
                    r.name
                );
                let last = *r.samples.t.last().unwrap();
                assert!(
                    last <= time + 1e-4,
                    "{}: samples end at the breakdown",
                    r.name
                );
            }
            ref other => panic!("{}: expected film_breakdown, got {other:?}", r.name),
        }
    }
    // All three methods see the breakdown at about the same time (same trajectory).
    let t = |r: &SimResult| match r.status {
        SimStatus::FilmBreakdown { time, .. } => time,
        _ => f64::NAN,
    };
    for r in &rs[1..3] {
        assert!(
            (t(r) - t(&rs[0])).abs() < 1e-4,
            "{}: {} vs {}",
            r.name,
            t(r),
            t(&rs[0])
        );
    }
    assert!(
        matches!(
            rs[3].status,
            SimStatus::Finished
                | SimStatus::FilmBreakdown { .. }
                | SimStatus::ThroughWall { .. }
                | SimStatus::StepSizeTooSmall { .. }
        ),
        "impact: {:?}",
        rs[3].status
    );
    for r in &rs[4..] {
        assert_eq!(r.status, SimStatus::Finished, "{}", r.name);
        assert!(
            !r.film_events.is_empty(),
            "{}: breakdown events listed",
            r.name
        );
    }
}

/// Short runs of the paper rotor at the edges of the parameter space.
fn extreme_scenes(t_end: f64) -> Vec<Scene> {
    let mut base = paper_bearing_scene();
    base.integrator.t_end = t_end;
    base.integrator.sample_interval = 1e-4;
    let both = |s: &mut Scene, f: &dyn Fn(&mut bearing_sweep::rotor::BearingSpec)| {
        s.bearings.iter_mut().for_each(f)
    };
    vec![
        named(base.clone(), "viscosity-1e-4", |s| {
            both(s, &|b| b.viscosity = Some(1e-4))
        }),
        named(base.clone(), "viscosity-10-radau5", |s| {
            both(s, &|b| b.viscosity = Some(10.0));
            s.integrator.method = Method::Radau5
        }),
        named(base.clone(), "viscosity-10-dopri5-budget", |s| {
            both(s, &|b| b.viscosity = Some(10.0));
            s.integrator.max_steps = 2000
        }),
        named(base.clone(), "clearance-5um", |s| {
            both(s, &|b| b.clearance = 5e-6);
            s.integrator.method = Method::Radau5;
            s.film.threshold = 1e-8
        }),
        named(base.clone(), "clearance-2mm", |s| {
            both(s, &|b| b.clearance = 2e-3)
        }),
        named(base.clone(), "speed-0", |s| s.initial.spin = 0.0),
        named(base.clone(), "speed-reversed", |s| s.initial.spin = -100.0),
        named(base.clone(), "speed-2e4", |s| {
            s.initial.spin = 2e4;
            s.integrator.method = Method::Radau5;
            s.integrator.sample_interval = 1e-5
        }),
        named(base.clone(), "zero-load", |s| {
            s.rotor.static_unbalance = [0.0, 0.0]
        }),
        named(base.clone(), "zero-load-ideal", |s| {
            s.rotor.static_unbalance = [0.0, 0.0];
            s.model = ModelKind::Ideal
        }),
    ]
}

#[test]
fn extreme_parameters_end_with_documented_statuses_and_finite_outputs() {
    let scenes = extreme_scenes(0.02);
    let rs = simulate(&scenes);
    for r in &rs {
        assert_all_finite(r);
        eprintln!(
            "{}: {} ({} steps, {} rejected, {} load evaluations)",
            r.name, r.status, r.stats.steps, r.stats.rejected, r.stats.load_evaluations
        );
    }
    let by = |n: &str| rs.iter().find(|r| r.name == n).unwrap();
    // Stiff film: radau5 finishes; dopri5 on a small step budget says why it stopped.
    assert_eq!(by("viscosity-10-radau5").status, SimStatus::Finished);
    match by("viscosity-10-dopri5-budget").status {
        SimStatus::MaxSteps { steps, time } => assert!(steps == 2000 && time < 0.02),
        ref s => panic!("dopri5 on the stiff film with 2000 steps: {s:?}"),
    }
    for n in [
        "viscosity-1e-4",
        "clearance-2mm",
        "speed-0",
        "speed-reversed",
        "speed-2e4",
        "zero-load",
        "zero-load-ideal",
    ] {
        assert_eq!(by(n).status, SimStatus::Finished, "{n}");
    }
    // 5 µm clearance with a 1 mm unbalance: the journal is thrown at the wall at once.
    let c = by("clearance-5um");
    assert!(
        matches!(
            c.status,
            SimStatus::Finished | SimStatus::FilmBreakdown { .. }
        ),
        "clearance-5um: {:?}",
        c.status
    );
    // Zero load: G stays exactly centred, spin decays only by friction.
    let z = by("zero-load");
    assert!(z
        .samples
        .x_g
        .iter()
        .chain(&z.samples.y_g)
        .all(|&x| x == 0.0));
    // Reversed spin keeps its sign (the mirror symmetry is checked below).
    assert!(by("speed-reversed").samples.spin.iter().all(|&w| w < 0.0));
    // Spin 0, no gravity: no film pressure without motion, no force at all: G stays put
    // at its unbalance offset.
    let s0 = by("speed-0");
    assert!(s0.samples.spin.iter().all(|&w| w == 0.0));
    assert!(s0.samples.x_g.iter().all(|&x| (x - 1e-3).abs() < 1e-18));
    assert!(s0.samples.y_g.iter().all(|&y| y.abs() < 1e-18));
}

#[test]
fn reversed_spin_mirrors_the_forward_run() {
    let mut fwd = paper_bearing_scene();
    fwd.integrator.t_end = 0.05;
    // Mirror about the x-z plane: spin reversed, unbalance along x unchanged.
    let rev = named(fwd.clone(), "reversed", |s| s.initial.spin = -100.0);
    let rs = simulate(&[fwd, rev]);
    let (a, b) = (&rs[0], &rs[1]);
    assert_eq!(a.status, SimStatus::Finished);
    assert_eq!(b.status, SimStatus::Finished);
    let mut worst = 0.0f64;
    for k in 0..a.samples.t.len() {
        let d = (a.samples.x_g[k] - b.samples.x_g[k]).hypot(a.samples.y_g[k] + b.samples.y_g[k]);
        worst = worst.max(d);
    }
    // Orbit ~1e-4 m; the two runs take different steps (rtol 1e-6): ~1e-10 m.
    eprintln!("reversed spin: max |G_fwd - mirror(G_rev)| = {worst:.2e} m");
    assert!(worst < 1e-8, "mirror symmetry: {worst:.2e} m > 1e-8 m");
}

#[test]
fn cpu_and_gpu_give_the_same_statuses_and_figures_on_the_stress_scenes() {
    let gpu_backend = match create_backend(BackendKind::Gpu, Accuracy::new(1e-6).unwrap()) {
        Ok((b, _)) => b,
        Err(e) => {
            assert!(
                !gpu_required(),
                "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
            );
            eprintln!("skipped: no GPU backend ({e})");
            return;
        }
    };
    let mut scenes = extreme_scenes(0.005);
    let mut wall = paper_bearing_scene();
    wall.integrator.t_end = 0.05;
    wall.rotor.static_unbalance = [0.05, 0.0];
    wall.film.threshold = 3e-5;
    scenes.push(named(wall, "unbalance-into-wall", |_| {}));
    let on_cpu = simulate(&scenes);
    let mut ev = LoadEvaluator::new(gpu_backend);
    let on_gpu = simulate_batch(&scenes, &mut ev, &mut |_, _| {});
    for (c, g) in on_cpu.iter().zip(&on_gpu) {
        assert_all_finite(g);
        assert_eq!(status_code(&c.status), status_code(&g.status), "{}", c.name);
        // Same figures: G's path (relative to the clearance), the end time.
        let n = c.samples.t.len().min(g.samples.t.len());
        let d = scenes.iter().find(|s| s.name == c.name).unwrap().bearings[0].clearance;
        let mut worst = 0.0f64;
        for k in 0..n {
            worst = worst.max(
                (c.samples.x_g[k] - g.samples.x_g[k]).hypot(c.samples.y_g[k] - g.samples.y_g[k]),
            );
        }
        eprintln!(
            "{}: {} on both; max |G_cpu - G_gpu| = {:.2e} m",
            c.name,
            status_code(&c.status),
            worst
        );
        assert!(
            worst < 1e-4 * d,
            "{}: {worst:.2e} m > 1e-4 × clearance",
            c.name
        );
        let end = |r: &SimResult| *r.samples.t.last().unwrap();
        assert!(
            (end(c) - end(g)).abs() < 2e-4,
            "{}: ends {} vs {}",
            c.name,
            end(c),
            end(g)
        );
    }
}

/// Long run of the paper rotor at a held 100 rad/s over `revolutions`: the bearing model
/// (energy balance: ΔKE = work of film forces, friction and the drive torque) and ideal
/// joints (G on its circle: the quaternion's norm; G's angle against the exact rotation
/// ω t: the attitude drift). Returns (worst |ΔKE − W| J, worst ||G| − e| m, worst attitude
/// drift rad).
fn long_run(revolutions: f64) -> (f64, f64, f64) {
    let omega = 100.0;
    let t_end = revolutions * std::f64::consts::TAU / omega;
    let mut b = paper_bearing_scene();
    b.spin = SpinMode::Held;
    b.integrator.t_end = t_end;
    b.integrator.sample_interval = 1e-3;
    b.integrator.rtol = 1e-8;
    b.integrator.atol = 1e-8;
    b.integrator.max_steps = 100_000_000;
    let ideal = named(b.clone(), "ideal", |s| s.model = ModelKind::Ideal);
    let rs = simulate(&[b, ideal]);
    for r in &rs {
        assert_eq!(r.status, SimStatus::Finished, "{}", r.name);
        assert_all_finite(r);
    }
    let s = &rs[0].samples;
    let mut energy = 0.0f64;
    for k in 0..s.t.len() {
        energy = energy.max(((s.kinetic_energy[k] - s.kinetic_energy[0]) - s.work[k]).abs());
    }
    let (e, s) = (1e-3, &rs[1].samples);
    let (mut radius, mut attitude) = (0.0f64, 0.0f64);
    for k in 0..s.t.len() {
        radius = radius.max((s.x_g[k].hypot(s.y_g[k]) - e).abs());
        let phase = s.y_g[k].atan2(s.x_g[k]) - omega * s.t[k];
        let wrapped = phase - std::f64::consts::TAU * (phase / std::f64::consts::TAU).round();
        attitude = attitude.max(wrapped.abs());
    }
    eprintln!(
        "{revolutions} revolutions ({t_end:.1} s): bearing model {} steps, worst |dKE - W| = {energy:.2e} J \
         (KE {:.0} J, work {:.2} J); ideal joints: worst ||G| - e| = {radius:.2e} m, worst attitude drift {attitude:.2e} rad",
        rs[0].stats.steps,
        rs[0].samples.kinetic_energy[0],
        rs[0].samples.work.last().unwrap()
    );
    (energy, radius, attitude)
}

#[test]
fn long_run_500_revolutions_keeps_energy_norm_and_attitude() {
    let (energy, radius, attitude) = long_run(500.0);
    // Tolerances set ~10x above the measured figures (BENCHMARKS.md, "Stress and stability").
    assert!(energy < 1e-6, "energy balance {energy:.2e} J > 1e-6 J");
    assert!(
        radius < 1e-15,
        "||G| - e| = {radius:.2e} m > 1e-15 m (quaternion norm)"
    );
    assert!(
        attitude < 1e-6,
        "attitude drift {attitude:.2e} rad > 1e-6 rad"
    );
}

/// 1e4 revolutions (628 s simulated): about a minute in release; run by hand:
/// `cargo test --release --test stress -- --ignored --nocapture long_run_1e4`.
#[test]
#[ignore]
fn long_run_1e4_revolutions_keeps_energy_norm_and_attitude() {
    let (energy, radius, attitude) = long_run(1e4);
    assert!(energy < 2e-5, "energy balance {energy:.2e} J");
    assert!(radius < 1e-15, "||G| - e| = {radius:.2e} m");
    assert!(attitude < 2e-5, "attitude drift {attitude:.2e} rad");
}

// ---------------------------------------------------------------------------------------
// The stress sweep through the command line
// ---------------------------------------------------------------------------------------

/// Runs `bearing-sweep run sweeps/stress.json` on `backend`; the result document.
fn run_stress_sweep(backend: &str) -> serde_json::Value {
    let out = std::env::temp_dir().join(format!(
        "bearing-sweep-stress-{}-{backend}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&out);
    let spec = concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/stress.json");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
        .args(["run", spec, "--quiet", "--backend", backend, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "run sweeps/stress.json --backend {backend}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let doc = std::fs::read_to_string(out.join("stress/result.json")).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    serde_json::from_str(&doc).unwrap()
}

/// Every number in `v` finite (serde_json cannot hold NaN; a NaN written by hand would
/// fail to parse): walks the document and returns the count of numbers seen.
fn count_finite_numbers(v: &serde_json::Value, path: &str) -> usize {
    match v {
        serde_json::Value::Number(n) => {
            assert!(n.as_f64().is_some_and(f64::is_finite), "{path} = {n}");
            1
        }
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(k, x)| count_finite_numbers(x, &format!("{path}[{k}]")))
            .sum(),
        serde_json::Value::Object(o) => o
            .iter()
            .map(|(k, x)| count_finite_numbers(x, &format!("{path}.{k}")))
            .sum(),
        _ => 0,
    }
}

/// The status each case of sweeps/stress.json ends with (README "Stress tests and
/// stability").
const STRESS_STATUSES: [(&str, &str); 18] = [
    ("paper", "ok"),
    ("unbalance-into-wall", "film_breakdown"),
    ("unbalance-into-wall-contact", "ok"),
    ("unbalance-into-wall-contact-radau5", "ok"),
    ("viscosity-1e-4", "ok"),
    ("viscosity-10-radau5", "ok"),
    ("viscosity-10-dopri5-budget", "max_steps"),
    ("clearance-5um-radau5", "ok"),
    ("clearance-2mm", "ok"),
    ("speed-0", "ok"),
    ("speed-reversed", "ok"),
    ("speed-2e4-radau5", "ok"),
    ("zero-load", "ok"),
    ("zero-load-ideal", "ok"),
    ("offset-eps-0.99", "ok"),
    ("tilt-eps-0.999-one-end", "ok"),
    ("impact-5m/s", "ok"),
    ("tilt-contact-1e-9-radau5", "ok"),
];

#[test]
fn the_stress_sweep_ends_every_variant_with_its_documented_status_on_cpu_and_gpu() {
    let cpu = run_stress_sweep("cpu");
    let n = count_finite_numbers(&cpu, "$");
    let variants = cpu["variants"].as_array().unwrap();
    assert_eq!(variants.len(), STRESS_STATUSES.len());
    for (v, (name, status)) in variants.iter().zip(STRESS_STATUSES) {
        assert_eq!(v["params"]["name"], *name);
        assert_eq!(v["status"], *status, "{name}: {}", v["message"]);
    }
    eprintln!("cpu: {} variants, {n} numbers, all finite", variants.len());
    if let Err(e) = create_backend(BackendKind::Gpu, Accuracy::default()) {
        assert!(
            !gpu_required(),
            "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
        );
        eprintln!("skipped the GPU sweep: no GPU backend ({e})");
        return;
    }
    let gpu = run_stress_sweep("gpu");
    count_finite_numbers(&gpu, "$");
    for (c, g) in variants.iter().zip(gpu["variants"].as_array().unwrap()) {
        let name = &c["params"]["name"];
        assert_eq!(c["status"], g["status"], "{name}");
        // Same figures: the thinnest film and when (f64 kernels agree to ~1e-13 on the
        // loads; the trajectories then to far below the 1e-6 relative asked here).
        let (hc, hg) = (
            c["reductions"]["h_min"]["value_m"].as_f64().unwrap(),
            g["reductions"]["h_min"]["value_m"].as_f64().unwrap(),
        );
        let rel = (hc - hg).abs() / hc.abs().max(1e-300);
        assert!(
            rel < 1e-6,
            "{name}: h_min {hc} (cpu) vs {hg} (gpu): {rel:.2e} > 1e-6"
        );
        let (pc, pg) = (
            c["reductions"]["power_loss_w"].as_f64().unwrap_or(0.0),
            g["reductions"]["power_loss_w"].as_f64().unwrap_or(0.0),
        );
        assert!(
            (pc - pg).abs() <= 1e-6 * pc.abs() + 1e-12,
            "{name}: power loss {pc} (cpu) vs {pg} (gpu)"
        );
    }
}

#[test]
fn a_rotor_tilted_to_contact_at_one_end_runs_on_every_method() {
    // The shaft tilted about x until bearings[0]'s far end face is 1e-9 δ off the wall
    // (a 1e-10 m film at t = 0, under a 1e-15 m threshold). radau5's finite-difference
    // Jacobian used to probe a quaternion component by 1.5e-8 rad, which pushed that end
    // through the wall and ended the run at t = 0 with `through_wall` (eccentricity ratio
    // 1.00002 of the probe, not of the trajectory); such a column is now a backward
    // difference. The squeeze film then pushes the journal off the wall.
    let mut base = paper_bearing_scene();
    base.integrator.t_end = 0.02;
    // End face of bearings[0] farthest from G: axial position 0.2 + B/2 = 0.21 m.
    base.initial.tilt = [(1.0 - 1e-9) * 3e-4 / 0.21, 0.0];
    base.film.threshold = 1e-15;
    let scenes = vec![
        named(base.clone(), "dopri5", |_| {}),
        named(base.clone(), "radau5", |s| {
            s.integrator.method = Method::Radau5
        }),
    ];
    let rs = simulate(&scenes);
    for r in &rs {
        assert_all_finite(r);
        let h0 = r.samples.bearings[0].h_min[0];
        let h_end = *r.samples.bearings[0].h_min.last().unwrap();
        eprintln!(
            "{} ({:?}): {} ({} steps, {} jacobians), film {h0:.2e} m at t = 0, {h_end:.2e} m at the end",
            r.name, r.method, r.status, r.stats.steps, r.stats.jacobians
        );
        assert_eq!(r.status, SimStatus::Finished, "{}", r.name);
        assert!(h0 < 2e-10, "{}: starts at contact: {h0}", r.name);
        assert!(h_end > 1e-6, "{}: pushed off the wall: {h_end}", r.name);
    }
}
