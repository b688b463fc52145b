//! Film friction and flow (issue 24 item 1; docs/finite-film.md "Friction and flow"):
//! Petroff, Butenschoen's B/d = 1/2 table (friction variable and side flow), the finite
//! film's mass balance, grid convergence, and the short-film closed forms as B/D -> 0.

use std::f64::consts::PI;

use bearing_sweep::bearing::finite::{
    finite_solution, flow_integrals, solution_grid, FiniteGrid, FiniteJob, FiniteSettings,
    FiniteSolver, FlowIntegrals,
};
use bearing_sweep::bearing::{
    film_loads, pack_state, Accuracy, BearingParams, BearingState, FilmModel, FilmRule, Loads,
};

/// A bearing of radius 0.5 m with `B/D = b_over_d`, δ = 1 mm, μ = 1 Pa·s, finite film.
fn bearing(b_over_d: f64, finite: FiniteSettings) -> BearingParams {
    BearingParams {
        radius: 0.5,
        length: b_over_d,
        clearance: 1e-3,
        viscosity: 1.0,
        model: FilmModel::Finite,
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

fn fixed(n_theta: u32, n_z: u32) -> FiniteSettings {
    FiniteSettings {
        n_theta: Some(n_theta),
        n_z: Some(n_z),
        tolerance: 1e-11,
        ..FiniteSettings::default()
    }
}

fn finite(p: &BearingParams, s: &BearingState) -> Loads {
    finite_solution(p, s, &p.finite, false).unwrap().loads
}

fn short(p: &BearingParams, s: &BearingState) -> Loads {
    let rule = FilmRule::new(Accuracy::new(1e-10).unwrap().settings());
    film_loads(p, s, &rule).unwrap()
}

/// Relative comparison that prints index, actual, expected and tolerance on failure.
fn check(what: &str, index: usize, actual: f64, expected: f64, tol: f64) {
    let err = (actual - expected).abs() / expected.abs();
    assert!(
        err <= tol,
        "{what} at index {index}: actual {actual:.6e}, expected {expected:.6e}, relative \
         error {err:.3e} > tolerance {tol:e}"
    );
}

/// Butenschoen (1976), B/d = 1/2 (../shared/reference-tables/butenschoen-1976.md):
/// ε, So (German convention), β (degrees), Q = side flow / ((d/2)³ ψ ω), both ends.
const BUTENSCHOEN: [(f64, f64, f64, f64); 9] = [
    (0.1, 0.0368, 81.767, 0.0939),
    (0.2, 0.0783, 75.142, 0.1878),
    (0.3, 0.1304, 68.493, 0.2816),
    (0.4, 0.2026, 61.778, 0.3755),
    (0.5, 0.3124, 54.993, 0.4694),
    (0.6, 0.4982, 48.049, 0.5634),
    (0.7, 0.8595, 40.803, 0.6578),
    (0.8, 1.7339, 32.938, 0.7529),
    (0.9, 5.0881, 23.566, 0.8453),
];

/// Solves a state and returns its loads, the flow integrals and the solver's integrals.
fn solve_with_flow(p: &BearingParams, s: &BearingState) -> (Loads, FlowIntegrals, [f64; 4], f64) {
    let packed = pack_state(p, s).unwrap();
    let job = FiniteJob::new(p, &packed);
    // Flows wanted: accuracy mode iterates its last grid's field to the tolerance, as
    // the evaluator does where film outputs are requested (issue 20).
    let g = FiniteGrid {
        polish: true,
        ..FiniteGrid::from(&p.finite)
    };
    let mut field = Vec::new();
    let (ints, report) = FiniteSolver::new().solve(&job, &g, &mut field);
    let (nt, nz, theta0) = solution_grid(&job, &g, &report);
    let flow = flow_integrals(
        &job,
        &g,
        nt,
        nz,
        theta0,
        s.omega / packed.rate_scale,
        &field,
    )
    .unwrap();
    (finite(p, s), flow, ints, packed.rate_scale)
}

#[test]
fn petroff_limit_at_small_eccentricity_short_and_finite() {
    for (k, b_over_d) in [0.25, 0.5, 1.0].into_iter().enumerate() {
        let p = bearing(b_over_d, FiniteSettings::default());
        let s = aligned(&p, 1e-4);
        let petroff = 2.0 * PI * p.viscosity * p.radius.powi(3) * p.length * s.omega / p.clearance;
        for (name, l) in [("short", short(&p, &s)), ("finite", finite(&p, &s))] {
            check(
                &format!("{name} Petroff torque, B/D = {b_over_d}"),
                k,
                -l.film.friction_torque_nm,
                petroff,
                1e-7,
            );
            check(
                &format!("{name} Petroff power, B/D = {b_over_d}"),
                k,
                l.film.power_loss_w,
                petroff * s.omega,
                1e-7,
            );
        }
    }
}

#[test]
fn butenschoen_friction_variable_and_side_flow_at_default_accuracy() {
    let p = bearing(0.5, FiniteSettings::default());
    for (k, &(ecc, so, beta_deg, q_want)) in BUTENSCHOEN.iter().enumerate() {
        let s = aligned(&p, ecc);
        let l = finite(&p, &s);
        let f_want = PI / ((1.0 - ecc * ecc).sqrt() * so) + 0.5 * ecc * beta_deg.to_radians().sin();
        let f_got = l.film.friction_variable.unwrap();
        let q = l.film.side_flow_m3_per_s / (p.radius.powi(2) * p.clearance * s.omega);
        eprintln!(
            "ε {ecc}: (r/c)f {f_got:.5} vs {f_want:.5} ({:+.3} %), Q {q:.5} vs {q_want} ({:+.3} %), inlet/side {:.8}",
            100.0 * (f_got / f_want - 1.0),
            100.0 * (q / q_want - 1.0),
            l.film.inlet_flow_m3_per_s / l.film.side_flow_m3_per_s
        );
        check("Butenschoen (r/c) f", k, f_got, f_want, 0.02);
        check("Butenschoen Q", k, q, q_want, 0.05);
    }
}

#[test]
fn finite_mass_balance_closes_aligned_tilted_and_squeezed() {
    // An explicit grid iterated to 1e-11: the discrete field's own conservation. (Accuracy
    // mode, its last grid polished where flows are wanted:
    // `accuracy_mode_balance_closes_when_flows_are_wanted` below.)
    let p = bearing(0.5, fixed(128, 32));
    let states = balance_states(&p);
    for (k, s) in states.iter().enumerate() {
        let (l, f, ints, _) = solve_with_flow(&p, s);
        eprintln!(
            "state {k}: side {:?} inlet {:.6e} storage {:.6e} residual {:.3e} scale {:.3e}",
            f.side, f.inlet, f.storage, f.residual, f.scale
        );
        // The post-processing sees the solver's grid: the same load integrals.
        for n in 0..4 {
            let tol = 1e-12 * ints.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            assert!(
                (f.loads[n] - ints[n]).abs() <= tol,
                "state {k} load integral {n}: actual {}, expected {}, tolerance {tol:e}",
                f.loads[n],
                ints[n]
            );
        }
        // Inflow = side flow + storage, to the solver's tolerance (relative 1e-8 of the
        // field; 1e-6 of the flow scale leaves room for the sum over the grid).
        let balance = f.inlet - f.side[0] - f.side[1] - f.storage;
        assert!(
            balance.abs() <= 1e-6 * f.scale,
            "state {k} mass balance: inlet {:e} − side {:e} − storage {:e} = {balance:e}, \
             tolerance {:e}",
            f.inlet,
            f.side[0] + f.side[1],
            f.storage,
            1e-6 * f.scale
        );
        // Nothing leaks in at an end.
        assert!(
            f.side[0] >= 0.0 && f.side[1] >= 0.0,
            "state {k}: {:?}",
            f.side
        );
        assert!(l.film.side_flow_m3_per_s >= 0.0);
    }
}

#[test]
fn side_flow_and_friction_converge_under_grid_refinement() {
    // B/D = 1/2, ε = 0.6, max_film inlet (on a node of every grid: the maximum film is at
    // θ = π) on explicit grids doubled in both directions, against the 512 × 128 grid:
    // the friction torque's error falls ~4x per doubling (second order); the side flow's
    // is second order with an irregular part (which end cells count as the pressure
    // zone's changes with the grid), so it must fall at least 2x over two doublings and
    // stay below 1e-3 relative.
    let solve = |nt: u32, nz: u32| {
        let p = bearing(0.5, fixed(nt, nz));
        let l = finite(&p, &aligned(&p, 0.6));
        (l.film.side_flow_m3_per_s, l.film.friction_torque_nm)
    };
    let (q_ref, t_ref) = solve(512, 128);
    let grids = [(32, 8), (64, 16), (128, 32)];
    let errs: Vec<(f64, f64)> = grids
        .iter()
        .map(|&(nt, nz)| {
            let (q, t) = solve(nt, nz);
            ((q / q_ref - 1.0).abs(), (t / t_ref - 1.0).abs())
        })
        .collect();
    eprintln!("errors (side flow, torque): {errs:?}");
    for k in 1..errs.len() {
        let ratio = errs[k - 1].1 / errs[k].1;
        assert!(
            ratio >= 3.0,
            "torque error ratio at index {k}: actual {ratio}, expected >= 3 (second order 4); \
             errors {errs:?}"
        );
    }
    for (k, e) in errs.iter().enumerate() {
        assert!(
            e.0 <= 1e-3,
            "side flow error at index {k}: actual {}, expected <= 1e-3",
            e.0
        );
    }
    assert!(
        errs[0].0 >= 2.0 * errs[2].0,
        "side flow error: actual {} on 128 x 32, expected <= half of {} on 32 x 8",
        errs[2].0,
        errs[0].0
    );
}

#[test]
fn short_film_closed_forms_are_the_finite_film_limit_as_b_over_d_shrinks() {
    // Aligned journal: the finite film tends to the short one like (B/D)² (MODEL.md
    // section 2); side flow, friction torque and friction variable follow.
    for (k, ecc) in [0.3, 0.7].into_iter().enumerate() {
        let mut last = f64::INFINITY;
        for b_over_d in [0.25, 0.125, 0.0625] {
            let p = bearing(
                b_over_d,
                FiniteSettings {
                    accuracy: 1e-4,
                    ..FiniteSettings::default()
                },
            );
            let s = aligned(&p, ecc);
            let (sh, fi) = (short(&p, &s), finite(&p, &s));
            let bound = b_over_d * b_over_d;
            let dq = fi.film.side_flow_m3_per_s / sh.film.side_flow_m3_per_s - 1.0;
            let dt = fi.film.friction_torque_nm / sh.film.friction_torque_nm - 1.0;
            let df = fi.film.friction_variable.unwrap() / sh.film.friction_variable.unwrap() - 1.0;
            eprintln!("ε {ecc} B/D {b_over_d}: dQ {dq:.3e} dT {dt:.3e} d(r/c)f {df:.3e}");
            for (name, d, c) in [
                ("side flow", dq, 0.5),
                ("torque", dt, 0.1),
                ("(r/c) f", df, 3.5),
            ] {
                assert!(
                    d.abs() <= c * bound,
                    "{name}, short vs finite at index {k} (ε = {ecc}, B/D = {b_over_d}): \
                     actual relative difference {d:e}, expected <= {c} (B/D)² = {:e}",
                    c * bound
                );
            }
            assert!(
                df.abs() < last,
                "(r/c) f difference does not fall at index {k}"
            );
            last = df.abs();
            // Aligned: the short film's inlet flow is its side flow.
            check(
                "short inlet/side",
                k,
                sh.film.inlet_flow_m3_per_s,
                sh.film.side_flow_m3_per_s,
                1e-12,
            );
        }
    }
}

#[test]
fn finite_pressure_torque_matches_the_load_moment_identity() {
    // (r0/2) ∬ p ∂h/∂θ = −½ Σ (e × F)_z: the grid's face sum of h ∂p/∂θ against the
    // identity evaluated on the finite film's own loads (second-order consistent).
    let p = bearing(0.5, FiniteSettings::default());
    let c = p.clearance;
    let states = [
        aligned(&p, 0.5),
        BearingState {
            xi: 0.3 * c,
            yi: -0.2 * c,
            xj: 0.7 * c,
            yj: 0.1 * c,
            omega: 1.0,
            ..BearingState::default()
        },
    ];
    for (k, s) in states.iter().enumerate() {
        let l = finite(&p, s);
        let couette = bearing_sweep::bearing::film_flow::couette_torque(&p, s);
        let identity =
            bearing_sweep::bearing::film_flow::pressure_torque(&p, s, [l.wx, l.wy], [l.mx, l.my]);
        check(
            "pressure torque",
            k,
            l.film.friction_torque_nm - couette,
            identity,
            2e-3,
        );
        // The short film takes the identity itself: the same total on the same loads.
        let sh =
            bearing_sweep::bearing::film_flow::short_film_flow(&p, s, [l.wx, l.wy], [l.mx, l.my]);
        check(
            "film torque",
            k,
            l.film.friction_torque_nm,
            sh.friction_torque_nm,
            2e-4,
        );
    }
}

/// `eval` (and the service's eval, the same code) reports the film's friction and flow
/// beside the paper's law, for the short and the finite film; a faulty state has `null`s.
/// The finite film's numbers through the evaluator (field from the backend) are those of
/// the direct solve.
#[test]
fn eval_reports_film_friction_and_flow() {
    use bearing_sweep::app::{eval_json, EvalOptions};
    for model in ["short", "finite"] {
        let input = serde_json::json!({
            "bearing": {"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.0242,
                        "model": model, "finite": {"accuracy": 2e-3}},
            "states": [
                {"xi": 1.8e-4, "yi": 0.0, "xj": 1.8e-4, "yj": 0.0, "vxi": 0.0, "vyi": 0.0,
                 "vxj": 0.0, "vyj": 0.0, "omega": 100.0},
                {"xi": 4e-4, "yi": 0.0, "xj": 0.0, "yj": 0.0, "vxi": 0.0, "vyi": 0.0,
                 "vxj": 0.0, "vyj": 0.0, "omega": 100.0}
            ]
        });
        let (out, _) = eval_json(&input.to_string(), EvalOptions::default()).unwrap();
        let p: BearingParams = serde_json::from_value(input["bearing"].clone()).unwrap();
        let s: BearingState = serde_json::from_value(input["states"][0].clone()).unwrap();
        let want = if model == "short" {
            short(&p, &s)
        } else {
            finite(&p, &s)
        };
        let l = &out["loads"][0];
        assert_eq!(l["friction_model"], "paper", "{model}");
        let film = &l["film"];
        for (n, (key, expected)) in [
            ("friction_torque_nm", want.film.friction_torque_nm),
            ("power_loss_w", want.film.power_loss_w),
            ("friction_variable", want.film.friction_variable.unwrap()),
            ("side_flow_i_m3_per_s", want.film.side_flow_i_m3_per_s),
            ("side_flow_j_m3_per_s", want.film.side_flow_j_m3_per_s),
            ("side_flow_m3_per_s", want.film.side_flow_m3_per_s),
            ("inlet_flow_m3_per_s", want.film.inlet_flow_m3_per_s),
        ]
        .into_iter()
        .enumerate()
        {
            let actual = film[key].as_f64().unwrap_or(f64::NAN);
            check(
                &format!("{model} eval film.{key}"),
                n,
                actual,
                expected,
                1e-9,
            );
        }
        // Steady, aligned: inlet = side flow. Short film: exactly (closed forms). Finite
        // film in accuracy mode (here 2e-3): eval wants the film outputs, so the ladder's
        // last grid is iterated to the field tolerance (1e-8; issue 20, "flows when
        // asked"), and the balance closes as on an explicit grid. (Before that polish
        // the flows carried the ladder's accuracy/50 stop: 1.9e-4 measured, held to
        // accuracy/4.)
        let tol = 1e-6;
        check(
            &format!("{model} inlet/side"),
            0,
            want.film.inlet_flow_m3_per_s,
            want.film.side_flow_m3_per_s,
            tol,
        );
        let bad = &out["loads"][1];
        assert_eq!(bad["status"], "through_wall", "{model}: {bad}");
        assert!(bad["film"].is_null() && bad["friction_model"].is_null());
    }
}

/// Accuracy mode (the default 5e-4) where flows are wanted: the film's mass balance closes
/// to 1e-6 of the flow scale on the states of the conservation test, as on an explicit
/// grid. Accuracy mode stops iterating each grid when the *loads'* iteration error is 2 %
/// of the accuracy (issue 20, cost); the flows are boundary gradients of the field and
/// converge more slowly (3.9e-4 of the flow scale measured on the tilted state at that
/// stop), so where film outputs are requested the last grid's field is iterated on to
/// `finite.tolerance` (`FiniteGrid::polish`; docs/finite-film.md "Friction and flow").
#[test]
fn accuracy_mode_balance_closes_when_flows_are_wanted() {
    let p = bearing(0.5, FiniteSettings::default());
    let states = balance_states(&p);
    for (k, s) in states.iter().enumerate() {
        let (_, f, _, _) = solve_with_flow(&p, s);
        let balance = f.inlet - f.side[0] - f.side[1] - f.storage;
        let tol = 1e-6 * f.scale;
        assert!(
            balance.abs() <= tol,
            "state {k}: inlet {:e} − side {:e} − storage {:e} = {balance:e}, tolerance {tol:e}",
            f.inlet,
            f.side[0] + f.side[1],
            f.storage
        );
    }
}

/// The states of the mass-balance tests: aligned, tilted in and out of the eccentricity's
/// plane, squeezed and whirling, pure squeeze tilted, spin backwards.
fn balance_states(p: &BearingParams) -> [BearingState; 5] {
    let c = p.clearance;
    [
        aligned(p, 0.6),
        // Tilted in and out of the eccentricity's plane.
        BearingState {
            xi: 0.3 * c,
            yi: -0.2 * c,
            xj: 0.7 * c,
            yj: 0.1 * c,
            omega: 1.0,
            ..BearingState::default()
        },
        // Squeezed toward the wall and whirling.
        BearingState {
            xi: 0.5 * c,
            xj: 0.5 * c,
            vxi: 0.2 * c,
            vxj: 0.2 * c,
            vyi: 0.1 * c,
            vyj: 0.1 * c,
            omega: 1.0,
            ..BearingState::default()
        },
        // Pure squeeze, tilted.
        BearingState {
            xi: 0.2 * c,
            xj: 0.4 * c,
            vxi: -0.3 * c,
            vxj: 0.2 * c,
            ..BearingState::default()
        },
        // Spin backwards.
        BearingState {
            xi: -0.4 * c,
            yi: 0.4 * c,
            xj: -0.4 * c,
            yj: 0.4 * c,
            omega: -3.0,
            ..BearingState::default()
        },
    ]
}

/// The polish costs nothing where film outputs are not requested (rotor stages): through
/// the evaluator with `film_outputs` off, accuracy-mode loads are bit for bit the
/// unpolished solve's, and the work is that of the ladder alone; with film outputs on,
/// the same states take more sweeps (the last grid iterated to the field tolerance) and
/// their loads move by about the ladder's per-grid stop, 10 % of the accuracy since issue
/// 20 session 35 (15 % measured on the tilted state; 2 % before, when 3 % was measured and
/// the bound was 10 %: the bound stays 5 × the stop, 50 %).
#[test]
fn polish_only_where_film_outputs_are_requested() {
    use bearing_sweep::backend::{
        create_backend, BackendKind, BearingPlan, LoadEvaluator, LoadRequest,
    };
    let p = bearing(0.5, FiniteSettings::default());
    let states = balance_states(&p);
    let requests: Vec<LoadRequest> = states
        .iter()
        .map(|s| LoadRequest {
            bearing: 0,
            state: *s,
        })
        .collect();
    let run = |film: bool| {
        let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
        let mut ev = LoadEvaluator::new(b);
        ev.set_warm_start(false);
        let plan = BearingPlan::new(&[p], film);
        let mut out = Vec::new();
        ev.evaluate_planned(&[p], &plan, &requests, &mut out);
        let loads: Vec<Loads> = out.into_iter().map(|r| r.unwrap()).collect();
        (loads, ev.stats().finite_sweeps)
    };
    let (off, sweeps_off) = run(false);
    let (on, sweeps_on) = run(true);
    for (k, s) in states.iter().enumerate() {
        let packed = pack_state(&p, s).unwrap();
        let job = FiniteJob::of_state(&p, &packed, s.omega);
        let (ints, _) =
            FiniteSolver::new().solve(&job, &FiniteGrid::from(&p.finite), &mut Vec::new());
        let want = bearing_sweep::bearing::finish_loads(&p, s, &ints, packed.rate_scale);
        assert_eq!(
            off[k].load_vector(p.length),
            want.load_vector(p.length),
            "state {k}: film outputs off must be the unpolished solve"
        );
        let (a, b) = (on[k].load_vector(p.length), off[k].load_vector(p.length));
        let norm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt();
        eprintln!(
            "state {k}: polish moved the loads by {:.2e} relative",
            diff / norm
        );
        assert!(
            diff <= 0.5 * p.finite.accuracy * norm,
            "state {k}: polish moved the loads by {:.2e} relative, bound {:.2e}",
            diff / norm,
            0.5 * p.finite.accuracy
        );
    }
    eprintln!("sweeps: film outputs off {sweeps_off}, on {sweeps_on}");
    assert!(
        sweeps_on > sweeps_off,
        "polish did no work: {sweeps_on} vs {sweeps_off}"
    );
}
