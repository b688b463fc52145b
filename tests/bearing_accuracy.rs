//! Accuracy of the default load rule against the adaptive reference: each accuracy level
//! keeps its promise on random states of every family; convergence under refinement;
//! the closed-form slice against adaptive quadrature in θ; the brute-force baseline
//! converging to the same loads.

mod common;

use bearing_sweep::bearing::reference::{reference_loads, reference_slice};
use bearing_sweep::bearing::{
    baseline_loads, film_loads, slice_integrals, Accuracy, BearingParams, BearingState, FilmRule,
    RuleSettings, ACCURACY_LEVELS,
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
const STATES_PER_CASE: usize = 200;

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
