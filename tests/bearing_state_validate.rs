//! `BearingState::validate`'s fast path (both ends clearly inside the bore, no `hypot`)
//! gives the same verdict as the exact test `hypot(x, y) / δ < 1` it short-cuts, on states
//! spread across the fast path's edge (0.99 δ) and the wall (δ), at several clearances;
//! its finiteness test (one sum, issue 28's eighth pass) names the same field as the loop
//! over the fields; `h_min`'s and `planar_length`'s `√(x² + y²)` (issue 28's ninth pass)
//! stay within 2 ulp of the two `hypot`s they replace, and equal them outside their range.

use bearing_sweep::bearing::{planar_length, BearingState, End, StateFault, PLANAR_RANGE};

/// Distance in units in the last place between two finite numbers of the same sign.
fn ulps(a: f64, b: f64) -> u64 {
    assert!(
        a.is_finite() && b.is_finite() && (a >= 0.0) == (b >= 0.0),
        "{a} vs {b}"
    );
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
}

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

/// A state with every field `v` except field `k` (JSON order) set to `bad`.
fn with_field(k: usize, v: f64, bad: f64) -> BearingState {
    let mut f = [v; 9];
    f[k] = bad;
    BearingState {
        xi: f[0],
        yi: f[1],
        xj: f[2],
        yj: f[3],
        vxi: f[4],
        vyi: f[5],
        vxj: f[6],
        vyj: f[7],
        omega: f[8],
    }
}

#[test]
fn a_non_finite_field_is_named_as_before() {
    let names = ["xi", "yi", "xj", "yj", "vxi", "vyi", "vxj", "vyj", "omega"];
    for (k, name) in names.iter().enumerate() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            // Finite fields of either sign and zero (`0 · x` is −0 for negative x).
            for v in [1e-6, -1e-6, 0.0] {
                let s = with_field(k, v, bad);
                assert_eq!(
                    s.validate(1e-3),
                    Err(StateFault::NonFinite { field: name }),
                    "field {name} = {bad}, others {v}"
                );
            }
        }
        // A huge finite field is finite (its `0 · x` is 0): no NonFinite fault.
        let s = with_field(k, 1e-6, if k < 4 { 1e-6 } else { 1e300 });
        assert_eq!(s.validate(1e-3), Ok(()), "field {name} huge");
    }
}

#[test]
fn h_min_is_within_two_ulp_of_both_hypots() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    // The farther end's length as before issue 28's ninth pass.
    let far = |s: &BearingState| s.xi.hypot(s.yi).max(s.xj.hypot(s.yj));
    let (mut near, mut differ, mut worst, mut outside) = (0, 0, 0, 0);
    for k in 0..200_000 {
        // Magnitudes from 1e-170 to 1e170 (squares under- and overflowing at the ends),
        // and ends equal or a few ulp apart in length every few states.
        let scale = 10f64.powf(-170.0 + 340.0 * next());
        let (ri, ai, aj) = (scale * next(), std::f64::consts::TAU * next(), 0.0);
        let rj = match k % 4 {
            0 => ri,
            1 => ri * (1.0 + f64::EPSILON * (8.0 * next() - 4.0).round()),
            2 => ri * (1.0 + 1e-12 * (2.0 * next() - 1.0)),
            _ => scale * next(),
        };
        let aj = if k % 8 < 4 {
            ai
        } else {
            aj + std::f64::consts::TAU * next()
        };
        let s = BearingState {
            xi: ri * ai.cos(),
            yi: ri * ai.sin(),
            xj: rj * aj.cos(),
            yj: rj * aj.sin(),
            omega: 1.0,
            ..BearingState::default()
        };
        near += usize::from(k % 4 < 3);
        // With δ = 0 the result is −(farther length) exactly: compare the lengths.
        let (got, want) = (-s.h_min(0.0), far(&s));
        let squares = (s.xi * s.xi + s.yi * s.yi).max(s.xj * s.xj + s.yj * s.yj);
        if PLANAR_RANGE.contains(&squares) {
            let u = ulps(got, want);
            assert!(u <= 2, "state {s:?}: {got:e} vs {want:e}, {u} ulp");
            differ += usize::from(u > 0);
            worst = worst.max(u);
        } else {
            // Outside the range: the two `hypot`s, bit for bit.
            assert_eq!(got.to_bits(), want.to_bits(), "state {s:?}");
            outside += 1;
        }
        // Any clearance: δ minus that same length.
        let c = scale;
        assert_eq!(s.h_min(c).to_bits(), (c - got).to_bits(), "state {s:?}");
    }
    assert!(near > 100_000);
    // Both paths were exercised.
    assert!(outside > 1000, "{outside} outside");
    assert!(differ <= 200_000 && worst <= 2);
    // Non-finite positions: as the two-hypot formula.
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in 0..4 {
            let s = with_field(k, 1e-5, bad);
            let (got, exp) = (s.h_min(1e-3), 1e-3 - far(&s));
            assert!(
                got.to_bits() == exp.to_bits() || (got.is_nan() && exp.is_nan()),
                "field {k} = {bad}: {got} vs {exp}"
            );
        }
    }
}

