//! The film rule's arc-end root searches run several states at a time in SIMD lanes
//! (`FilmRule::integrate_many`, issue 28): every lane must give the scalar search's roots
//! and sweep counts bit for bit, and the batched integrals must equal `integrate`'s bit
//! for bit on every state family (aligned, tilted, kinks, degree-dropped quartics, near
//! the wall), at every accuracy level and on every instruction set.

mod common;

use bearing_sweep::backend::{CpuBackend, FilmBackend};
use bearing_sweep::bearing::{
    quartic_roots_counted, quartic_roots_lanes, Accuracy, FilmIntegrals, FilmRule, LaneIsa,
    PackedState, Singularities, ACCURACY_LEVELS, ROOT_LANES,
};
use common::*;

const ISAS: [LaneIsa; 3] = [LaneIsa::Baseline, LaneIsa::Avx2, LaneIsa::Avx512];

/// Random states of every family and eccentricity range, mixed with `bench loads`'s
/// strongly tilted ones (whose roots are near the bearing: nearly all of them searched).
fn mixed_states(seed: u64) -> Vec<PackedState> {
    let out = mixed_packed_states(seed, 1500);
    let n = out.len();
    (0..n).map(|k| out[(k * 7919) % n]).collect()
}

#[test]
fn root_lanes_match_the_scalar_search_bit_for_bit() {
    let settings = Accuracy::default().settings();
    let mut quartics = Vec::new();
    for st in mixed_states(0x2007_1A4E) {
        let sing = Singularities::of_all_roots(&st, &settings);
        if sing.root_work.0 != 4 {
            continue;
        }
        // The quartic as `Singularities` builds it (t = s − 1/2).
        let [e0x, e0y, ejx, ejy] = st.ecc;
        let [r0x, r0y, rjx, rjy] = st.rate;
        let (e1x, e1y, r1x, r1y) = (ejx - e0x, ejy - e0y, rjx - r0x, rjy - r0y);
        let (ecx, ecy) = (e0x + 0.5 * e1x, e0y + 0.5 * e1y);
        let (rcx, rcy) = (r0x + 0.5 * r1x, r0y + 0.5 * r1y);
        let a0 = ecx * rcx + ecy * rcy;
        let a1 = ecx * r1x + ecy * r1y + e1x * rcx + e1y * rcy;
        let a2 = e1x * r1x + e1y * r1y;
        let b0 = rcx * rcx + rcy * rcy;
        let b1 = 2.0 * (rcx * r1x + rcy * r1y);
        let b2 = r1x * r1x + r1y * r1y;
        let c = [
            a0 * a0 - b0,
            2.0 * a0 * a1 - b1,
            a1 * a1 + 2.0 * a0 * a2 - b2,
            2.0 * a1 * a2,
            a2 * a2,
        ];
        if quartic_roots_counted(c).1 == 4 {
            quartics.push(c);
        }
    }
    assert!(quartics.len() > 1000, "only {} quartics", quartics.len());
    let mut sweeps_seen = std::collections::BTreeSet::new();
    for group in quartics.chunks_exact(ROOT_LANES) {
        let c: [[f64; 5]; ROOT_LANES] = group.try_into().unwrap();
        let want: Vec<_> = c.iter().map(|&c| quartic_roots_counted(c)).collect();
        for isa in ISAS {
            let got = quartic_roots_lanes(isa, &c);
            for (l, (roots, sweeps)) in got.iter().enumerate() {
                let (w_roots, _, w_sweeps) = want[l];
                sweeps_seen.insert(w_sweeps);
                assert_eq!(*sweeps, w_sweeps, "{isa:?} lane {l}: sweeps for {:?}", c[l]);
                for k in 0..4 {
                    assert_eq!(
                        (roots[k].0.to_bits(), roots[k].1.to_bits()),
                        (w_roots[k].0.to_bits(), w_roots[k].1.to_bits()),
                        "{isa:?} lane {l} root {k} for {:?}",
                        c[l]
                    );
                }
            }
        }
    }
    // Lanes that stop at different sweeps (the selects are exercised).
    assert!(sweeps_seen.len() >= 4, "sweep counts seen: {sweeps_seen:?}");
}

