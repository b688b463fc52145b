//! Brute-force baseline, for benchmarks only: a uniform tensor rule (midpoints in `z`,
//! the periodic trapezoid rule in `θ` over the full circle) applied to `max(p, 0)`.
//! It converges slowly (second order) because of the kinks at the arc ends.

use super::{BearingParams, BearingState};

/// Load vector `[W_x, W_y, M_x, M_y]` (N, N·m) of eq. (5) with half-Sommerfeld
/// cavitation, on an `n_theta × n_z` uniform grid.
pub fn baseline_loads(
    params: &BearingParams,
    state: &BearingState,
    n_theta: usize,
    n_z: usize,
) -> [f64; 4] {
    let (r0, b, d, mu) = (
        params.radius,
        params.length,
        params.clearance,
        params.viscosity,
    );
    let dtheta = 2.0 * std::f64::consts::PI / n_theta as f64;
    let dz = b / n_z as f64;
    let trig: Vec<(f64, f64)> = (0..n_theta)
        .map(|m| (m as f64 * dtheta).sin_cos())
        .map(|(s, c)| (c, s))
        .collect();
    let mut out = [0.0; 4];
    for k in 0..n_z {
        let z = (k as f64 + 0.5) * dz;
        let t = z / b;
        let x = state.xi + (state.xj - state.xi) * t;
        let y = state.yi + (state.yj - state.yi) * t;
        let vx = state.vxi + (state.vxj - state.vxi) * t;
        let vy = state.vyi + (state.vyj - state.vyi) * t;
        let pre = 3.0 * mu * z * (z - b);
        let (mut fc, mut fs) = (0.0, 0.0);
        for &(c, s) in &trig {
            let h = d - x * c - y * s;
            let bracket = state.omega * (x * s - y * c) - 2.0 * (vx * c + vy * s);
            let p = pre * bracket / (h * h * h);
            if p > 0.0 {
                fc += p * c;
                fs += p * s;
            }
        }
        let (fc, fs) = (fc * r0 * dtheta * dz, fs * r0 * dtheta * dz);
        out[0] -= fc;
        out[1] -= fs;
        out[2] += z * fs;
        out[3] -= z * fc;
    }
    out
}
