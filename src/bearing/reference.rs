//! Reference values for tests and benchmarks: adaptive quadrature to near rounding.
//! Slow; never on a hot path.

use super::loads::pack_state;
use super::rule::{slice_integrals, PackedState};
use super::{BearingParams, BearingState, StateFault};
use crate::numerics::adaptive_gauss_kronrod;

/// Load vector `[W_x, W_y, M_x, M_y]` with the closed-form arcs and an adaptive
/// Gauss-Kronrod integral in `z` to relative tolerance `rtol` (split at the real part
/// of the rate vector's zero when it lies inside the bearing).
pub fn reference_loads(
    params: &BearingParams,
    state: &BearingState,
    rtol: f64,
) -> Result<[f64; 4], StateFault> {
    let packed = pack_state(params, state)?;
    if packed.rate_scale == 0.0 {
        return Ok([0.0; 4]);
    }
    let j = reference_integrals(&packed.state, rtol);
    let f = params.force_scale() * packed.rate_scale;
    Ok([
        f * j[0],
        f * j[1],
        -f * params.length * j[3],
        f * params.length * j[2],
    ])
}

/// Film integrals of a packed state by adaptive quadrature in `z`.
pub fn reference_integrals(state: &PackedState, rtol: f64) -> [f64; 4] {
    let breaks = reference_breaks(state);
    let [e0x, e0y, ejx, ejy] = state.ecc;
    let [r0x, r0y, rjx, rjy] = state.rate;
    let f = |z: f64| {
        let [c, s] = slice_integrals(
            e0x + (ejx - e0x) * z,
            e0y + (ejy - e0y) * z,
            r0x + (rjx - r0x) * z,
            r0y + (rjy - r0y) * z,
        );
        let g = z * (1.0 - z);
        [g * c, g * s, g * z * c, g * z * s]
    };
    adaptive_gauss_kronrod(f, &breaks, rtol, 1e-300, MAX_Z_INTERVALS).value
}

/// Interval cap of the reference's `z` integral. Near the wall (ε ~ 0.99) the closed-form
/// slices carry rounding noise of ~1e-14 relative, which a 1e-14 request can never get
/// below: the adaptive rule then bisects until the cap. 2000 intervals (30 000 slices)
/// already resolve every singular feature (the near-kink is pre-split); 20 000 only cost
/// 0.6 s a state for nothing.
const MAX_Z_INTERVALS: usize = 2000;

/// Break points of the reference's `z` integral: the ends, and around the rate vector's
/// zero `s_r ± i d` when its real part lies inside: `s_r` and `s_r ± d 4^k` (`k >= 0`).
/// Without the graded points a near-kink (`d` tiny) is invisible to the Gauss-Kronrod
/// error estimate on any interval much longer than `d`: both rules miss the `~d²`
/// contribution of the region where the rate vector turns, and agree (measured: errors
/// of 1e-12 at a requested 1e-14).
fn reference_breaks(state: &PackedState) -> Vec<f64> {
    let [r0x, r0y, rjx, rjy] = state.rate;
    let (r1x, r1y) = (rjx - r0x, rjy - r0y);
    let r1sq = r1x * r1x + r1y * r1y;
    let mut breaks = vec![0.0, 1.0];
    if r1sq > 0.0 {
        let s_r = -(r0x * r1x + r0y * r1y) / r1sq;
        let d = (r0x * r1y - r0y * r1x).abs() / r1sq;
        if s_r > 0.0 && s_r < 1.0 {
            breaks.push(s_r);
            if d > 0.0 {
                let mut off = d;
                while off < 1.0 {
                    for b in [s_r - off, s_r + off] {
                        if b > 0.0 && b < 1.0 {
                            breaks.push(b);
                        }
                    }
                    off *= 4.0;
                }
            }
        }
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    breaks
}

/// One slice's `|r| (C, S)` (`C, S = ∫ sin(θ−α) (cos θ, sin θ) / (1 − ε·(cos θ, sin θ))³ dθ`
/// over the loaded arc `θ − α ∈ (π, 2π)`) by adaptive quadrature in `θ`: an independent
/// check of the closed form in [`slice_integrals`].
pub fn reference_slice(ex: f64, ey: f64, rx: f64, ry: f64, rtol: f64) -> [f64; 2] {
    let alpha = ry.atan2(rx);
    let r = rx.hypot(ry);
    // Loaded arc θ ∈ (α+π, α+2π); integrand r sin(θ−α) (cos θ, sin θ)/(1 − ε·(cos θ, sin θ))³.
    let f = |t: f64| {
        let th = alpha + std::f64::consts::PI + t;
        let (s, c) = th.sin_cos();
        let h = 1.0 - ex * c - ey * s;
        let v = r * (th - alpha).sin() / (h * h * h);
        [v * c, v * s]
    };
    // Split at the peak of 1/h³ (θ = arg ε) when it is on the arc, for the adaptive rule's sake.
    let mut breaks = vec![0.0, std::f64::consts::PI];
    let peak = (ey.atan2(ex) - alpha - std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI);
    if peak > 0.0 && peak < std::f64::consts::PI {
        breaks.insert(1, peak);
    }
    adaptive_gauss_kronrod(f, &breaks, rtol, 1e-300, 20_000).value
}
