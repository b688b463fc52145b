//! Film friction and flow (issue 24 item 1; docs/finite-film.md "Friction and flow"): the
//! friction torque from the shear stress over the film, the friction variable `(r0/δ) f`,
//! the side flow at both ends and the flow the film is fed with, from the short-bearing
//! closed forms (this file) or from the finite film's converged pressure field
//! ([`crate::bearing::finite::finite_flow`]).
//!
//! **Shear stress.** On the journal surface, `τ = μ ω0 r0 / h + (h / 2r0) ∂p/∂θ` (Couette
//! plus the pressure-gradient term of the Reynolds velocity profile), so the torque about
//! `+z` on the journal is
//!
//! ```text
//! M_z = −∬ (μ ω0 r0³ / h + (r0/2) h ∂p/∂θ) dθ dz.
//! ```
//!
//! **The cavitated zone** carries the Couette shear of a full film (the "full-film shear
//! assumption" of the classical tables, Butenschoen 1976, and of Petroff's law): the
//! Couette term is integrated over the whole 360°, the pressure term only where `p > 0`
//! (it vanishes elsewhere). Over a 360° film the Couette integral depends on the geometry
//! alone, `∬ dθ dz / h = 2π ∫ dz / (δ √(1 − ε(z)²))`, evaluated in closed form for aligned
//! and tilted journals ([`couette_integral`]). Integrating the pressure term by parts
//! (`h` periodic, `p` continuous) gives `(r0/2) ∬ p ∂h/∂θ`, which for the journal's linear
//! axis is the load's moment arm: `−½ Σ_ends (e × F)_z` with `F_i, F_j` the end-point
//! forces of MODEL.md section 4 — exact for any pressure field, and what the short film
//! uses. The finite film sums `h ∂p/∂θ` over its grid directly.
//!
//! **Power loss** is `−M_z ω0` (the power the spin does against the film), W.
//!
//! **Side flow** at an end is the pressure flow `∮ h³/(12μ) |∂p/∂z| r0 dθ` out of that end
//! face. Short film: `∂p/∂z = −3μB R/h³ sin(θ − α)` at `z = 0` with `R` the amplitude of
//! the bracket of MODEL.md section 3 at that end, so `Q_end = r0 B R_end / 2` (the
//! Couette/Poiseuille balance of the loaded half-turn: the aligned journal's
//! `Q = ε δ ω0 r0 B` in all).
//!
//! **Inlet flow** is the oil the film must be fed with: the flow into the pressure (full
//! film) zone less the flow that leaves it at the rupture boundary and is carried on through
//! the ruptured zone (at constant flow, as streamers) back to the inlet. Steady, it equals
//! the side flow; with squeeze it is side flow + the rate at which the pressure zone's
//! volume grows. Short film: per slice, the Couette flow `ω0 r0 h/2` entering the loaded
//! half-turn at its start minus that leaving at its end, `ω0 r0 (e · û)` per unit length
//! with `û = (cos α, sin α)`, integrated over `z` in closed form. For a tilted journal the
//! slice model is not mass-conservative (its slices ignore the axial change of `ε`), so its
//! inlet flow and side flow differ there; for an aligned journal they agree exactly.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

use super::{BearingParams, BearingState};

/// Which law produced a friction number (JSON `"friction_model"` in outputs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrictionLaw {
    /// The paper's Sommerfeld-number law, eqs. 10-11 (MODEL.md section 5), with the
    /// bearing's `clearance_convention`. Default for `mz`, `friction_coefficient` and
    /// `power_loss`.
    #[default]
    Paper,
    /// The shear stress integrated over the film ([`FilmFlow`]).
    Film,
}

impl FrictionLaw {
    /// Name written into outputs.
    pub fn name(self) -> &'static str {
        match self {
            FrictionLaw::Paper => "paper",
            FrictionLaw::Film => "film",
        }
    }
}

