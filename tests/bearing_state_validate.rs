//! `BearingState::validate`'s fast path (both ends clearly inside the bore, no `hypot`)
//! gives the same verdict as the exact test `hypot(x, y) / δ < 1` it short-cuts, on states
//! spread across the fast path's edge (0.99 δ) and the wall (δ), at several clearances.

use bearing_sweep::bearing::{BearingState, End, StateFault};

/// The exact rule, as `validate` states it for states past the fast path.
fn exact(s: &BearingState, c: f64) -> Result<(), StateFault> {
    let ei = s.xi.hypot(s.yi) / c;
    let ej = s.xj.hypot(s.yj) / c;
    if ei >= 1.0 {
        return Err(StateFault::ThroughWall {
            end: End::I,
            ratio: ei,
        });
    }
    if ej >= 1.0 {
        return Err(StateFault::ThroughWall {
            end: End::J,
            ratio: ej,
        });
    }
    Ok(())
}

#[test]
fn the_fast_path_agrees_with_the_exact_wall_test() {
    // A fixed linear congruential sequence: reproducible, no dependency.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut inside, mut through) = (0, 0);
    for &c in &[1e-4, 3e-4, 6e-4, 1.0, 7.3e-5] {
        for k in 0..20_000 {
            // Radii from 0.97 δ to 1.01 δ, and every 50th exactly at 0.99 δ or δ.
            let r = |u: f64| match k % 50 {
                0 => 0.99 * c,
                1 => c,
                _ => c * (0.97 + 0.04 * u),
            };
            let (ri, rj) = (r(next()), r(next()));
            let (ai, aj) = (
                std::f64::consts::TAU * next(),
                std::f64::consts::TAU * next(),
            );
            let s = BearingState {
                xi: ri * ai.cos(),
                yi: ri * ai.sin(),
                xj: rj * aj.cos(),
                yj: rj * aj.sin(),
                vxi: 0.0,
                vyi: 0.0,
                vxj: 0.0,
                vyj: 0.0,
                omega: 100.0,
            };
            let (got, want) = (s.validate(c), exact(&s, c));
            assert_eq!(got, want, "clearance {c}, state {s:?}");
            if want.is_ok() {
                inside += 1;
            } else {
                through += 1;
            }
        }
    }
    // Both verdicts were exercised in numbers.
    assert!(
        inside > 10_000 && through > 10_000,
        "{inside} inside, {through} through"
    );
}
