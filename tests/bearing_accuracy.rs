//! Accuracy of the default load rule against the adaptive reference: each accuracy level
//! keeps its promise on random states of every family; convergence under refinement;
//! the closed-form slice against adaptive quadrature in θ; the brute-force baseline
//! converging to the same loads.

mod common;

use bearing_sweep::bearing::reference::{reference_loads, reference_slice};
use bearing_sweep::bearing::{
    baseline_loads, film_loads, pack_state, slice_integrals, Accuracy, BearingParams, BearingState,
    FilmRule, RuleSettings, ACCURACY_LEVELS,
};
use common::*;

/// Reference tolerance: the adaptive Gauss-Kronrod reference to near rounding.
const REF_RTOL: f64 = 1e-14;

fn reference(p: &BearingParams, s: &BearingState) -> [f64; 4] {
    load_vector(
        reference_loads(p, s, REF_RTOL).expect("valid state"),
        p.length,
    )
}

fn rule_vector(p: &BearingParams, s: &BearingState, rule: &FilmRule) -> [f64; 4] {
    film_loads(p, s, rule)
        .expect("valid state")
        .load_vector(p.length)
}

/// States per (family, eccentricity band): 6 families × 2 bands × this = reference calls.
const STATES_PER_CASE: usize = 400;

/// Every level keeps its promise on random states of every family: `rtol` for larger end
/// eccentricity ratio <= 0.95, `promise_near_wall()` up to 0.99.
#[test]
fn every_level_keeps_its_promise_on_random_states() {
    let rules: Vec<(Accuracy, FilmRule)> = ACCURACY_LEVELS
        .iter()
        .map(|&r| {
            let a = Accuracy::new(r).unwrap();
            (a, FilmRule::new(a.settings()))
        })
        .collect();
    let geoms = geometries();
    let mut rng = Rng::new(0xACC0_2026);
    let mut index = 0;
    let mut worst = vec![[0.0_f64; 2]; rules.len()];
    for family in FAMILIES {
        for (band, emax) in [0.95, 0.99].into_iter().enumerate() {
            for k in 0..STATES_PER_CASE {
                let (gname, p) = &geoms[k % geoms.len()];
                let s = random_state(&mut rng, p, family, emax);
                let expected = reference(p, &s);
                for (lv, (acc, rule)) in rules.iter().enumerate() {
                    let tol = if band == 0 {
                        acc.rtol()
                    } else {
                        acc.promise_near_wall()
                    };
                    let actual = rule_vector(p, &s, rule);
                    // The panel cap is a safety net only: reaching it would leave one
                    // panel spanning the rest of the bearing.
                    let packed = pack_state(p, &s).unwrap();
                    let panels = rule.integrate(&packed.state).1 / rule.settings().nodes;
                    assert!(
                        panels < rule.settings().max_panels,
                        "[{index}] {family:?} level {:e}: {panels} panels reach the cap; state {s:?}",
                        acc.rtol()
                    );
                    let err = rel_error(&actual, &expected);
                    worst[lv][band] = worst[lv][band].max(err);
                    assert_close(
                        &format!(
                            "{family:?} emax {emax} level {:e} geometry {gname} state {s:?}",
                            acc.rtol()
                        ),
                        index,
                        &actual,
                        &expected,
                        tol,
                        0.0,
                    );
                }
                index += 1;
            }
        }
    }
    for (lv, (acc, _)) in rules.iter().enumerate() {
        println!(
            "level {:e}: worst relative error {:.2e} (ε <= 0.95), {:.2e} (ε <= 0.99)",
            acc.rtol(),
            worst[lv][0],
            worst[lv][1]
        );
    }
}

