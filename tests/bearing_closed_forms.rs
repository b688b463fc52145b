//! Closed forms of MODEL.md: Ocvirk's short-bearing loads (section 7) at every accuracy
//! level and several geometries, the minimum film thickness, and every case of the
//! friction law (section 5) with the paper's and Vogelpohl's clearance conventions.

mod common;

use bearing_sweep::bearing::{
    film_loads, friction, Accuracy, BearingParams, BearingState, ClearanceConvention, FilmRule,
    ACCURACY_LEVELS,
};
use common::*;

/// Aligned journals are integrated exactly (one slice, closed-form arc): agreement to
/// rounding. The factors `(1 − ε²)^{-2}` amplify rounding of `ε` near the wall, hence
/// the tolerance grows like `1e-14 / (1 − ε)`.
#[test]
fn ocvirk_forces_and_moments_at_every_level() {
    let eps_list = [0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.98];
    let mut index = 0;
    for &level in &ACCURACY_LEVELS {
        let rule = FilmRule::new(Accuracy::new(level).unwrap().settings());
        for (gname, p) in geometries() {
            for &eps in &eps_list {
                for omega in [1.0, 100.0, 3000.0] {
                    let (state, expected) = ocvirk_model(&p, eps, omega);
                    let loads = film_loads(&p, &state, &rule).expect("valid aligned state");
                    let actual = [loads.wx, loads.wy, loads.mx, loads.my];
                    assert_close_each(
                        &format!("Ocvirk level {level:e} {gname} eps {eps} omega {omega}"),
                        index,
                        &actual,
                        &expected,
                        1e-14 / (1.0 - eps),
                        0.0,
                    );
                    index += 1;
                }
            }
        }
    }
}

/// Ocvirk's ratios, independent of the geometry: the attitude angle
/// `tan φ = π √(1−ε²) / (4 ε)` and the moments at the mid-plane arm `B/2`.
#[test]
fn ocvirk_attitude_angle_and_mid_plane_arm() {
    let rule = FilmRule::new(Accuracy::default().settings());
    for (k, eps) in [0.05, 0.4, 0.8, 0.97].into_iter().enumerate() {
        let p = table2();
        let (state, _) = ocvirk_model(&p, eps, 250.0);
        let l = film_loads(&p, &state, &rule).unwrap();
        // The film pushes the journal back toward the centre (W_x < 0) and ahead of the
        // line of centres in the spin direction (W_y > 0).
        assert!(l.wx < 0.0 && l.wy > 0.0, "[{k}] {l:?}");
        let attitude = (l.wy / -l.wx).atan();
        let expected = (std::f64::consts::PI * (1.0 - eps * eps).sqrt() / (4.0 * eps)).atan();
        assert_scalar("attitude angle", k, attitude, expected, 1e-13, 0.0);
        assert_scalar(
            "M_x = -B/2 W_y",
            k,
            l.mx,
            -0.5 * p.length * l.wy,
            1e-13,
            0.0,
        );
        assert_scalar("M_y = B/2 W_x", k, l.my, 0.5 * p.length * l.wx, 1e-13, 0.0);
        // End-point forces of an aligned journal: half the load at each end.
        let (fi, fj) = l.end_forces(p.length);
        assert_close("F_i = F_j = W/2", k, &fi, &fj, 1e-13, 0.0);
    }
}

/// `h_min = δ − max(|e_i|, |e_j|)`, in the loads and on the state.
#[test]
fn minimum_film_thickness() {
    let p = table2();
    let d = p.clearance;
    let rule = FilmRule::new(Accuracy::default().settings());
    let cases = [
        (0.3, 0.0, 0.0, 0.6, 0.4 * d),
        (-0.9, 0.0, 0.2, 0.1, 0.1 * d),
        (0.0, 0.0, 0.0, 0.0, d),
        (0.6, 0.8, 0.0, 0.0, 0.0), // |e_i| = δ: through the wall, checked on the state only
    ];
    for (k, &(xi, yi, xj, yj, expected)) in cases.iter().enumerate() {
        let s = BearingState {
            xi: xi * d,
            yi: yi * d,
            xj: xj * d,
            yj: yj * d,
            omega: 100.0,
            ..Default::default()
        };
        assert_scalar("state h_min", k, s.h_min(d), expected, 1e-12, 1e-20);
        if expected > 0.0 {
            let l = film_loads(&p, &s, &rule).unwrap();
            assert_scalar("loads h_min", k, l.h_min, expected, 1e-12, 1e-20);
        }
    }
}