/// Friction and flow of the film for one state (SI; JSON object `"film"` of a load).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FilmFlow {
    /// Friction torque on the journal about `+z` from the shear stress over the film
    /// (full-film Couette shear over 360° plus the pressure-gradient term), N·m; opposes
    /// the spin in steady running.
    pub friction_torque_nm: f64,
    /// Friction power loss `−M_z ω0`, W.
    pub power_loss_w: f64,
    /// Film friction coefficient `f = |M_z| / (r0 |W|)`; `null` where `|W| = 0`.
    pub friction_coefficient: Option<f64>,
    /// Friction variable `(r0/δ) f = |M_z| / (δ |W|)` of the classical tables; `null` where
    /// `|W| = 0`.
    pub friction_variable: Option<f64>,
    /// Side flow out of the end face `z = 0`, m³/s.
    pub side_flow_i_m3_per_s: f64,
    /// Side flow out of the end face `z = B`, m³/s.
    pub side_flow_j_m3_per_s: f64,
    /// Side flow out of both ends, m³/s.
    pub side_flow_m3_per_s: f64,
    /// Oil the film is fed with (finite film: at its held nodes, the `max_film` inlet line
    /// or grooves; short film: the Couette balance of the loaded arcs), m³/s.
    pub inlet_flow_m3_per_s: f64,
}

/// `∫₀¹ dζ / √(1 − |a + b ζ|²)` for `|a + bζ| < 1` on `[0, 1]` (2-vectors `a`, `b`), in
/// closed form: with `A = |b|²` and `q = 1 − (a × b)²/A` (one minus the squared distance
/// of the line from the origin), `u(ζ) = (Aζ + a·b)/√(A q)` and the integral is
/// `(asin u(1) − asin u(0))/√A`, the difference taken without cancellation.
pub fn inverse_film_integral(a: [f64; 2], b: [f64; 2]) -> f64 {
    let big_a = b[0] * b[0] + b[1] * b[1];
    let aa = a[0] * a[0] + a[1] * a[1];
    if big_a == 0.0 {
        return 1.0 / (1.0 - aa).sqrt();
    }
    let cross = a[0] * b[1] - a[1] * b[0];
    let dot = a[0] * b[0] + a[1] * b[1];
    let q = (1.0 - cross * cross / big_a).max(f64::MIN_POSITIVE);
    let root = (big_a * q).sqrt();
    let u1 = (dot / root).clamp(-1.0, 1.0);
    let u2 = ((big_a + dot) / root).clamp(-1.0, 1.0);
    let (c1, c2) = ((1.0 - u1 * u1).sqrt(), (1.0 - u2 * u2).sqrt());
    // sin(asin u2 − asin u1) = u2 c1 − u1 c2 = (u2² − u1²)/(u2 c1 + u1 c2): the second
    // form where the first cancels (u1 ≈ u2), with u2 − u1 = √(A/q) exactly.
    let direct = u2 * c1 - u1 * c2;
    let sum = u2 * c1 + u1 * c2;
    let sine = if sum.abs() > direct.abs() {
        (big_a / q).sqrt() * (u2 + u1) / sum
    } else {
        direct
    };
    sine.atan2(c1 * c2 + u1 * u2) / big_a.sqrt()
}

/// Couette integral of the full 360° film, `∬ dθ dζ / H` (`H = h/δ`, `ζ = z/B`), in
/// closed form: `2π ∫₀¹ dζ / √(1 − ε(ζ)²)`. Petroff: `2π` for the centred journal.
pub fn couette_integral(params: &BearingParams, state: &BearingState) -> f64 {
    let d = params.clearance;
    let a = [state.xi / d, state.yi / d];
    let b = [(state.xj - state.xi) / d, (state.yj - state.yi) / d];
    2.0 * PI * inverse_film_integral(a, b)
}

/// The pressure part of the film torque, `(r0/2) ∬ p ∂h/∂θ dθ dz = −½ Σ_ends (e × F)_z`
/// (N·m), from the film's loads `W = (wx, wy)` and `M = (mx, my)` (exact for any pressure
/// field, see the module docs).
pub fn pressure_torque(
    params: &BearingParams,
    state: &BearingState,
    w: [f64; 2],
    m: [f64; 2],
) -> f64 {
    let b = params.length;
    0.5 * (-state.xi * w[1]
        + state.yi * w[0]
        + ((state.xj - state.xi) * m[0] + (state.yj - state.yi) * m[1]) / b)
}

