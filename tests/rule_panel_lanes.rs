//! The film rule's panel loop runs in SIMD lanes (issue 28, seventh pass): node setup,
//! slices and the weighted products of a panel's Gauss nodes together, the products summed
//! node by node in order. The integrals must equal, bit for bit, those of the scalar panel
//! loop it replaced (written out below from the rule's public pieces: its singularities,
//! `panel_end`, Gauss table and `slices_lanes`), on every state family, at every accuracy
//! level (12 nodes at 1e-12: two lane groups, the second partly padded), on every
//! instruction set, one state at a time and through `integrate_many`.

mod common;

use bearing_sweep::bearing::{
    slices_lanes, Accuracy, FilmIntegrals, FilmRule, LaneIsa, Lanes, PackedState, Singularities,
    ACCURACY_LEVELS, LANES,
};
use common::*;

const ISAS: [LaneIsa; 3] = [LaneIsa::Baseline, LaneIsa::Avx2, LaneIsa::Avx512];

/// Random states of every family and eccentricity range (aligned ones included), mixed
/// with 1000 of `bench loads`'s strongly tilted ones.
fn mixed_states(seed: u64) -> Vec<PackedState> {
    mixed_packed_states(seed, 1000)
}

/// The panel loop before the seventh pass: per panel, the nodes set up one at a time, the
/// slices in `slices_lanes` (unused lanes zero), then `acc += w c` etc. node by node.
fn scalar_panel_loop(rule: &FilmRule, state: &PackedState) -> FilmIntegrals {
    let [e0x, e0y, ejx, ejy] = state.ecc;
    let [r0x, r0y, rjx, rjy] = state.rate;
    let (e1x, e1y, r1x, r1y) = (ejx - e0x, ejy - e0y, rjx - r0x, rjy - r0y);
    if e1x == 0.0 && e1y == 0.0 && r1x == 0.0 && r1y == 0.0 {
        // Aligned: one slice (not a panel loop); taken from the rule itself.
        return rule.integrate(state).0;
    }
    let settings = rule.settings();
    let sing = Singularities::of(state, settings);
    let (nodes, weights) = (&rule.gauss().nodes, &rule.gauss().weights);
    let mut acc = [0.0; 4];
    let mut s = 0.0;
    let mut panels = 0;
    while s < 1.0 {
        panels += 1;
        let end = if panels >= settings.max_panels {
            1.0
        } else {
            sing.panel_end(s, settings)
        };
        let len = end - s;
        let mut first = 0;
        while first < nodes.len() {
            let m = (nodes.len() - first).min(LANES);
            let (mut ex, mut ey, mut rx, mut ry): (Lanes, Lanes, Lanes, Lanes) =
                ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
            let mut zs = [0.0; LANES];
            for i in 0..m {
                let z = s + len * nodes[first + i];
                zs[i] = z;
                ex[i] = e0x + e1x * z;
                ey[i] = e0y + e1y * z;
                rx[i] = r0x + r1x * z;
                ry[i] = r0y + r1y * z;
            }
            let (mut cs, mut ss) = ([0.0; LANES], [0.0; LANES]);
            slices_lanes(LaneIsa::Baseline, &ex, &ey, &rx, &ry, &mut cs, &mut ss);
            for i in 0..m {
                let (z, c, sn) = (zs[i], cs[i], ss[i]);
                let wg = weights[first + i] * len * z * (1.0 - z);
                acc[0] += wg * c;
                acc[1] += wg * sn;
                acc[2] += wg * z * c;
                acc[3] += wg * z * sn;
            }
            first += m;
        }
        s = end;
    }
    acc
}

#[test]
fn panel_lanes_equal_the_scalar_panel_loop_bit_for_bit() {
    let states = mixed_states(0x7A4E_1507);
    for &level in &ACCURACY_LEVELS {
        let settings = Accuracy::new(level).unwrap().settings();
        let reference = FilmRule::with_isa(settings, LaneIsa::Baseline);
        let want: Vec<FilmIntegrals> = states
            .iter()
            .map(|s| scalar_panel_loop(&reference, s))
            .collect();
        // Some tilted states, several panels each (the loop is exercised).
        let tilted = states
            .iter()
            .filter(|s| reference.integrate(s).1 > 2 * settings.nodes)
            .count();
        assert!(
            tilted > 1000,
            "level {level:e}: {tilted} multi-panel states"
        );
        for isa in ISAS {
            let rule = FilmRule::with_isa(settings, isa);
            let one: Vec<FilmIntegrals> = states.iter().map(|s| rule.integrate(s).0).collect();
            assert_eq!(
                integral_bits(&one),
                integral_bits(&want),
                "integrate, level {level:e} {isa:?}"
            );
            let mut many = vec![[f64::NAN; 4]; states.len()];
            rule.integrate_many(&states, &mut many);
            assert_eq!(
                integral_bits(&many),
                integral_bits(&want),
                "integrate_many, level {level:e} {isa:?}"
            );
        }
    }
}