fn with_convention(c: ClearanceConvention) -> BearingParams {
    BearingParams {
        clearance_convention: c,
        ..table2()
    }
}

/// The `S < 1` torque `6 r0² B μ |ω0| / φ`: Table 2 at 100 rad/s gives 0.0155 N·m with the
/// paper's `φ = δ/2r0`, 1.91 × Petroff's `2π μ ω0 r0³ B / δ` = 0.0081 N·m; Vogelpohl's
/// `ψ = δ/r0` gives 0.95 × Petroff (MODEL.md section 5).
#[test]
fn light_load_torque_against_petroff() {
    let omega = 100.0;
    let p = table2();
    let petroff = 2.0 * std::f64::consts::PI * p.viscosity * omega * p.radius.powi(3) * p.length
        / p.clearance;
    assert_scalar(
        "Petroff torque (MODEL.md figure)",
        0,
        petroff,
        0.0081,
        0.0,
        5e-5,
    );
    let paper = friction(&with_convention(ClearanceConvention::Paper), 1e-3, omega);
    let vogel = friction(
        &with_convention(ClearanceConvention::Vogelpohl),
        1e-3,
        omega,
    );
    assert!(paper.sommerfeld.unwrap() < 1.0 && vogel.sommerfeld.unwrap() < 1.0);
    assert_scalar("paper |M_z|", 1, paper.mz.abs(), 0.0155, 0.0, 5e-5);
    assert_scalar("paper exact", 2, paper.mz.abs(), 0.015488, 1e-12, 0.0);
    assert_scalar(
        "paper / Petroff",
        3,
        paper.mz.abs() / petroff,
        1.91,
        0.0,
        5e-3,
    );
    assert_scalar(
        "vogelpohl / Petroff",
        4,
        vogel.mz.abs() / petroff,
        0.955,
        0.0,
        5e-3,
    );
    assert_scalar(
        "paper = 2 vogelpohl",
        5,
        paper.mz,
        2.0 * vogel.mz,
        1e-14,
        0.0,
    );
    // Opposes the spin.
    assert!(paper.mz < 0.0);
    assert!(friction(&p, 1e-3, -omega).mz > 0.0);
}