/// The Couette part of the film torque, `−μ ω0 r0³ B/δ · ∬ dθ dζ / H`, N·m.
pub fn couette_torque(params: &BearingParams, state: &BearingState) -> f64 {
    let r = params.radius;
    -params.viscosity * state.omega * r * r * r * params.length / params.clearance
        * couette_integral(params, state)
}

/// Friction outputs from the film torque `mz` (N·m) for a film force `|W|` (N); flows zero.
pub fn friction_outputs(params: &BearingParams, omega: f64, mz: f64, w_abs: f64) -> FilmFlow {
    let ratio = |len: f64| {
        let v = mz.abs() / (len * w_abs);
        (w_abs > 0.0 && v.is_finite()).then_some(v)
    };
    FilmFlow {
        friction_torque_nm: mz,
        power_loss_w: -mz * omega,
        friction_coefficient: ratio(params.radius),
        friction_variable: ratio(params.clearance),
        ..FilmFlow::default()
    }
}

/// Bracket vector of MODEL.md section 3 at an end: `(ω0 x − 2ẏ, ω0 y + 2ẋ)`, m/s; its
/// length is the amplitude `R` of the slice's bracket `R sin(θ − α)`.
fn bracket(omega: f64, x: f64, y: f64, vx: f64, vy: f64) -> [f64; 2] {
    [omega * x - 2.0 * vy, omega * y + 2.0 * vx]
}

/// Eight-point Gauss–Legendre nodes on [0, 1] (abscissae `(1 ± x_k)/2`) and weights.
const GL8_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL8_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// `∫₀¹ e(ζ) · c(ζ) / |c(ζ)| dζ` for linear 2-vectors `e = e0 + e1 ζ`, `c = c0 + c1 ζ`
/// (0 where `c = 0`). Closed form in `t = ζ + (c0·c1)/|c1|²`, where `|c| = |c1| √(t² + k²)`
/// and `k` is the line's distance from the origin over `|c1|`; when the nearest zero of
/// `c` (complex `t = ±ik`) is more than 2 from the interval's centre, where the closed
/// form's terms cancel, 8-point Gauss–Legendre (error below 1e-14 there).
pub fn projected_integral(e0: [f64; 2], e1: [f64; 2], c0: [f64; 2], c1: [f64; 2]) -> f64 {
    let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
    let at = |u: [f64; 2], v: [f64; 2], z: f64| [u[0] + v[0] * z, u[1] + v[1] * z];
    let big_a = dot(c1, c1);
    let integrand = |z: f64| {
        let c = at(c0, c1, z);
        let n = c[0].hypot(c[1]);
        if n > 0.0 {
            dot(at(e0, e1, z), c) / n
        } else {
            0.0
        }
    };
    if big_a == 0.0 {
        return integrand(0.5);
    }
    let t0 = dot(c0, c1) / big_a;
    let k = (c0[0] * c1[1] - c0[1] * c1[0]).abs() / big_a;
    if (0.5 + t0).hypot(k) > 2.0 {
        return GL8_X
            .iter()
            .zip(GL8_W)
            .map(|(&x, w)| 0.5 * w * (integrand(0.5 * (1.0 - x)) + integrand(0.5 * (1.0 + x))))
            .sum();
    }
    // Expansion of N = e·c about t = 0 (ζ = −t0, the point nearest the origin).
    let cn = at(c0, c1, -t0);
    let en = at(e0, e1, -t0);
    let n0 = dot(en, cn);
    let n1 = dot(e1, cn) + dot(en, c1);
    let n2 = dot(e1, c1);
    let f = |t: f64| {
        let s = t.hypot(k);
        let log_term = if k > 0.0 {
            (n0 - 0.5 * n2 * k * k) * (t / k).asinh()
        } else {
            // k = 0: c vanishes at t = 0, so n0 = 0 and the term is absent.
            0.0
        };
        log_term + n1 * s + 0.5 * n2 * t * s
    };
    (f(1.0 + t0) - f(t0)) / big_a.sqrt()
}

