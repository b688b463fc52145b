//! Static equilibrium of one bearing under a load at a speed: the aligned journal position
//! whose film force balances the applied load. Start: the short-bearing closed form (exact
//! for an aligned journal in this model, MODEL.md section 7); then Newton iterations on
//! the batched film loads polish it to rounding.

use super::coefficients::{
    aligned_state, coefficients_batch, load_noise, pin_grid, CoefficientJob, DiffOptions,
};
use super::StabilityError;
use crate::backend::LoadEvaluator;
use crate::bearing::{BearingParams, BearingState, Loads};

/// Equilibrium of one bearing.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BearingEquilibrium {
    /// Journal centre (mid-plane), x, m.
    pub x: f64,
    /// Journal centre (mid-plane), y, m.
    pub y: f64,
    /// `ε = |e| / δ`.
    pub eccentricity_ratio: f64,
    /// Angle from the applied load's direction to the journal's displacement, rad,
    /// positive about `+z` (for `ω > 0` it lies in `(0, π/2]`: the journal moves ahead of
    /// the load in the spin direction). Zero for a zero load.
    pub attitude_angle: f64,
    /// Film loads there (force balances the applied load).
    pub loads: Loads,
    /// `|W_film + P| / |P|` after the last iteration (0 for a zero load).
    pub residual: f64,
    /// Newton iterations after the closed-form start.
    pub iterations: u32,
}

/// Ocvirk's short-bearing load capacity over `μ r0 B³ |ω| / δ²` at eccentricity `ε`
/// (MODEL.md section 7): `ε √(16 ε² + π² (1 − ε²)) / (4 (1 − ε²)²)`.
pub fn ocvirk_capacity(eps: f64) -> f64 {
    let pi2 = std::f64::consts::PI * std::f64::consts::PI;
    let q = 1.0 - eps * eps;
    eps * (16.0 * eps * eps + pi2 * q).sqrt() / (4.0 * q * q)
}

