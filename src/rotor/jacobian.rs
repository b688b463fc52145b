//! The rotor's Jacobian from its bearings' own inputs (issue 28, tenth pass).
//!
//! A short-film bearing's load vector `L = (W_x, W_y, M_x, M_y)` depends on its state only
//! through the eight film coordinates the rule sees ([`film_coordinates`], as
//! [`crate::bearing::pack_state`] forms them): the end-centre eccentricities `e = (x_i,
//! y_i, x_j, y_j) / δ` and the rates `r = (ω e_x − 2 v_y / δ, ω e_y + 2 v_x / δ)` at both
//! ends (1/s). Two relations give two of `∂L/∂(e, r)`'s eight columns from the others and
//! `L` itself:
//!
//! - **homogeneity**: `L` is homogeneous of degree 1 in `r` (the rule integrates `r / max
//!   |r|` and multiplies back by `max |r|`), so `Σ_k r_k ∂L/∂r_k = L`;
//! - **rotation**: the bore is round, so turning every in-plane vector (both ends' `e` and
//!   `r`) by an angle turns the forces and the moments `(M_x, M_y)` by it:
//!   `Σ_k t_k ∂L/∂p_k = (−W_y, W_x, −M_y, M_x)` with `t = (−e_1, e_0, −e_3, e_2, −r_1, r_0,
//!   −r_3, r_2)`.
//!
//! So six probes a bearing (four eccentricities at fixed rates, the rates of one end) give
//! the whole `4 x 8` film Jacobian; the other end's two rate columns solve the two
//! relations (a `2 x 2` system with determinant `r_a² + r_b²`, the end with the larger
//! rate). The rotor's Jacobian follows by forward differences of the rotor's own
//! right-hand side with these loads linearised about the base state: kinematics, end
//! forces, friction torque, contact and the rigid-body derivative are evaluated exactly
//! (cheap closed forms), only the film integrals are linear. 6 film evaluations a bearing
//! (7 when the base state's loads are not at hand) instead of the 10 rotor columns' 10.
//!
//! The relations hold for the exact film integrals; the rule meets them to its
//! tolerance, which is all a Jacobian that steers Newton needs.

use crate::bearing::BearingState;

/// Film coordinates of a bearing state: `[e_0, e_1, e_2, e_3, r_0, r_1, r_2, r_3]`
/// (eccentricities, 1; rates, 1/s), with [`crate::bearing::pack_state`]'s arithmetic
/// before its normalisation.
#[inline]
pub(crate) fn film_coordinates(s: &BearingState, clearance: f64) -> [f64; 8] {
    let d = clearance;
    let w = s.omega;
    let e = [s.xi / d, s.yi / d, s.xj / d, s.yj / d];
    [
        e[0],
        e[1],
        e[2],
        e[3],
        w * e[0] - 2.0 * s.vyi / d,
        w * e[1] + 2.0 * s.vxi / d,
        w * e[2] - 2.0 * s.vyj / d,
        w * e[3] + 2.0 * s.vxj / d,
    ]
}

/// Probes of one bearing: the states to evaluate and which film coordinates they move.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Probes {
    /// The probe states.
    pub states: [BearingState; 6],
    /// The film coordinate each probe moves (`0..8`).
    pub coordinate: [usize; 6],
    /// The step each realised in its coordinate.
    pub step: [f64; 6],
    /// The base state's film coordinates.
    pub base: [f64; 8],
    /// The rate pair derived from the relations: `4 + 0` and `4 + 1` (end `i`) or `4 + 2`
    /// and `4 + 3` (end `j`).
    pub derived: usize,
}

