//! The film rule's slices evaluated in SIMD lanes (issue 28): the same bits on every
//! instruction set, within a few ulp of the scalar `slice_integrals` (only `atan2` differs:
//! an arithmetic one instead of libm's), and the branch-free edge cases (zero rate, centred
//! journal) as in the scalar path.

#![allow(clippy::needless_range_loop)]

mod common;

use bearing_sweep::bearing::{atan2_lane, slice_integrals, slices_lanes, LaneIsa, Lanes, LANES};
use common::*;

/// `atan2_lane` within 4 ulp of libm's `atan2` over all quadrants, magnitudes and the axes.
#[test]
fn arithmetic_atan2_is_within_a_few_ulp_of_libm() {
    let mut rng = Rng::new(0xA7A2);
    let mut worst: f64 = 0.0;
    let mut check = |y: f64, x: f64| {
        let (a, b) = (atan2_lane(y, x), y.atan2(x));
        // ulp of the result (at least that of 1e-300 for results near zero).
        let ulp = f64::EPSILON * b.abs().max(1e-300);
        let e = (a - b).abs() / ulp;
        worst = worst.max(e);
        assert!(e <= 4.0, "atan2({y:e}, {x:e}) = {a:e}, libm {b:e}: {e} ulp");
    };
    for _ in 0..200_000 {
        let ang = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        let r = 10f64.powf(rng.range(-6.0, 3.0));
        check(r * ang.sin(), r * ang.cos());
    }
    for &(y, x) in &[
        (0.0, 1.0),
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, -1.0),
        (1e-300, -1.0),
        (-1e-300, -1.0),
        (1.0, 1.0),
        (-1.0, -1.0),
        (1e-17, 1.0),
    ] {
        check(y, x);
    }
    assert_eq!(atan2_lane(0.0, 0.0), 0.0);
    println!("atan2_lane: worst {worst:.2} ulp");
}

fn random_lanes(rng: &mut Rng) -> [Lanes; 4] {
    let mut v = [[0.0; LANES]; 4];
    for i in 0..LANES {
        let e = rng.range(0.0, 0.995);
        let a = rng.angle();
        v[0][i] = e * a.cos();
        v[1][i] = e * a.sin();
        let (x, y) = rng.in_disc(1.0);
        v[2][i] = x;
        v[3][i] = y;
    }
    v
}

/// Every instruction set gives the same bits, and each lane is the scalar slice to a few
/// ulp of the slice's size `|r| · 2π / (1 − ε²)^{5/2}` (the scale of its largest term).
#[test]
fn lanes_match_the_scalar_slice_and_every_instruction_set_agrees() {
    let mut rng = Rng::new(0x1A9E5);
    let isas = [LaneIsa::Baseline, LaneIsa::Avx2, LaneIsa::Avx512];
    let mut worst: f64 = 0.0;
    for round in 0..20_000 {
        let [mut ex, mut ey, mut rx, mut ry] = random_lanes(&mut rng);
        if round % 50 == 0 {
            // Edge cases in some lanes: zero rate, centred journal, both.
            rx[1] = 0.0;
            ry[1] = 0.0;
            ex[2] = 0.0;
            ey[2] = 0.0;
            (ex[3], ey[3], rx[3], ry[3]) = (0.0, 0.0, 0.0, 0.0);
        }
        let mut outs = Vec::new();
        for &isa in &isas {
            let (mut c, mut s) = ([0.0; LANES], [0.0; LANES]);
            slices_lanes(isa, &ex, &ey, &rx, &ry, &mut c, &mut s);
            outs.push((c, s));
        }
        for o in &outs[1..] {
            assert_eq!(
                o.0.map(f64::to_bits),
                outs[0].0.map(f64::to_bits),
                "instruction sets disagree"
            );
            assert_eq!(o.1.map(f64::to_bits), outs[0].1.map(f64::to_bits));
        }
        let (c, s) = outs[0];
        for i in 0..LANES {
            let [c0, s0] = slice_integrals(ex[i], ey[i], rx[i], ry[i]);
            let eps2 = ex[i] * ex[i] + ey[i] * ey[i];
            let r = rx[i].hypot(ry[i]);
            let size = r * 2.0 * std::f64::consts::PI / (1.0 - eps2).powf(2.5);
            let e = (c[i] - c0).abs().max((s[i] - s0).abs());
            if size == 0.0 {
                assert_eq!((c[i], s[i]), (0.0, 0.0), "zero rate must give no load");
                assert_eq!((c0, s0), (0.0, 0.0));
                continue;
            }
            let ulps = e / (f64::EPSILON * size);
            worst = worst.max(ulps);
            assert!(
                ulps <= 16.0,
                "lane {i}: ({:e}, {:e}) vs scalar ({c0:e}, {s0:e}): {ulps} ulp of the size",
                c[i],
                s[i]
            );
        }
    }
    println!("slices_lanes vs slice_integrals: worst {worst:.2} ulp of the slice size");
}
