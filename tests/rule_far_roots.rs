//! The film rule leaves out arc-end roots that cannot shorten a panel (issue 28): the
//! panel layout, hence every integral, is bit-identical to the one with every root found,
//! and the shortcut is actually taken where the roots are far (mildly tilted journals, the
//! rotor workloads' states) and not where they bind.

mod common;

use bearing_sweep::bearing::{
    Accuracy, BearingState, FilmRule, RuleSettings, Singularities, ACCURACY_LEVELS,
};
use common::*;

/// Panel ends as `FilmRule::integrate` marches them, for given singularities.
fn panel_ends(sing: &Singularities, settings: &RuleSettings) -> Vec<f64> {
    let mut ends = Vec::new();
    let mut s = 0.0;
    let mut panels = 0;
    while s < 1.0 {
        panels += 1;
        let end = if panels >= settings.max_panels {
            1.0
        } else {
            sing.panel_end(s, settings)
        };
        ends.push(end);
        s = end;
    }
    ends
}

#[test]
fn leaving_out_far_roots_keeps_the_panel_layout_bit_for_bit() {
    let geoms = geometries();
    let mut rng = Rng::new(0xFA12_2028);
    let (mut shortcut, mut searched) = (0usize, 0usize);
    for &level in &ACCURACY_LEVELS {
        let settings = Accuracy::new(level).unwrap().settings();
        let rule = FilmRule::new(settings);
        for family in FAMILIES {
            for emax in [0.5, 0.95, 0.99] {
                for k in 0..150 {
                    let (_, p) = &geoms[k % geoms.len()];
                    let st = packed(p, &random_state(&mut rng, p, family, emax));
                    let fast = Singularities::of(&st, &settings);
                    let full = Singularities::of_all_roots(&st, &settings);
                    let (a, b) = (panel_ends(&fast, &settings), panel_ends(&full, &settings));
                    assert_eq!(
                        a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        b.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        "{family:?} level {level:e}: panel ends differ for {st:?}"
                    );
                    // Integrals follow the layout; checked directly on a subset.
                    if k % 10 == 0 {
                        let (v, _) = rule.integrate(&st);
                        assert!(v.iter().all(|x| x.is_finite()));
                    }
                    if full.root_work.1 > 0 {
                        if fast.root_work.1 == 0 {
                            shortcut += 1;
                        } else {
                            searched += 1;
                        }
                    }
                }
            }
        }
    }
    println!("roots left out on {shortcut} states, searched on {searched}");
    // Both paths are exercised by these families (strong tilts keep their roots).
    assert!(shortcut > 100 && searched > 100, "{shortcut} / {searched}");
}

/// A rotor-like state: ends of a mildly tilted journal (the tilt a rigid rotor's
/// bearings see) with whirl velocities; the roots lie far away and are not searched.
#[test]
fn mildly_tilted_states_skip_the_root_search_and_strong_tilts_do_not() {
    let p = table2();
    let settings = Accuracy::default().settings();
    let d = p.clearance;
    let w = 100.0;
    let mild = BearingState {
        xi: 0.40 * d,
        yi: -0.30 * d,
        xj: 0.41 * d,
        yj: -0.31 * d,
        vxi: 0.02 * d * w,
        vyi: 0.01 * d * w,
        vxj: 0.021 * d * w,
        vyj: 0.011 * d * w,
        omega: w,
    };
    let fast = Singularities::of(&packed(&p, &mild), &settings);
    let full = Singularities::of_all_roots(&packed(&p, &mild), &settings);
    assert_eq!(fast.root_work.1, 0, "mild tilt searched its roots");
    assert!(full.root_work.1 > 0);
    // Every root the full search finds is beyond the radius where it could bind.
    for &(re, im) in &full.complex[..full.complex_count] {
        assert!(
            (re - 0.5).hypot(im) > 2.5,
            "root ({re}, {im}) near the bearing"
        );
    }
    let strong = BearingState {
        xi: 0.8 * d,
        yi: 0.0,
        xj: -0.6 * d,
        yj: 0.5 * d,
        ..mild
    };
    let fast = Singularities::of(&packed(&p, &strong), &settings);
    assert!(fast.root_work.1 > 0, "strong tilt skipped its roots");
}