/// Regression: a near-kink (rate zero 1.2e-8 off the real axis) whose arc-end quartic roots
/// Durand-Kerner returned almost real (Im 1.6e-14): the panels graded toward them ran into
/// the panel cap and the 1e-12 level returned an error of 5e-5.
#[test]
fn near_kink_with_noisy_quartic_roots() {
    let p = geometries()[2].1;
    let s = BearingState {
        xi: 8.418555697182219e-5,
        yi: -0.00016877259168739393,
        xj: 0.00010028031756487535,
        yj: 0.00014898783925553676,
        vxi: -0.05846435152039471,
        vyi: -0.03445733019258653,
        vxj: -0.03507104610719925,
        vyj: 0.010577836912072812,
        omega: -753.7887309763253,
    };
    let expected = reference(&p, &s);
    for (k, &level) in ACCURACY_LEVELS.iter().enumerate() {
        let rule = FilmRule::new(Accuracy::new(level).unwrap().settings());
        assert_close(
            &format!("noisy near-kink, level {level:e}"),
            k,
            &rule_vector(&p, &s, &rule),
            &expected,
            level,
            0.0,
        );
    }
}

/// A journal pivoting about an end face in pure rotation (`e_i = 0`, so the rate vector
/// `ω ε` vanishes exactly at `s = 0`, and up to rounding just behind it): a kink on the
/// bearing's boundary. The rule must neither grade toward the quartic's double root there
/// (tens of panels toward a point 1e-17 behind the start) nor lose accuracy.
#[test]
fn pivot_about_an_end_face_is_cheap_and_accurate() {
    let p = table2();
    for (k, &(ej, omega)) in [(0.9, 100.0), (0.98, -300.0), (0.5, 1e4)]
        .iter()
        .enumerate()
    {
        for &pivot_at_j in &[false, true] {
            let e = ej * p.clearance;
            let (ex, ey) = (e * 0.6, -e * 0.8);
            let s = if pivot_at_j {
                BearingState {
                    xi: ex,
                    yi: ey,
                    omega,
                    ..Default::default()
                }
            } else {
                BearingState {
                    xj: ex,
                    yj: ey,
                    omega,
                    ..Default::default()
                }
            };
            let expected = reference(&p, &s);
            for &level in &ACCURACY_LEVELS {
                let rule = FilmRule::new(Accuracy::new(level).unwrap().settings());
                let packed = pack_state(&p, &s).unwrap();
                let slices = rule.integrate(&packed.state).1;
                let nodes = rule.settings().nodes;
                // Poles only: a handful of panels (measured 2-9).
                assert!(
                    slices <= 12 * nodes,
                    "pivot [{k}] at j={pivot_at_j}, level {level:e}: {slices} slices ({nodes} per panel)"
                );
                assert_close(
                    &format!("pivot at j={pivot_at_j}, level {level:e}"),
                    k,
                    &rule_vector(&p, &s, &rule),
                    &expected,
                    level,
                    0.0,
                );
            }
        }
    }
}

/// The promise at the default level: 1e-6 up to ε = 0.95, 1e-4 up to 0.99; and
/// every level's near-wall promise is no looser than 1e-4 or 100 × its own tolerance.
#[test]
fn near_wall_promise_is_sensible() {
    let d = Accuracy::default();
    assert_eq!(d.rtol(), 1e-6);
    assert!(d.promise_near_wall() <= 1e-4, "{}", d.promise_near_wall());
    for &r in &ACCURACY_LEVELS {
        let a = Accuracy::new(r).unwrap();
        assert!(a.promise_near_wall() >= a.rtol());
        assert!(a.promise_near_wall() <= (100.0 * a.rtol()).max(1e-3) + 1e-18);
    }
}

/// Errors of the graded rule at `nodes` Gauss points per panel (other settings as the
/// default level's) against the reference.
fn refinement_errors(p: &BearingParams, s: &BearingState, nodes: &[u32]) -> Vec<f64> {
    let expected = reference(p, s);
    nodes
        .iter()
        .map(|&n| {
            let rule = FilmRule::new(RuleSettings {
                nodes: n,
                ..Accuracy::default().settings()
            });
            rel_error(&rule_vector(p, s, &rule), &expected)
        })
        .collect()
}