/// `ε` at which the aligned short bearing carries the dimensionless load `w` (bisection;
/// the capacity rises monotonically from 0 to infinity on `[0, 1)`).
pub fn ocvirk_eccentricity(w: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    // 200 halvings reach the last bit of [0, 1).
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if ocvirk_capacity(mid) < w {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

/// Closed-form aligned position `(x, y)` where the film carries `load` (N, applied to the
/// journal) at spin `omega`: film force `W_r = −a|ω| ε²/(1−ε²)²` along the line of
/// centres and `W_t = a ω π ε / (4 (1−ε²)^{3/2})` ahead of it, `a = μ r0 B³/δ²`.
pub fn closed_form_position(params: &BearingParams, omega: f64, load: [f64; 2]) -> [f64; 2] {
    let p = load[0].hypot(load[1]);
    if p == 0.0 {
        return [0.0, 0.0];
    }
    let a = params.viscosity * params.radius * params.length.powi(3) / params.clearance.powi(2);
    let eps = ocvirk_eccentricity(p / (a * omega.abs()));
    let q = 1.0 - eps * eps;
    let wr = -eps * eps / (q * q);
    let wt = omega.signum() * std::f64::consts::PI * eps / (4.0 * q * q.sqrt());
    // Film force direction = −P: φ_e + atan2(W_t, W_r) = atan2(−P).
    let phi = (-load[1]).atan2(-load[0]) - wt.atan2(wr);
    let e = eps * params.clearance;
    [e * phi.cos(), e * phi.sin()]
}

/// Relative residual below which Newton stops.
const TOLERANCE: f64 = 1e-12;
/// Newton iterations at most.
const MAX_ITERATIONS: u32 = 30;

/// Equilibria of several bearings (each with its speed and applied load `[P_x, P_y]`, N),
/// in lockstep: every Newton iteration is one evaluator call for all unconverged ones.
pub fn bearing_equilibria(
    evaluator: &mut LoadEvaluator,
    cases: &[(BearingParams, f64, [f64; 2])],
) -> Vec<Result<BearingEquilibrium, StabilityError>> {
    let mut out: Vec<Option<Result<BearingEquilibrium, StabilityError>>> = vec![None; cases.len()];
    let mut pos: Vec<[f64; 2]> = Vec::with_capacity(cases.len());
    for (k, (params, omega, load)) in cases.iter().enumerate() {
        pos.push([0.0, 0.0]);
        if let Err(e) = params.validate() {
            out[k] = Some(Err(StabilityError::input(
                format!("bearing.{}", e.field),
                format!("{} ({})", e.reason, e.value),
            )));
            continue;
        }
        if !(omega.is_finite() && load.iter().all(|v| v.is_finite())) {
            out[k] = Some(Err(StabilityError::input(
                "speed",
                "speed and load must be finite",
            )));
            continue;
        }
        if *omega == 0.0 && load != &[0.0, 0.0] {
            out[k] = Some(Err(StabilityError::NoEquilibrium {
                speed_rad_s: 0.0,
                reason: "a journal at rest carries no static load (the film needs spin)".into(),
            }));
            continue;
        }
        pos[k] = closed_form_position(params, *omega, *load);
    }
    let mut iterations = vec![0u32; cases.len()];
    // Finite film in accuracy mode: the grid chosen at the first iterate is held for the
    // iteration (a grid change between iterates is a jump of the order of the accuracy,
    // which Newton cannot converge through).
    let mut pinned: Vec<Option<[u32; 2]>> = vec![None; cases.len()];
    loop {
        let active: Vec<usize> = (0..cases.len()).filter(|&k| out[k].is_none()).collect();
        if active.is_empty() {
            break;
        }
        let jobs: Vec<CoefficientJob> = active
            .iter()
            .map(|&k| CoefficientJob {
                params: pin_grid(&cases[k].0, pinned[k]),
                state: aligned_state(pos[k][0], pos[k][1], cases[k].1),
            })
            .collect();
        // Only K's x-y block enters the step below.
        let coeffs = coefficients_batch(evaluator, &jobs, &DiffOptions::newton_positions());
        for (&k, c) in active.iter().zip(coeffs) {
            let (params, omega, load) = cases[k];
            let c = match c {
                Ok(c) => c,
                Err(e) => {
                    out[k] = Some(Err(e));
                    continue;
                }
            };
            if pinned[k].is_none() {
                pinned[k] = c.grid;
            }
            let p = load[0].hypot(load[1]);
            let r = [c.loads.wx + load[0], c.loads.wy + load[1]];
            // The film's own noise floor (finite film: its iteration tolerance).
            let noise = load_noise(&params);
            let tolerance = TOLERANCE.max(10.0 * noise);
            let accept = 1e-8_f64.max(100.0 * noise);
            let rel = if p > 0.0 { r[0].hypot(r[1]) / p } else { 0.0 };
            let kk = c.stiffness;
            let det = kk[0][0] * kk[1][1] - kk[0][1] * kk[1][0];
            if rel <= tolerance || iterations[k] >= MAX_ITERATIONS || det == 0.0 || p == 0.0 {
                if rel > accept {
                    out[k] = Some(Err(StabilityError::NoEquilibrium {
                        speed_rad_s: omega,
                        reason: format!(
                            "Newton stopped after {} iterations at a relative load residual {rel:.2e}",
                            iterations[k]
                        ),
                    }));
                    continue;
                }
                let (x, y) = (pos[k][0], pos[k][1]);
                let e = x.hypot(y);
                let attitude = if p > 0.0 {
                    let a = y.atan2(x) - load[1].atan2(load[0]);
                    a - std::f64::consts::TAU * (a / std::f64::consts::TAU).round()
                } else {
                    0.0
                };
                out[k] = Some(Ok(BearingEquilibrium {
                    x,
                    y,
                    eccentricity_ratio: e / params.clearance,
                    attitude_angle: attitude,
                    loads: c.loads,
                    residual: rel,
                    iterations: iterations[k],
                }));
                continue;
            }
            // W(e + d) ≈ W(e) − K d = −P  ⇒  d = K⁻¹ (W + P).
            let d = [
                (kk[1][1] * r[0] - kk[0][1] * r[1]) / det,
                (-kk[1][0] * r[0] + kk[0][0] * r[1]) / det,
            ];
            // Stay inside the bore: at most half the remaining gap per step.
            let e = pos[k][0].hypot(pos[k][1]);
            let gap = params.clearance - e;
            let len = d[0].hypot(d[1]);
            let f = if len > 0.5 * gap {
                0.5 * gap / len
            } else {
                1.0
            };
            pos[k] = [pos[k][0] + f * d[0], pos[k][1] + f * d[1]];
            iterations[k] += 1;
        }
    }
    out.into_iter()
        .map(|r| r.expect("every case ends"))
        .collect()
}

/// The state of a bearing equilibrium (aligned, at rest, spinning at `omega`).
pub fn equilibrium_state(eq: &BearingEquilibrium, omega: f64) -> BearingState {
    aligned_state(eq.x, eq.y, omega)
}