/// The six probes of base state `s0` (clearance `clearance`, m), or `None` where the
/// film has no rate at all (`max |r| = 0`: no load, no homogeneity to use) or the
/// coordinates are not finite.
pub(crate) fn probes(s0: &BearingState, clearance: f64) -> Option<Probes> {
    let d = clearance;
    let p0 = film_coordinates(s0, d);
    if !p0.iter().all(|v| v.is_finite()) {
        return None;
    }
    let r = &p0[4..];
    let rmax = r.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if rmax <= 0.0 {
        return None;
    }
    let h = f64::EPSILON.sqrt();
    // Derive the rate pair of the end with the larger rate (the relations' 2 x 2 system
    // is then far from singular); probe the other end's.
    let derived = if r[0] * r[0] + r[1] * r[1] >= r[2] * r[2] + r[3] * r[3] {
        0
    } else {
        2
    };
    let probed = 2 - derived;
    let w = s0.omega;
    let mut states = [*s0; 6];
    let mut coordinate = [0; 6];
    let mut step = [0.0; 6];
    for k in 0..4 {
        // Eccentricities move toward the bore axis (a probe never crosses the wall), by
        // √ε of the unit ratio (the rotor's own columns moved √ε·δ), at fixed rates: the
        // rate's `ω e` term is balanced by the velocity.
        let de = if p0[k] > 0.0 { -h } else { h };
        let s = &mut states[k];
        match k {
            0 => {
                s.xi += d * de;
                s.vyi += 0.5 * w * d * de;
            }
            1 => {
                s.yi += d * de;
                s.vxi -= 0.5 * w * d * de;
            }
            2 => {
                s.xj += d * de;
                s.vyj += 0.5 * w * d * de;
            }
            _ => {
                s.yj += d * de;
                s.vxj -= 0.5 * w * d * de;
            }
        }
        coordinate[k] = k;
    }
    for (n, k) in [probed, probed + 1].into_iter().enumerate() {
        let dr = h * rmax;
        let s = &mut states[4 + n];
        match k {
            0 => s.vyi -= 0.5 * d * dr,
            1 => s.vxi += 0.5 * d * dr,
            2 => s.vyj -= 0.5 * d * dr,
            _ => s.vxj += 0.5 * d * dr,
        }
        coordinate[4 + n] = 4 + k;
    }
    for n in 0..6 {
        let c = coordinate[n];
        // The step as the rule sees it (after the rounding of the state's arithmetic).
        step[n] = film_coordinates(&states[n], d)[c] - p0[c];
        if step[n] == 0.0 || !step[n].is_finite() {
            return None;
        }
    }
    Some(Probes {
        states,
        coordinate,
        step,
        base: p0,
        derived,
    })
}

/// The load vector `(W_x, W_y, M_x, M_y)` of loads `l`.
#[inline]
pub(crate) fn load_vector(l: &crate::bearing::Loads) -> [f64; 4] {
    [l.wx, l.wy, l.mx, l.my]
}

/// `∂L/∂p` (`4 x 8`, rows `W_x, W_y, M_x, M_y`, columns the film coordinates) from the
/// base loads `l0` and the probes' loads `lk` (in [`Probes`]' order).
pub(crate) fn film_jacobian(pr: &Probes, l0: [f64; 4], lk: &[[f64; 4]; 6]) -> [[f64; 8]; 4] {
    let mut j = [[0.0; 8]; 4];
    for (n, ln) in lk.iter().enumerate() {
        let c = pr.coordinate[n];
        for o in 0..4 {
            j[o][c] = (ln[o] - l0[o]) / pr.step[n];
        }
    }
    let p = &pr.base;
    // Rotation generator in film coordinates, and its action on the loads.
    let t = [-p[1], p[0], -p[3], p[2], -p[5], p[4], -p[7], p[6]];
    let rl = [-l0[1], l0[0], -l0[3], l0[2]];
    let (a, b) = (4 + pr.derived, 5 + pr.derived);
    let (c1, c2) = if pr.derived == 0 { (6, 7) } else { (4, 5) };
    let (ra, rb) = (p[a], p[b]);
    let n2 = ra * ra + rb * rb;
    for o in 0..4 {
        // Homogeneity: r_a J_a + r_b J_b = L − Σ_probed r_k J_k.
        let hom = l0[o] - p[c1] * j[o][c1] - p[c2] * j[o][c2];
        // Rotation: −r_b J_a + r_a J_b = R L − Σ_probed t_k J_k.
        let mut rot = rl[o] - t[c1] * j[o][c1] - t[c2] * j[o][c2];
        for k in 0..4 {
            rot -= t[k] * j[o][k];
        }
        j[o][a] = (ra * hom - rb * rot) / n2;
        j[o][b] = (rb * hom + ra * rot) / n2;
    }
    j
}