/// Convergence under refinement: for tilted states with and without squeeze and for a
/// tilt about the mid-plane, the error falls geometrically with the nodes per panel
/// (every two more nodes gain at least a factor 5 until rounding, ~1e-14, is reached)
/// and is at rounding level by 14 nodes.
#[test]
fn error_falls_rapidly_with_nodes_per_panel() {
    let nodes = [2, 4, 6, 8, 10, 12, 14];
    let p = table2();
    let mut rng = Rng::new(0x0C04_E46E);
    // Rounding floor of the comparison (reference at 1e-14, sums of ~100 slices).
    let floor = 3e-14;
    let mut index = 0;
    for family in [
        Family::General,
        Family::RotationTilted,
        Family::MidplaneTilt,
        Family::SqueezeOnly,
    ] {
        for emax in [0.6, 0.95, 0.99] {
            for _ in 0..5 {
                let s = random_state(&mut rng, &p, family, emax);
                let errs = refinement_errors(&p, &s, &nodes);
                for k in 1..errs.len() {
                    let bound = (errs[k - 1] / 5.0).max(floor);
                    assert!(
                        errs[k] <= bound,
                        "[{index}] {family:?} emax {emax}: error {:.3e} at {} nodes is not \
                         below {:.3e} (error at {} nodes / 5, or rounding); all errors {}; state {s:?}",
                        errs[k],
                        nodes[k],
                        bound,
                        nodes[k - 1],
                        sci(&errs)
                    );
                }
                assert!(
                    errs[errs.len() - 1] <= floor,
                    "[{index}] {family:?} emax {emax}: {}",
                    sci(&errs)
                );
                index += 1;
            }
        }
    }
}

/// The closed-form loaded-arc integrals against adaptive quadrature in θ on random
/// slices, eccentricity up to 0.99, rate vectors in every direction.
#[test]
fn closed_form_slice_matches_adaptive_theta_quadrature() {
    let mut rng = Rng::new(0x511CE);
    for k in 0..600 {
        let emax = if k % 2 == 0 { 0.95 } else { 0.99 };
        let (ex, ey) = rng.in_disc(emax);
        let (rx, ry) = rng.in_disc(3.0);
        let actual = slice_integrals(ex, ey, rx, ry);
        let expected = reference_slice(ex, ey, rx, ry, 1e-14);
        assert_close(
            &format!("slice eps=({ex}, {ey}) r=({rx}, {ry})"),
            k,
            &actual,
            &expected,
            1e-11,
            0.0,
        );
    }
    // Degenerate directions: centred journal, rate along and against the eccentricity.
    for (k, (ex, ey, rx, ry)) in [
        (0.0, 0.0, 1.0, 0.0),
        (0.9, 0.0, 1.0, 0.0),
        (0.9, 0.0, -1.0, 0.0),
        (0.0, 0.9, 0.0, 2.0),
        (0.5, 0.0, 0.0, -1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let actual = slice_integrals(ex, ey, rx, ry);
        let expected = reference_slice(ex, ey, rx, ry, 1e-14);
        assert_close("degenerate slice", k, &actual, &expected, 1e-11, 1e-14);
    }
    assert_eq!(slice_integrals(0.5, 0.1, 0.0, 0.0), [0.0, 0.0]);
}

/// The brute-force baseline converges to the rule's loads at second order: quadrupling
/// the grid in both directions cuts the error by at least 8 (16 expected), and the
/// 1024 × 1024 grid is within 1e-4.
#[test]
fn baseline_converges_to_the_same_loads() {
    let p = table2();
    let d = p.clearance;
    let states = [
        // Moderate tilted, squeezed state.
        BearingState {
            xi: 0.5 * d,
            yi: -0.1 * d,
            xj: 0.2 * d,
            yj: 0.3 * d,
            vxi: 0.002,
            vyi: -0.001,
            vxj: 0.0,
            vyj: 0.003,
            omega: 100.0,
        },
        // Aligned Ocvirk state (the baseline has no closed form to exploit).
        ocvirk_model(&p, 0.5, 100.0).0,
    ];
    for (index, s) in states.iter().enumerate() {
        let expected = reference(&p, s);
        let errs: Vec<f64> = [64, 256, 1024]
            .iter()
            .map(|&n| {
                rel_error(
                    &load_vector(baseline_loads(&p, s, n, n), p.length),
                    &expected,
                )
            })
            .collect();
        println!("baseline errors at 64², 256², 1024²: {}", sci(&errs));
        for k in 1..errs.len() {
            assert!(
                errs[k] <= errs[k - 1] / 8.0,
                "[{index}] baseline error not second order: {}",
                sci(&errs)
            );
        }
        assert!(errs[2] <= 1e-4, "[{index}] baseline errors {}", sci(&errs));
    }
}