#[test]
fn integrate_many_equals_integrate_bit_for_bit() {
    let states = mixed_states(0x1A4E_5EED);
    for &level in &ACCURACY_LEVELS {
        let settings = Accuracy::new(level).unwrap().settings();
        for isa in ISAS {
            let rule = FilmRule::with_isa(settings, isa);
            let want: Vec<FilmIntegrals> = states.iter().map(|s| rule.integrate(s).0).collect();
            // Whole slice, and odd-sized pieces (partial blocks, partial lane groups).
            let mut got = vec![[f64::NAN; 4]; states.len()];
            rule.integrate_many(&states, &mut got);
            assert_eq!(
                integral_bits(&got),
                integral_bits(&want),
                "level {level:e} {isa:?}"
            );
            for piece in [1, 3, 5, 63, 65, 130] {
                let mut got = vec![[f64::NAN; 4]; states.len()];
                for (s, o) in states.chunks(piece).zip(got.chunks_mut(piece)) {
                    rule.integrate_many(s, o);
                }
                assert_eq!(
                    integral_bits(&got),
                    integral_bits(&want),
                    "level {level:e} {isa:?} piece {piece}"
                );
            }
        }
    }
}

#[test]
fn cpu_backend_gives_the_one_state_rule_bit_for_bit() {
    let states = mixed_states(0xC0DE_2028);
    let acc = Accuracy::default();
    let rule = FilmRule::new(acc.settings());
    let want: Vec<FilmIntegrals> = states.iter().map(|s| rule.integrate(s).0).collect();
    for threads in [Some(1), Some(2)] {
        let mut cpu = CpuBackend::new(acc, threads);
        let mut got = Vec::new();
        cpu.integrate(&states, &mut got).unwrap();
        assert_eq!(
            integral_bits(&got),
            integral_bits(&want),
            "threads {threads:?}"
        );
    }
}

/// The rotor workloads' kind of state: slightly tilted journals whose film is one panel of
/// one lane group, which `integrate_many` evaluates two at a time (`panel_pair`, issue 28's
/// fifteenth pass). Each must still get `integrate`'s bits, odd counts included (the last
/// state then waits alone), at every level and on every instruction set.
#[test]
fn paired_single_panel_states_equal_integrate_bit_for_bit() {
    let mut rng = Rng::new(0x9A1E_D5EE);
    let states: Vec<PackedState> = (0..1001)
        .map(|_| {
            let (e, a) = (rng.range(0.0, 0.9), rng.range(-3.2, 3.2));
            let (ex, ey) = (e * a.cos(), e * a.sin());
            let tilt = rng.range(-0.01, 0.01);
            let (b, rx, ry) = (rng.range(-3.2, 3.2), rng.range(0.5, 1.0), 0.0);
            let (rx, ry) = (rx * b.cos() - ry * b.sin(), rx * b.sin() + ry * b.cos());
            let dr = rng.range(-0.02, 0.02);
            PackedState {
                ecc: [ex, ey, ex + tilt, ey - tilt],
                rate: [rx, ry, rx + dr, ry - dr],
            }
        })
        .collect();
    for &level in &ACCURACY_LEVELS {
        let settings = Accuracy::new(level).unwrap().settings();
        for isa in ISAS {
            let rule = FilmRule::with_isa(settings, isa);
            let want: Vec<(FilmIntegrals, u32)> =
                states.iter().map(|s| rule.integrate(s)).collect();
            // The pairs' precondition holds for most of these states below the 1e-12 level
            // (one panel of `nodes` slices, at most 8 of them): else this test proves little.
            let single = want.iter().filter(|w| w.1 == settings.nodes).count();
            if settings.nodes as usize <= 8 {
                assert!(
                    2 * single > states.len(),
                    "level {level:e}: only {single} of {} states are one panel",
                    states.len()
                );
            }
            let want: Vec<FilmIntegrals> = want.into_iter().map(|w| w.0).collect();
            for piece in [states.len(), 2, 3, 7] {
                let mut got = vec![[f64::NAN; 4]; states.len()];
                for (s, o) in states.chunks(piece).zip(got.chunks_mut(piece)) {
                    rule.integrate_many(s, o);
                }
                for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        g.map(f64::to_bits),
                        w.map(f64::to_bits),
                        "level {level:e} {isa:?} piece {piece}, state {k}: {g:?} vs {w:?}"
                    );
                }
            }
        }
    }
}