#[test]
fn planar_length_is_within_two_ulp_of_hypot() {
    let mut seed = 0x2f6b_1d3a_99c4_0e57u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut inside, mut outside, mut differ) = (0, 0, 0);
    for k in 0..400_000 {
        // Components from 1e-320 (subnormal) to 1e300 in magnitude, of either sign, one
        // of them much smaller every few pairs, or exactly zero.
        let mag = |u: f64| 10f64.powf(-320.0 + 620.0 * u);
        let x = mag(next()) * if next() < 0.5 { -1.0 } else { 1.0 };
        let y = match k % 5 {
            0 => 0.0,
            1 => x * 1e-9 * next(),
            _ => mag(next()) * if next() < 0.5 { -1.0 } else { 1.0 },
        };
        let (got, want) = (planar_length(x, y), x.hypot(y));
        if PLANAR_RANGE.contains(&(x * x + y * y)) {
            let u = ulps(got, want);
            assert!(u <= 2, "({x:e}, {y:e}): {got:e} vs {want:e}, {u} ulp");
            inside += 1;
            differ += usize::from(u > 0);
        } else {
            assert_eq!(got.to_bits(), want.to_bits(), "({x:e}, {y:e})");
            outside += 1;
        }
    }
    // Both paths exercised; `√(x² + y²)` does differ from `hypot` in the last bit on some
    // (so that the 2 ulp bound, not equality, is what holds).
    assert!(inside > 50_000 && outside > 50_000 && differ > 100);
    // Non-finite inputs: `hypot`'s answer (∞ for an infinite component, even with a NaN).
    for (x, y) in [
        (f64::INFINITY, f64::NAN),
        (f64::NAN, 1.0),
        (f64::NEG_INFINITY, 2.0),
        (1e300, 1e300),
        (f64::MAX, f64::MAX),
        (5e-324, 0.0),
        (0.0, 0.0),
    ] {
        let (got, want) = (planar_length(x, y), x.hypot(y));
        assert!(
            got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
            "({x:e}, {y:e}): {got} vs {want}"
        );
    }
}

#[test]
fn finite_or_fault_names_the_first_non_finite_output() {
    use bearing_sweep::bearing::{FilmFlow, FrictionLaw, Loads};
    let ok = Loads {
        wx: -1.0,
        wy: 2.0,
        mx: -0.0,
        my: 3.0,
        mz: -4.0,
        friction_coefficient: Some(0.1),
        sommerfeld: None,
        h_min: 1e-5,
        power_loss: 5.0,
        friction_model: FrictionLaw::Paper,
        film: FilmFlow {
            friction_variable: None,
            ..FilmFlow::default()
        },
    };
    assert_eq!(ok.finite_or_fault(), Ok(ok));
    // Each output's JSON name and how to set it.
    type Setter = (&'static str, fn(&mut Loads, f64));
    let set: [Setter; 14] = [
        ("wx", |l, v| l.wx = v),
        ("wy", |l, v| l.wy = v),
        ("mx", |l, v| l.mx = v),
        ("my", |l, v| l.my = v),
        ("mz", |l, v| l.mz = v),
        ("friction_coefficient", |l, v| {
            l.friction_coefficient = Some(v)
        }),
        ("sommerfeld", |l, v| l.sommerfeld = Some(v)),
        ("h_min", |l, v| l.h_min = v),
        ("power_loss", |l, v| l.power_loss = v),
        ("film.friction_torque_nm", |l, v| {
            l.film.friction_torque_nm = v
        }),
        ("film.power_loss_w", |l, v| l.film.power_loss_w = v),
        ("film.friction_variable", |l, v| {
            l.film.friction_variable = Some(v)
        }),
        ("film.side_flow_m3_per_s", |l, v| {
            l.film.side_flow_m3_per_s = v
        }),
        ("film.inlet_flow_m3_per_s", |l, v| {
            l.film.inlet_flow_m3_per_s = v
        }),
    ];
    for (k, (name, f)) in set.iter().enumerate() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut l = ok;
            f(&mut l, bad);
            // A later field non-finite too: the first is named.
            if let Some((_, g)) = set.get(k + 1) {
                g(&mut l, f64::NAN);
            }
            assert_eq!(
                l.finite_or_fault(),
                Err(StateFault::Overflow { quantity: name }),
                "{name} = {bad}"
            );
        }
        // Huge finite values pass.
        let mut l = ok;
        f(&mut l, -1e308);
        assert!(l.finite_or_fault().is_ok(), "{name} huge");
    }
}