/// Side flows at the two ends and the inlet flow of the short (Ocvirk) film, m³/s
/// (module docs).
pub fn short_flows(params: &BearingParams, state: &BearingState) -> ([f64; 2], f64) {
    let (r, b, w) = (params.radius, params.length, state.omega);
    let ci = bracket(w, state.xi, state.yi, state.vxi, state.vyi);
    let cj = bracket(w, state.xj, state.yj, state.vxj, state.vyj);
    let side = [
        0.5 * r * b * ci[0].hypot(ci[1]),
        0.5 * r * b * cj[0].hypot(cj[1]),
    ];
    let inlet = if w == 0.0 {
        0.0
    } else {
        let e0 = [state.xi, state.yi];
        let e1 = [state.xj - state.xi, state.yj - state.yi];
        let c1 = [cj[0] - ci[0], cj[1] - ci[1]];
        w * r * b * projected_integral(e0, e1, ci, c1)
    };
    (side, inlet)
}

/// Film friction and flow of a state whose film loads are `W = (wx, wy)`, `M = (mx, my)`,
/// with the short-film flows: the full-film Couette torque plus the pressure torque
/// `−½ Σ (e × F)_z`. What [`crate::bearing::finish_loads`] fills in; the finite film
/// replaces the flows and the pressure torque with its grid's
/// ([`crate::bearing::finite::finite_flow`]).
pub fn short_film_flow(
    params: &BearingParams,
    state: &BearingState,
    w: [f64; 2],
    m: [f64; 2],
) -> FilmFlow {
    let mz = couette_torque(params, state) + pressure_torque(params, state, w, m);
    let (side, inlet) = short_flows(params, state);
    FilmFlow {
        side_flow_i_m3_per_s: side[0],
        side_flow_j_m3_per_s: side[1],
        side_flow_m3_per_s: side[0] + side[1],
        inlet_flow_m3_per_s: inlet,
        ..friction_outputs(params, state.omega, mz, w[0].hypot(w[1]))
    }
}

