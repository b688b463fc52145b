//! The panel grading of the film rule (issue 28, seventh pass): toward a complex
//! singularity a panel `[s, s + L]` is the longest whose Bernstein ellipse with
//! focal-distance sum `k L` (`k = RuleSettings::complex_ellipse`, `1 + √2`) leaves the
//! singularity outside; toward the real poles it is `κ` times their distance. Checked on
//! the panels the rule lays out for states of every family and `bench loads`'s strongly
//! tilted ones: every complex singularity is on or outside every panel's ellipse, and each
//! panel that is not cut by the bearing's end or a kink is as long as its binding
//! constraint allows (one of them holds with equality). The accuracy this grading gives is
//! checked against the 1e-14 reference in tests/bearing_accuracy.rs.

mod common;

use bearing_sweep::bearing::{
    pack_state, Accuracy, BearingParams, PackedState, Singularities, ACCURACY_LEVELS,
};
use bearing_sweep::bench::bench_states;
use common::*;

fn states() -> Vec<PackedState> {
    let geoms = geometries();
    let mut rng = Rng::new(0x6AAD_1A6E);
    let mut out = Vec::new();
    for family in FAMILIES {
        for emax in [0.5, 0.95, 0.99] {
            for k in 0..40 {
                let (_, p) = &geoms[k % geoms.len()];
                let s = random_state(&mut rng, p, family, emax);
                out.push(pack_state(p, &s).expect("valid state").state);
            }
        }
    }
    let p = BearingParams::paper_table2();
    out.extend(
        bench_states(&p, 500)
            .iter()
            .map(|s| pack_state(&p, s).expect("valid state").state),
    );
    out
}

#[test]
fn panels_keep_complex_singularities_outside_their_ellipse_and_are_longest() {
    let states = states();
    let mut bound_by_complex = 0;
    for &level in &ACCURACY_LEVELS {
        let settings = Accuracy::new(level).unwrap().settings();
        let k = settings.complex_ellipse;
        assert!((k - (1.0 + 2f64.sqrt())).abs() < 1e-15, "default {k}");
        for (i, st) in states.iter().enumerate() {
            let sing = Singularities::of_all_roots(st, &settings);
            let cs = &sing.complex[..sing.complex_count];
            let mut s = 0.0;
            let mut panels = 0;
            while s < 1.0 && panels < settings.max_panels - 1 {
                panels += 1;
                let e = sing.panel_end(s, &settings);
                let len = e - s;
                assert!(len > 0.0, "[{i}] level {level:e}: empty panel at {s}");
                // Slack for the rounding of the closed form (terms of order one).
                let tol = 1e-12 * (1.0 + len);
                let mut tight = false;
                for &(re, im) in cs {
                    let d1 = ((re - s).powi(2) + im * im).sqrt();
                    let d2 = ((re - e).powi(2) + im * im).sqrt();
                    let margin = d1 + d2 - k * len;
                    assert!(
                        margin >= -tol * k,
                        "[{i}] level {level:e}: singularity ({re}, {im}) inside the ellipse of \
                         [{s}, {e}] by {margin:e}"
                    );
                    tight |= margin <= tol * k;
                }
                if tight {
                    bound_by_complex += 1;
                }
                // The poles: κ times their distance, ahead and behind.
                if sing.pole_hi.is_finite() {
                    let cap = settings.kappa_ahead * (sing.pole_hi - s);
                    assert!(len <= cap + tol, "[{i}] pole ahead");
                    tight |= len >= cap - tol;
                }
                if sing.pole_lo.is_finite() {
                    let cap = settings.kappa_behind * (s - sing.pole_lo);
                    assert!(len <= cap + tol, "[{i}] pole behind");
                    tight |= len >= cap - tol;
                }
                let cut = e == 1.0 || e == sing.kink_s;
                assert!(
                    tight || cut,
                    "[{i}] level {level:e}: panel [{s}, {e}] shorter than any constraint needs"
                );
                s = e;
            }
        }
    }
    // The complex singularities do bind on these states (the check above is exercised).
    assert!(bound_by_complex > 1000, "{bound_by_complex} panels bound");
}