/// Every branch of eqs. (10)-(11) with its closed form, both conventions.
#[test]
fn friction_law_cases() {
    for (k, conv) in [ClearanceConvention::Paper, ClearanceConvention::Vogelpohl]
        .into_iter()
        .enumerate()
    {
        let p = with_convention(conv);
        let phi = conv.relative_clearance(p.clearance, p.radius);
        let (r0, b, mu) = (p.radius, p.length, p.viscosity);
        let sommerfeld = |w: f64, om: f64| w / (2.0 * r0 * b) * phi * phi / (mu * om.abs());
        // S < 1: load-independent torque, f = 3φ/S.
        let (w, om) = (0.01, 200.0);
        let fr = friction(&p, w, om);
        let s = sommerfeld(w, om);
        assert!(s < 1.0);
        assert_scalar("S (S<1)", k, fr.sommerfeld.unwrap(), s, 1e-14, 0.0);
        assert_scalar(
            "f (S<1)",
            k,
            fr.coefficient.unwrap(),
            3.0 * phi / s,
            1e-14,
            0.0,
        );
        let torque = 6.0 * r0 * r0 * b * mu * om / phi;
        assert_scalar("M_z (S<1)", k, fr.mz, -torque, 1e-14, 0.0);
        // Consistency of the S < 1 form with M_z = f r0 |W|.
        assert_scalar(
            "f r0 W (S<1)",
            k,
            fr.mz.abs(),
            3.0 * phi / s * r0 * w,
            1e-13,
            0.0,
        );
        // S >= 1: f = 3φ/√S, M_z = −sign(ω) f r0 |W|.
        let (w, om) = (500.0, -5.0);
        let fr = friction(&p, w, om);
        let s = sommerfeld(w, om);
        assert!(s >= 1.0, "S = {s}");
        let f = 3.0 * phi / s.sqrt();
        assert_scalar("f (S>=1)", k, fr.coefficient.unwrap(), f, 1e-14, 0.0);
        assert_scalar("M_z (S>=1)", k, fr.mz, f * r0 * w, 1e-14, 0.0);
        // Continuous at S = 1 (both branches give f = 3φ).
        let om = 50.0;
        let w1 = 2.0 * r0 * b * mu * om / (phi * phi);
        let below = friction(&p, w1 * (1.0 - 1e-12), om);
        let above = friction(&p, w1 * (1.0 + 1e-12), om);
        assert_scalar("M_z continuous at S=1", k, below.mz, above.mz, 1e-9, 0.0);
        assert_scalar(
            "f = 3φ at S=1",
            k,
            above.coefficient.unwrap(),
            3.0 * phi,
            1e-9,
            0.0,
        );
        // W = 0, ω ≠ 0: S = 0, f null (infinite), M_z finite.
        let fr = friction(&p, 0.0, 100.0);
        assert_eq!(fr.sommerfeld, Some(0.0), "[{k}]");
        assert_eq!(fr.coefficient, None, "[{k}]");
        assert_scalar(
            "M_z (W=0)",
            k,
            fr.mz,
            -6.0 * r0 * r0 * b * mu * 100.0 / phi,
            1e-14,
            0.0,
        );
        // ω = 0, W > 0: S null (infinite), f = 0, M_z = 0.
        let fr = friction(&p, 10.0, 0.0);
        assert_eq!(
            (fr.sommerfeld, fr.coefficient, fr.mz),
            (None, Some(0.0), 0.0),
            "[{k}]"
        );
        // Both zero: S and f null, M_z = 0.
        let fr = friction(&p, 0.0, 0.0);
        assert_eq!(
            (fr.sommerfeld, fr.coefficient, fr.mz),
            (None, None, 0.0),
            "[{k}]"
        );
    }
}

/// Through the film loads: a centred journal (`W = 0`) still has a finite friction torque
/// and power loss, with `f` null; a squeeze-only state has `M_z = 0`.
#[test]
fn friction_in_the_loads() {
    let p = table2();
    let rule = FilmRule::new(Accuracy::default().settings());
    let centred = BearingState {
        omega: 100.0,
        ..Default::default()
    };
    let l = film_loads(&p, &centred, &rule).unwrap();
    assert_eq!([l.wx, l.wy, l.mx, l.my], [0.0; 4]);
    assert_eq!(l.friction_coefficient, None);
    assert_eq!(l.sommerfeld, Some(0.0));
    assert_scalar("M_z centred", 0, l.mz, -0.015488, 1e-12, 0.0);
    assert_scalar("power loss", 0, l.power_loss, 1.5488, 1e-12, 0.0);
    let squeeze = BearingState {
        xi: 1e-4,
        xj: 1e-4,
        vxi: 1e-3,
        vxj: 1e-3,
        ..Default::default()
    };
    let l = film_loads(&p, &squeeze, &rule).unwrap();
    assert!(l.wx < 0.0, "squeeze film resists the approach: {l:?}");
    assert_eq!((l.mz, l.power_loss, l.sommerfeld), (0.0, 0.0, None));
    assert_eq!(l.friction_coefficient, Some(0.0));
    // Heavily loaded (S >= 1 with the paper's φ): f r0 |W| law.
    let (state, ocv) = ocvirk_model(&p, 0.98, 20.0);
    let l = film_loads(&p, &state, &rule).unwrap();
    let w = ocv[0].hypot(ocv[1]);
    let s = l.sommerfeld.unwrap();
    assert!(s >= 1.0, "S = {s}");
    let phi = p.clearance / (2.0 * p.radius);
    let f = 3.0 * phi / s.sqrt();
    assert_scalar(
        "f at eps 0.98",
        0,
        l.friction_coefficient.unwrap(),
        f,
        1e-12,
        0.0,
    );
    assert_scalar("M_z at eps 0.98", 0, l.mz, -f * p.radius * w, 1e-12, 0.0);
}