/// The load vector of state `s` from the linear model about the probes' base:
/// `l0 + J (p(s) − p0)`.
#[inline]
pub(crate) fn linear_loads(
    pr: &Probes,
    j: &[[f64; 8]; 4],
    l0: [f64; 4],
    s: &BearingState,
    clearance: f64,
) -> [f64; 4] {
    let p = film_coordinates(s, clearance);
    let mut l = l0;
    for c in 0..8 {
        let dp = p[c] - pr.base[c];
        if dp != 0.0 {
            for o in 0..4 {
                l[o] += j[o][c] * dp;
            }
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bearing::{film_loads, Accuracy, BearingParams, FilmRule};

    fn params() -> BearingParams {
        BearingParams {
            radius: 0.02,
            length: 0.02,
            clearance: 3e-4,
            viscosity: 0.0242,
            ..BearingParams::paper_table2()
        }
    }

    fn loads(rule: &FilmRule, s: &BearingState) -> [f64; 4] {
        load_vector(&film_loads(&params(), s, rule).expect("a valid state"))
    }

    /// The derived columns against central differences of the rule at the 1e-12 level,
    /// on tilted, squeezing states with either end the faster.
    #[test]
    fn the_derived_rate_columns_match_differences_of_the_rule() {
        let rule = FilmRule::new(Accuracy::new(1e-12).unwrap().settings());
        let d = params().clearance;
        let states = [
            BearingState {
                xi: 0.4 * d,
                yi: -0.3 * d,
                xj: 0.55 * d,
                yj: -0.1 * d,
                vxi: 0.01,
                vyi: -0.02,
                vxj: 0.005,
                vyj: 0.015,
                omega: 100.0,
            },
            BearingState {
                xi: -0.2 * d,
                yi: 0.7 * d,
                xj: 0.1 * d,
                yj: 0.6 * d,
                vxi: -0.03,
                vyi: 0.01,
                vxj: 0.04,
                vyj: -0.02,
                omega: 250.0,
            },
        ];
        for s0 in &states {
            let pr = probes(s0, d).expect("probes");
            let l0 = loads(&rule, s0);
            let lk: [[f64; 4]; 6] = std::array::from_fn(|n| loads(&rule, &pr.states[n]));
            let j = film_jacobian(&pr, l0, &lk);
            let scale = l0.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            // Central differences in each rate coordinate (velocity moves only).
            for k in 0..4 {
                let rmax = pr.base[4..].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                let dr = 1e-5 * rmax;
                let mv = |sign: f64| {
                    let mut s = *s0;
                    match k {
                        0 => s.vyi -= sign * 0.5 * d * dr,
                        1 => s.vxi += sign * 0.5 * d * dr,
                        2 => s.vyj -= sign * 0.5 * d * dr,
                        _ => s.vxj += sign * 0.5 * d * dr,
                    }
                    s
                };
                let (lp, lm) = (loads(&rule, &mv(1.0)), loads(&rule, &mv(-1.0)));
                for o in 0..4 {
                    let fd = (lp[o] - lm[o]) / (2.0 * dr);
                    let err = (j[o][4 + k] - fd).abs() * rmax / scale;
                    assert!(
                        err < 1e-5,
                        "rate column {k}, row {o}: {} against {fd} (relative {err:.2e}; \
                         derived pair {})",
                        j[o][4 + k],
                        pr.derived
                    );
                }
            }
            // And the linear model reproduces a nearby state's loads to second order.
            let mut s1 = *s0;
            s1.xi += 1e-6 * d;
            s1.vyj += 1e-6 * d * 100.0;
            let lin = linear_loads(&pr, &j, l0, &s1, d);
            let exact = loads(&rule, &s1);
            for o in 0..4 {
                let err = (lin[o] - exact[o]).abs() / scale;
                assert!(err < 1e-9, "linear model row {o}: relative {err:.2e}");
            }
        }
    }
}