/// Loads of one state with the bearing's own film model (`short`, `finite`, or `auto`
/// resolved per state), on the calling thread (finite film: a cold solve), with the film
/// friction and flow in [`Loads::film`](super::Loads). The entry point for callers that
/// need friction power and flow of single states (e.g. at a trial viscosity: set
/// `params.viscosity` and call again).
pub fn bearing_loads(
    params: &BearingParams,
    state: &BearingState,
    rule: &super::FilmRule,
) -> Result<super::Loads, super::StateFault> {
    match super::finite::effective_model(params, state) {
        super::FilmModel::Finite => {
            super::finite::finite_solution(params, state, &params.finite, false).map(|s| s.loads)
        }
        _ => super::film_loads(params, state, rule),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Composite Simpson reference for a smooth integrand on [0, 1].
    fn simpson(f: impl Fn(f64) -> f64, n: usize) -> f64 {
        let h = 1.0 / n as f64;
        let mut s = f(0.0) + f(1.0);
        for i in 1..n {
            s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    fn close(what: &str, got: f64, want: f64, tol: f64) {
        let err = (got - want).abs() / want.abs().max(1e-300);
        assert!(
            err <= tol,
            "{what}: actual {got:e}, expected {want:e}, relative error {err:e} > tolerance {tol:e}"
        );
    }

    #[test]
    fn the_inverse_film_integral_matches_quadrature_aligned_tilted_and_nearly_aligned() {
        let cases: [([f64; 2], [f64; 2]); 7] = [
            ([0.5, 0.0], [0.0, 0.0]),
            ([0.3, -0.2], [0.4, 0.3]),
            ([-0.7, 0.1], [1.2, 0.5]),
            ([0.9, 0.0], [-1.8, 0.0]),
            ([0.6, 0.2], [1e-9, -2e-9]),
            ([0.2, 0.9], [1e-4, -0.3]),
            ([0.0, 0.0], [0.3, 0.4]),
        ];
        for (n, (a, b)) in cases.iter().enumerate() {
            let f = |z: f64| {
                let (x, y) = (a[0] + b[0] * z, a[1] + b[1] * z);
                1.0 / (1.0 - x * x - y * y).sqrt()
            };
            close(
                &format!("case {n}"),
                inverse_film_integral(*a, *b),
                simpson(f, 20_000),
                1e-11,
            );
        }
    }

    #[test]
    fn the_projected_integral_matches_quadrature_across_its_branches() {
        // (e0, e1, c0, c1): constant c, far zero (Gauss-Legendre), near zero, a zero
        // inside the interval (kink), a zero at an end.
        type Case = ([f64; 2], [f64; 2], [f64; 2], [f64; 2]);
        let cases: [Case; 6] = [
            ([1.0, 0.5], [0.2, 0.0], [3.0, -1.0], [0.0, 0.0]),
            ([1.0, 0.5], [0.2, 0.1], [3.0, -1.0], [0.1, 0.05]),
            ([0.4, -0.3], [0.5, 0.9], [1.0, 0.2], [-1.5, 0.3]),
            ([0.7, 0.1], [-0.2, 0.4], [-0.5, 1.0], [1.0, -2.0]),
            ([0.3, 0.3], [0.1, -0.6], [0.2, 0.3], [-0.2, -0.3]),
            ([0.3, 0.3], [0.1, -0.6], [0.2, 0.3], [-0.2, -0.31]),
        ];
        for (n, (e0, e1, c0, c1)) in cases.iter().enumerate() {
            let f = |z: f64| {
                // Inside the interval: case 4's c vanishes at its end, where the integrand
                // has a limit (the direction of −c1), not the value 0.
                let z = z.clamp(1e-12, 1.0 - 1e-12);
                let c = [c0[0] + c1[0] * z, c0[1] + c1[1] * z];
                let e = [e0[0] + e1[0] * z, e0[1] + e1[1] * z];
                let m = c[0].hypot(c[1]);
                if m > 0.0 {
                    (e[0] * c[0] + e[1] * c[1]) / m
                } else {
                    0.0
                }
            };
            // Split at the kink (case 3: c = 0 at ζ = 0.5) for the reference.
            let reference =
                simpson(|z| 0.5 * f(0.5 * z), 20_000) + simpson(|z| 0.5 * f(0.5 + 0.5 * z), 20_000);
            close(
                &format!("case {n}"),
                projected_integral(*e0, *e1, *c0, *c1),
                reference,
                1e-7,
            );
        }
    }

    #[test]
    fn petroff_at_the_centre_and_ocvirk_side_flow_aligned() {
        let p = BearingParams::paper_table2();
        let s = BearingState {
            omega: 100.0,
            ..Default::default()
        };
        let f = short_film_flow(&p, &s, [0.0; 2], [0.0; 2]);
        let petroff = 2.0 * PI * p.viscosity * p.radius.powi(3) * p.length * 100.0 / p.clearance;
        close("Petroff torque", -f.friction_torque_nm, petroff, 1e-14);
        close("Petroff power", f.power_loss_w, petroff * 100.0, 1e-14);
        assert_eq!(f.friction_coefficient, None);
        assert_eq!(f.side_flow_m3_per_s, 0.0);
        let eps = 0.6;
        let s = BearingState {
            xi: eps * p.clearance,
            xj: eps * p.clearance,
            omega: 100.0,
            ..Default::default()
        };
        let f = short_film_flow(&p, &s, [0.0; 2], [0.0; 2]);
        let q = eps * p.clearance * 100.0 * p.radius * p.length;
        close("aligned side flow", f.side_flow_m3_per_s, q, 1e-14);
        close("aligned inlet flow", f.inlet_flow_m3_per_s, q, 1e-14);
    }
}