/// The friction law with its bearing constants worked out once per bearing
/// (`FrictionConstants`, issue 28's thirteenth pass) gives bit for bit the law written
/// out per state in the order MODEL.md section 5 states it (`|W| / (2 r0 B) · φ · φ /
/// (μ |ω0|)`, `6 · r0 · r0 · B · μ · |ω0| / φ`, `3 φ / S`, `3 φ / √S · r0 · |W|`): both
/// branches, both conventions, both spin signs, zero and subnormal spins, zero loads. A
/// regrouped product (e.g. `φ²` formed once) differs in the last bit for some of these
/// and fails.
#[test]
fn friction_constants_keep_the_per_state_arithmetic_bit_for_bit() {
    let mut index = 0;
    for conv in [ClearanceConvention::Paper, ClearanceConvention::Vogelpohl] {
        for (radius, length, clearance, viscosity) in [
            (0.02, 0.02, 3e-4, 0.0242),
            (0.0317, 0.0123, 1.7e-4, 0.0121),
            (0.05, 0.1, 4.5e-4, 0.0484),
        ] {
            let p = BearingParams {
                radius,
                length,
                clearance,
                viscosity,
                clearance_convention: conv,
                ..table2()
            };
            let phi = conv.relative_clearance(clearance, radius);
            for w in [0.0, 1e-318, 0.013, 7.3, 512.0, 9.1e4] {
                for om in [0.0, 1e-320, -3.7e-7, 1.3, -97.1, 2900.0] {
                    let fr = friction(&p, w, om);
                    let expected = if om == 0.0 {
                        (0.0, if w > 0.0 { Some(0.0) } else { None }, None)
                    } else {
                        let den = viscosity * om.abs();
                        let s = if den >= f64::MIN_POSITIVE {
                            w / (2.0 * radius * length) * phi * phi / den
                        } else {
                            w / (2.0 * radius * length) * phi * phi / viscosity / om.abs()
                        };
                        let (f, mz_abs) = if s < 1.0 {
                            let torque =
                                6.0 * radius * radius * length * viscosity * om.abs() / phi;
                            let f = 3.0 * phi / s;
                            ((s > 0.0 && f.is_finite()).then_some(f), torque)
                        } else {
                            let f = 3.0 * phi / s.sqrt();
                            (Some(f), f * radius * w)
                        };
                        (-om.signum() * mz_abs, f, s.is_finite().then_some(s))
                    };
                    let bits = |v: Option<f64>| v.map(f64::to_bits);
                    assert!(
                        fr.mz.to_bits() == expected.0.to_bits()
                            && bits(fr.coefficient) == bits(expected.1)
                            && bits(fr.sommerfeld) == bits(expected.2),
                        "case {index} ({conv:?}, r0 {radius}, |W| {w}, ω0 {om}): got (mz, f, S) = \
                         ({:e}, {:?}, {:?}), expected ({:e}, {:?}, {:?}) bit for bit",
                        fr.mz,
                        fr.coefficient,
                        fr.sommerfeld,
                        expected.0,
                        expected.1,
                        expected.2
                    );
                    index += 1;
                }
            }
        }
    }
}
