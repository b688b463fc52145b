//! The default load rule: each slice's loaded arc integrated in closed form, the axial
//! integral by Gauss-Legendre panels graded toward the integrand's singularities.
//!
//! # Derivation (MODEL.md sections 2-4)
//! Nondimensionalise with `s = z/B`, `ε = (x, y)/δ` and the rate vector
//! `r = (ω0 X − 2 Ẏ, ω0 Y + 2 Ẋ)` (`X = x/δ`, 1/s). The bracket of eq. (5) is
//! `|r| δ sin(θ − α)` with `α = arg r`, so a slice is loaded on `θ − α ∈ (π, 2π)`.
//! In the line-of-centres angle `ψ = θ − arg ε`, with `β = α − arg ε`, the slice needs
//! `∫ sin(ψ−β) {cos ψ, sin ψ} / (1 − ε cos ψ)³ dψ` over `ψ ∈ (β+π, β+2π)`. Sommerfeld's
//! substitution `1 − ε cos ψ = (1 − ε²)/(1 + ε cos γ)` turns every term into a
//! trigonometric polynomial of degree 2 in `γ`:
//!
//! ```text
//! ∫ sin ψ cos ψ / D³ dψ = [sin²γ/2 − ε cos γ] / (1−ε²)²
//! ∫ cos² ψ   / D³ dψ = [(1/2 + ε²) γ + sin γ cos γ / 2 + 2 ε sin γ] / (1−ε²)^{5/2}
//! ∫ sin² ψ   / D³ dψ = [γ/2 − sin γ cos γ / 2] / (1−ε²)^{3/2}
//! ```
//!
//! so each arc is exact for any `ε < 1` and the peak's narrowing costs nothing. The arc
//! ends need only `cos β, sin β` (no trigonometric function) and the arc's length in `γ`
//! one `atan2`.
//!
//! The slice loads, times `s(1 − s)`, are integrated over `s ∈ [0, 1]`. Their
//! singularities are located per state (see [`Singularities`]): the poles where
//! `|ε(s)| = 1`, the zero of the rate vector `r(s)` (a kink where it is real and inside),
//! and the complex points where an arc end meets the complex pole of `1/h³`. Panels march from
//! `s = 0`; each is at most `κ` times the distance from its start to the nearest real pole
//! (`κ = 1/2` ahead, `1` behind: Bernstein-ellipse parameter 3 + 2√2 for the panel), and at
//! most as long as keeps every complex singularity outside the panel's Bernstein ellipse of
//! parameter `1 + √2 + √(2 + 2√2)` ≈ 4.61 (the smallest the `κ` rule, used for them too
//! before issue 28's seventh pass, gave a complex singularity: one straight above a panel's
//! start; see [`RuleSettings::complex_ellipse`]), and a real kink is a panel boundary. Aligned
//! journals (`ε` and `r` constant along `z`) are integrated exactly with one slice.

use std::f64::consts::PI;

use crate::numerics::{gauss_legendre_unit, GaussRule};

/// Kernel input for one bearing state, nondimensional: `ecc = (εx_i, εy_i, εx_j, εy_j)`
/// (displacement over radial clearance) and `rate = (rx_i, ry_i, rx_j, ry_j)`, the rate
/// vectors `(ω0 X − 2 Ẏ, ω0 Y + 2 Ẋ)` at the two end faces divided by a rate scale
/// chosen by the caller (so that they are of order one).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PackedState {
    /// Eccentricity vectors at `z = 0` and `z = B`.
    pub ecc: [f64; 4],
    /// Scaled rate vectors at `z = 0` and `z = B`.
    pub rate: [f64; 4],
}

/// Kernel output, nondimensional: `[J_c, J_s, K_c, K_s]` with
/// `J = ∫ s(1−s) |r| (C, S) ds`, `K = ∫ s · s(1−s) |r| (C, S) ds` (C, S the slice's arc
/// integrals rotated to the bearing frame). Loads: `W = F (J_c, J_s)`,
/// `M_x = −F B K_s`, `M_y = F B K_c` with `F = 3 μ r0 B³ / δ²` times the rate scale.
pub type FilmIntegrals = [f64; 4];

/// Parameters of the graded composite rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RuleSettings {
    /// Gauss-Legendre nodes per panel.
    pub nodes: u32,
    /// Panel length over distance to a singularity ahead of the panel.
    pub kappa_ahead: f64,
    /// Panel length over distance to a singularity behind the panel.
    pub kappa_behind: f64,
    /// Grading toward the complex singularities (arc-end roots, the rate vector's zero,
    /// a kink's side points), dimensionless, default `1 + √2`: a panel `[s, s + L]` ends
    /// where its Bernstein ellipse whose focal-distance sum is `complex_ellipse × L` would
    /// reach the nearest one, `L = 2 (k d − Δ) / (k² − 1)` with `k` this value, `d` the
    /// singularity's distance from `s` and `Δ` its signed axial offset ahead of `s`. The
    /// real poles keep `kappa_ahead`, `kappa_behind` (the same ellipse as `k = 3` there).
    pub complex_ellipse: f64,
    /// Near-kinks of the rate vector closer than this to the real axis (in `s`) are
    /// treated as exact kinks: a panel boundary, no grading. The error this leaves is
    /// of order `C floor²`, `C` up to a few thousand where the near-kink slice is close
    /// to the wall (see [`Accuracy::settings`]).
    pub kink_floor: f64,
    /// Hard cap on panels per state (never reached for `ε < 1 − 1e-12`).
    pub max_panels: u32,
}

/// Requested accuracy: the relative error bound on the load vector
/// `(W_x, W_y, M_x/B, M_y/B)` that the rule promises for states whose larger end
/// eccentricity ratio is at most 0.95; states up to 0.99 get
/// [`Accuracy::promise_near_wall`] (1e-4 at the default level).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accuracy {
    rtol: f64,
}

/// The accuracy levels the rule is calibrated for, loosest first.
pub const ACCURACY_LEVELS: [f64; 4] = [1e-3, 1e-6, 1e-9, 1e-12];

impl Default for Accuracy {
    fn default() -> Self {
        Accuracy { rtol: 1e-6 }
    }
}

impl Accuracy {
    /// The loosest calibrated level at least as tight as `rtol`; `None` for a request
    /// tighter than 1e-12 or not a positive finite number.
    pub fn new(rtol: f64) -> Option<Self> {
        if !(rtol.is_finite() && rtol > 0.0) {
            return None;
        }
        ACCURACY_LEVELS
            .iter()
            .copied()
            .find(|&level| level <= rtol * (1.0 + 1e-9))
            .map(|rtol| Accuracy { rtol })
    }

    /// The level's relative error bound.
    pub fn rtol(&self) -> f64 {
        self.rtol
    }

    /// The error bound promised up to eccentricity 0.99 (states between 0.95 and 0.99):
    /// `min(100 rtol, max(1e-4, rtol))`, i.e. 1e-3, 1e-4, 1e-7, 1e-10 for the four levels
    /// (the issue asks 1e-4 at the default level). Measured worst errors there are 24 to
    /// 1500 times smaller (tests/bearing_accuracy.rs).
    pub fn promise_near_wall(&self) -> f64 {
        (self.rtol * 100.0).min(1e-4_f64.max(self.rtol))
    }

    /// Rule parameters for this level (calibrated in `tests/bearing_accuracy.rs`).
    pub fn settings(&self) -> RuleSettings {
        // Calibrated against the adaptive reference on random states of seven families
        // (tilted, squeezed, mid-plane tilts, half-whirl kinks, near-kinks, up to ε = 0.99;
        // tests/bearing_accuracy.rs): worst errors 3e-5, 5e-8, 7e-11, 1.4e-14 for
        // 5, 7, 9, 12 nodes, a margin of >= 15 on each promise.
        let nodes = match self.rtol {
            r if r >= 1e-3 => 5,
            r if r >= 1e-6 => 7,
            r if r >= 1e-9 => 9,
            _ => 12,
        };
        RuleSettings {
            nodes,
            kappa_ahead: 0.5,
            kappa_behind: 1.0,
            // The focal-distance sum over panel length that κ = 1 behind gave a complex
            // singularity straight above a panel's start (d + √2 d over a panel of d), the
            // smallest ellipse that rule gave any complex singularity; now every complex
            // singularity gets it (before: up to 3 straight behind, 4.24 just ahead).
            // Same worst errors at every level on the calibration states, ~16 % fewer
            // slices on strongly tilted ones (BENCHMARKS.md "Issue 28, seventh pass").
            complex_ellipse: 1.0 + std::f64::consts::SQRT_2,
            // Treating a near-kink at distance d as exact costs ~C d² with C up to ~3e3
            // (relative, measured: a near-kink on a slice near the wall while the rest of
            // the film carries little load; `NearKinkWhirl` states in the tests). With
            // 0.1 √rtol that reached 2.6 × rtol; 0.01 √rtol keeps it below rtol / 10.
            kink_floor: (self.rtol.sqrt() * 0.01).min(1e-3),
            max_panels: 96,
        }
    }
}

/// Closed-form loaded-arc integrals of one slice: `|r| (C, S)` in the bearing frame, for
/// eccentricity vector `(ex, ey)` (`|ε| < 1`) and rate vector `(rx, ry)`.
#[inline]
pub fn slice_integrals(ex: f64, ey: f64, rx: f64, ry: f64) -> [f64; 2] {
    // Lengths as `sqrt(x² + y²)`, not `hypot` (a libm call costing about as much as the
    // rest of the slice's arithmetic but one `atan2`): the kernel's inputs are of order
    // one (`|ε| < 1`, rates scaled to at most 1), so the squares can neither overflow nor
    // lose anything that matters (a component below 1e-154 contributes below rounding).
    // Within 1 ulp of `hypot`; the WGSL kernel computes the same way.
    let r = (rx * rx + ry * ry).sqrt();
    if r == 0.0 {
        return [0.0, 0.0];
    }
    let eps = (ex * ex + ey * ey).sqrt();
    let (cphi, sphi) = if eps > 0.0 {
        (ex / eps, ey / eps)
    } else {
        (1.0, 0.0)
    };
    let (ca, sa) = (rx / r, ry / r);
    // β = α − φ.
    let cb = ca * cphi + sa * sphi;
    let sb = sa * cphi - ca * sphi;
    let sq2 = (1.0 - eps) * (1.0 + eps);
    let sq = sq2.sqrt();
    // Arc ends ψ_a = β + π, ψ_b = β + 2π mapped to γ.
    let da = 1.0 + eps * cb;
    let db = 1.0 - eps * cb;
    let cga = (-cb - eps) / da;
    let sga = -sq * sb / da;
    let cgb = (cb - eps) / db;
    let sgb = sq * sb / db;
    // Counter-clockwise angle from γ_a to γ_b, in (0, 2π).
    let mut dg = (cga * sgb - sga * cgb).atan2(cga * cgb + sga * sgb);
    if dg <= 0.0 {
        dg += 2.0 * PI;
    }
    let d_sc = sgb * cgb - sga * cga;
    let a_sc = 0.5 * (sgb * sgb - sga * sga) - eps * (cgb - cga);
    let a_cc = (0.5 + eps * eps) * dg + 0.5 * d_sc + 2.0 * eps * (sgb - sga);
    let a_ss = 0.5 * dg - 0.5 * d_sc;
    let i_sc = a_sc / (sq2 * sq2);
    let i_cc = a_cc / (sq2 * sq2 * sq);
    let i_ss = a_ss / (sq2 * sq);
    let c_arc = cb * i_sc - sb * i_cc;
    let s_arc = cb * i_ss - sb * i_sc;
    [
        r * (c_arc * cphi - s_arc * sphi),
        r * (s_arc * cphi + c_arc * sphi),
    ]
}

/// Slices evaluated together by [`slices_lanes`]: one panel of up to 8 Gauss nodes (the
/// 1e-3 to 1e-9 levels use 5, 7 and 9 nodes; 12 at 1e-12 take two calls), the width of an
/// AVX-512 register of f64.
pub const LANES: usize = 8;

/// Inputs or outputs of [`slices_lanes`], one slice per lane.
pub type Lanes = [f64; LANES];

/// `atan(v)` for `|v| <= tan(π/8)` without a library call: the odd Taylor series to
/// `v^47` (truncation below 1e-20 relative), its coefficients `(−1)^k / (2k + 1)` summed by
/// Estrin's scheme (pairs, then pairs of pairs: five levels of dependent operations instead
/// of Horner's twenty-four; the kernel waits on latencies, issue 28's fifteenth pass).
/// Branch-free, so that it vectorises.
#[inline(always)]
fn atan_small(v: f64) -> f64 {
    let v2 = v * v;
    let c = |k: usize| {
        let sign = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
        sign / (2 * k + 1) as f64
    };
    let x2 = v2 * v2;
    let x4 = x2 * x2;
    let x8 = x4 * x4;
    let q: [f64; 12] = std::array::from_fn(|j| c(2 * j) + c(2 * j + 1) * v2);
    let r: [f64; 6] = std::array::from_fn(|j| q[2 * j] + q[2 * j + 1] * x2);
    let t0 = r[0] + r[1] * x4;
    let t1 = r[2] + r[3] * x4;
    let t2 = r[4] + r[5] * x4;
    let p = t0 + (t1 * x8 + t2 * (x8 * x8));
    v * p
}

/// `atan2(y, x)` in `(−π, π]` by quarter angles (the WGSL kernel's `atan2_arith` takes
/// the same angles in three halvings): `x >= 0`: `4 atan(t)` with `t = tan(θ/4) = y / (d +
/// √(2 r d))`, `d = r + x`, `r = |(x, y)|`; `x < 0`: `2 (±π/2 − 2 atan(t))` with `d = r − x`.
/// `|t| <= tan(π/8)`, free of cancellation; 0 at the origin. Within a few ulp of libm's
/// `atan2` (tests/rule_lanes.rs), branch-free.
#[inline(always)]
pub fn atan2_lane(y: f64, x: f64) -> f64 {
    let r = (x * x + y * y).sqrt();
    let right = x >= 0.0;
    let den = if right { r + x } else { r - x };
    // tan of half of `atan(y / den)`: `u / (1 + √(1 + u²))` with `u = y / den`, one
    // division instead of two (`(1 + u²) den² = 2 r den`).
    let t = y / (den + (2.0 * r * den).sqrt());
    let a = 2.0 * atan_small(t);
    let half_pi = if y < 0.0 { -0.5 * PI } else { 0.5 * PI };
    let v = if right { 2.0 * a } else { 2.0 * (half_pi - a) };
    if r == 0.0 {
        0.0
    } else {
        v
    }
}

/// [`slice_integrals`] for [`LANES`] slices at once, written branch-free (selects instead
/// of early returns) so that the compiler evaluates the lanes in SIMD registers. The
/// scalar path's arithmetic (Rust does not contract `a * b + c` into a fused
/// multiply-add, and `+ − × ÷ √` are correctly rounded in SIMD too), except that quotients
/// sharing a denominator multiply by its reciprocal and `atan2` is [`atan2_lane`] instead
/// of libm's: results differ from [`slice_integrals`] by a few ulp of the slice's size
/// (tests/rule_lanes.rs).
/// Identical bit for bit whichever instruction set runs it ([`slices_lanes`]).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one lane per index across six arrays
fn slices_lanes_generic(
    ex: &Lanes,
    ey: &Lanes,
    rx: &Lanes,
    ry: &Lanes,
    out_c: &mut Lanes,
    out_s: &mut Lanes,
) {
    slices_n(ex, ey, rx, ry, out_c, out_s)
}

/// [`slices_lanes_generic`] for `N` lanes (8, or 16 for two states' panels at once), the
/// same operations lane by lane.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one lane per index across six arrays
fn slices_n<const N: usize>(
    ex: &[f64; N],
    ey: &[f64; N],
    rx: &[f64; N],
    ry: &[f64; N],
    out_c: &mut [f64; N],
    out_s: &mut [f64; N],
) {
    for i in 0..N {
        let (ex, ey, rx, ry) = (ex[i], ey[i], rx[i], ry[i]);
        let r = (rx * rx + ry * ry).sqrt();
        let eps = (ex * ex + ey * ey).sqrt();
        let off = eps > 0.0;
        // Reciprocals where a quotient's denominator is shared (here, and below the arc
        // ends' and the three integrals'): divisions and square roots are the kernel's
        // slowest operations, 14 divisions a slice before, 7 now. Within a few ulp of
        // the scalar path's separate quotients (tests/rule_lanes.rs).
        let inv_eps = 1.0 / eps;
        let cphi = if off { ex * inv_eps } else { 1.0 };
        let sphi = if off { ey * inv_eps } else { 0.0 };
        let inv_r = 1.0 / r;
        let (ca, sa) = (rx * inv_r, ry * inv_r);
        let cb = ca * cphi + sa * sphi;
        let sb = sa * cphi - ca * sphi;
        let sq2 = (1.0 - eps) * (1.0 + eps);
        let sq = sq2.sqrt();
        let da = 1.0 + eps * cb;
        let db = 1.0 - eps * cb;
        // `da db = 1 − ε² cos²β ≥ 1 − ε² > 0`.
        let inv_dadb = 1.0 / (da * db);
        let (inv_da, inv_db) = (db * inv_dadb, da * inv_dadb);
        let cga = (-cb - eps) * inv_da;
        let sga = -sq * sb * inv_da;
        let cgb = (cb - eps) * inv_db;
        let sgb = sq * sb * inv_db;
        // The angle from γ_a to γ_b: `atan2` of `(sin, cos)(γ_b − γ_a)` times
        // `da db > 0`, whose products need no quotient (`atan2` ignores a positive
        // scale), so the angle's long chain does not wait on the division above.
        let dg = atan2_lane(
            -2.0 * eps * sq * sb,
            -(cb + eps) * (cb - eps) - sq2 * sb * sb,
        );
        let dg = if dg <= 0.0 { dg + 2.0 * PI } else { dg };
        let d_sc = sgb * cgb - sga * cga;
        let a_sc = 0.5 * (sgb * sgb - sga * sga) - eps * (cgb - cga);
        let a_cc = (0.5 + eps * eps) * dg + 0.5 * d_sc + 2.0 * eps * (sgb - sga);
        let a_ss = 0.5 * dg - 0.5 * d_sc;
        // `1 / ((1 − ε²)^2 √(1 − ε²))`, the three denominators from it.
        let inv_5 = 1.0 / (sq2 * sq2 * sq);
        let i_sc = a_sc * (sq * inv_5);
        let i_cc = a_cc * inv_5;
        let i_ss = a_ss * (sq2 * inv_5);
        let c_arc = cb * i_sc - sb * i_cc;
        let s_arc = cb * i_ss - sb * i_sc;
        // A zero rate vector: no pressure (the scalar path's early return).
        let loaded = r != 0.0;
        out_c[i] = if loaded {
            r * (c_arc * cphi - s_arc * sphi)
        } else {
            0.0
        };
        out_s[i] = if loaded {
            r * (s_arc * cphi + c_arc * sphi)
        } else {
            0.0
        };
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn slices_lanes_avx512(
    ex: &Lanes,
    ey: &Lanes,
    rx: &Lanes,
    ry: &Lanes,
    out_c: &mut Lanes,
    out_s: &mut Lanes,
) {
    slices_lanes_generic(ex, ey, rx, ry, out_c, out_s)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn slices_lanes_avx2(
    ex: &Lanes,
    ey: &Lanes,
    rx: &Lanes,
    ry: &Lanes,
    out_c: &mut Lanes,
    out_s: &mut Lanes,
) {
    slices_lanes_generic(ex, ey, rx, ry, out_c, out_s)
}

/// The film line of a tilted state, `(e0x, e0y, e1x, e1y, r0x, r0y, r1x, r1y)`: eccentricity
/// and rate vectors at `s = 0` and their changes over the bearing (`ε(s) = e0 + e1 s`).
type FilmLine = [f64; 8];

/// One panel's weighted slice loads, lane by lane: `[w c, w s, w z c, w z s]` with
/// `w = weight · len · z (1 − z)` at node `z = s + len · node` (the scalar panel loop's
/// products, the same operations in the same order, so that summing lanes `0..m` in order
/// gives its sums bit for bit). Node setup, slices and products all in SIMD lanes; pad
/// lanes (node 0, weight 0) evaluate a valid slice at `z = s` that the caller does not sum.
#[inline(always)]
fn panel_lanes_generic(
    s: f64,
    len: f64,
    line: &FilmLine,
    nodes: &Lanes,
    weights: &Lanes,
) -> [Lanes; 4] {
    let [out] = panels_side_by_side::<1, LANES>([s], [len], [line], nodes, weights);
    out
}

/// [`panel_lanes_generic`] of `K` states' panels at once, their `LANES` lanes each side by
/// side in `W = K · LANES`: lane by lane the same operations, so each state's products
/// are the bits it gets alone. Two states' (`panel_pair`) overlap their long chains of
/// dependent divisions, roots and series (the kernel waits on those latencies, not on its
/// arithmetic; issue 28, fifteenth pass).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one lane per index across the arrays
fn panels_side_by_side<const K: usize, const W: usize>(
    s: [f64; K],
    len: [f64; K],
    lines: [&FilmLine; K],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; K] {
    const { assert!(W == K * LANES, "W must be K lane groups") };
    let (mut z, mut ex, mut ey, mut rx, mut ry) =
        ([0.0; W], [0.0; W], [0.0; W], [0.0; W], [0.0; W]);
    for (h, line) in lines.iter().enumerate() {
        let [e0x, e0y, e1x, e1y, r0x, r0y, r1x, r1y] = **line;
        for i in 0..LANES {
            let zi = s[h] + len[h] * nodes[i];
            let l = h * LANES + i;
            z[l] = zi;
            ex[l] = e0x + e1x * zi;
            ey[l] = e0y + e1y * zi;
            rx[l] = r0x + r1x * zi;
            ry[l] = r0y + r1y * zi;
        }
    }
    let (mut c, mut sn) = ([0.0; W], [0.0; W]);
    slices_n(&ex, &ey, &rx, &ry, &mut c, &mut sn);
    // Returned by value (every entry written below): the caller does not clear an
    // output array for each state.
    let mut out = [[[0.0; LANES]; 4]; K];
    for h in 0..K {
        for i in 0..LANES {
            let l = h * LANES + i;
            let wg = weights[i] * len[h] * z[l] * (1.0 - z[l]);
            out[h][0][i] = wg * c[l];
            out[h][1][i] = wg * sn[l];
            out[h][2][i] = wg * z[l] * c[l];
            out[h][3][i] = wg * z[l] * sn[l];
        }
    }
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn panel_lanes_avx512(
    s: f64,
    len: f64,
    line: &FilmLine,
    nodes: &Lanes,
    weights: &Lanes,
) -> [Lanes; 4] {
    panel_lanes_generic(s, len, line, nodes, weights)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn panel_lanes_avx2(
    s: f64,
    len: f64,
    line: &FilmLine,
    nodes: &Lanes,
    weights: &Lanes,
) -> [Lanes; 4] {
    panel_lanes_generic(s, len, line, nodes, weights)
}

/// [`panel_lanes_generic`] on the build's baseline instruction set, kept out of line so
/// that its register setup does not weigh on [`FilmRule::panels`] when a SIMD extension
/// runs the lanes (~40 instructions a state there, issue 28's ninth pass).
#[inline(never)]
fn panel_lanes_baseline(
    s: f64,
    len: f64,
    line: &FilmLine,
    nodes: &Lanes,
    weights: &Lanes,
) -> [Lanes; 4] {
    panel_lanes_generic(s, len, line, nodes, weights)
}

/// [`panel_lanes_generic`] on instruction set `isa` (dispatched as [`slices_lanes`]; the
/// same bits on every one).
#[inline]
fn panel_lanes(
    isa: LaneIsa,
    s: f64,
    len: f64,
    line: &FilmLine,
    nodes: &Lanes,
    weights: &Lanes,
) -> [Lanes; 4] {
    match isa {
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: the CPU has AVX-512F (checked just above).
            unsafe { panel_lanes_avx512(s, len, line, nodes, weights) }
        }
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { panel_lanes_avx2(s, len, line, nodes, weights) }
        }
        _ => panel_lanes_baseline(s, len, line, nodes, weights),
    }
}

/// Two states' single panels on `[0, len_k]` at once ([`panels_side_by_side`]).
#[inline(always)]
fn panel_pair_generic(
    len: [f64; 2],
    lines: [&FilmLine; 2],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; 2] {
    panels_side_by_side::<2, { 2 * LANES }>([0.0; 2], len, lines, nodes, weights)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn panel_pair_avx512(
    len: [f64; 2],
    lines: [&FilmLine; 2],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; 2] {
    panel_pair_generic(len, lines, nodes, weights)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn panel_pair_avx2(
    len: [f64; 2],
    lines: [&FilmLine; 2],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; 2] {
    panel_pair_generic(len, lines, nodes, weights)
}

/// [`panel_pair_generic`] on the build's baseline instruction set (out of line, as
/// [`panel_lanes_baseline`]).
#[inline(never)]
fn panel_pair_baseline(
    len: [f64; 2],
    lines: [&FilmLine; 2],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; 2] {
    panel_pair_generic(len, lines, nodes, weights)
}

/// [`panel_pair_generic`] on instruction set `isa` (the same bits on every one).
#[inline]
fn panel_pair(
    isa: LaneIsa,
    len: [f64; 2],
    lines: [&FilmLine; 2],
    nodes: &Lanes,
    weights: &Lanes,
) -> [[Lanes; 4]; 2] {
    match isa {
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: the CPU has AVX-512F (checked just above).
            unsafe { panel_pair_avx512(len, lines, nodes, weights) }
        }
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { panel_pair_avx2(len, lines, nodes, weights) }
        }
        _ => panel_pair_baseline(len, lines, nodes, weights),
    }
}

/// The instruction set [`slices_lanes`] runs on, detected once per process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaneIsa {
    /// The build's baseline (SSE2 on x86-64: two lanes per register).
    Baseline,
    /// AVX2, four f64 lanes.
    Avx2,
    /// AVX-512F, eight f64 lanes.
    Avx512,
}

impl LaneIsa {
    /// The widest instruction set this CPU offers.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return LaneIsa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return LaneIsa::Avx2;
            }
        }
        LaneIsa::Baseline
    }
}

/// [`slice_integrals`] of eight slices at once on instruction set `isa` (one of those
/// [`LaneIsa::detect`] may return; a wider one than the CPU has falls back to the
/// baseline). The same bits on every instruction set.
pub fn slices_lanes(
    isa: LaneIsa,
    ex: &Lanes,
    ey: &Lanes,
    rx: &Lanes,
    ry: &Lanes,
    out_c: &mut Lanes,
    out_s: &mut Lanes,
) {
    match isa {
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: the CPU has AVX-512F (checked just above).
            unsafe { slices_lanes_avx512(ex, ey, rx, ry, out_c, out_s) }
        }
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { slices_lanes_avx2(ex, ey, rx, ry, out_c, out_s) }
        }
        _ => slices_lanes_generic(ex, ey, rx, ry, out_c, out_s),
    }
}

/// Most complex singularities a state's axial integrand has: four roots of the
/// arc-end quartic and the rate vector's zero.
pub const MAX_COMPLEX_SINGULARITIES: usize = 5;

/// Where the axial integrand is singular, for one packed state (in `s = z/B`).
///
/// Three kinds (the slice function is analytic in `ε` for `|ε| < 1`, and in `r` away from
/// `r = 0`, but the arc depends on `arg r`):
/// - the real poles where `|ε(s)| = 1`, just outside `[0, 1]` when an end face nears the wall;
/// - the zero of the rate vector, `r(s)·r(s) = 0` at `s_r ± i d_r` (a kink where `d_r = 0`);
/// - an arc end `θ = arg(∓r)` meeting the complex pole of `1/h³`, `1 = ε·(∓r/|r|)`: the roots
///   of the quartic `Q(s) = (ε(s)·r(s))² − r(s)·r(s)`, complex for `|ε| < 1` on `[0, 1]`,
///   at distance `~ acosh(1/ε) / |dβ/ds|` where the arc sweeps past the film minimum.
///   Two special cases: at a real kink the quartic's double root there is spurious and is
///   replaced by the two real points `ε(s)·r̂1 = ±1` (outside `[0, 1]`); at a near-kink the
///   two roots clustered there are at rounding level for Durand-Kerner and get the
///   imaginary part the local analysis guarantees (comments in [`Singularities::of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Singularities {
    /// Pole `|ε(s)| = 1` below `s = 0` (`-inf` if none).
    pub pole_lo: f64,
    /// Pole `|ε(s)| = 1` above `s = 1` (`+inf` if none).
    pub pole_hi: f64,
    /// A real kink of the rate vector inside `(0, 1)`, a panel boundary (`NaN` if none).
    pub kink_s: f64,
    /// Complex singularities `(re, |im|)`; the first `complex_count` are used.
    pub complex: [(f64, f64); MAX_COMPLEX_SINGULARITIES],
    /// How many entries of `complex` are set.
    pub complex_count: usize,
    /// Degree of the arc-end quartic after dropping negligible leading terms, and the
    /// Durand-Kerner sweeps spent on it (0, 0 where it was not needed); for flop counts.
    pub root_work: (usize, usize),
}

/// Durand-Kerner iterations at most (quadratic convergence: ~10 suffice for simple roots).
const ROOT_ITERATIONS: usize = 64;

/// Roots of `c[0] + c[1] t + ... + c[4] t⁴` that matter for `|t| ≲ 2`, by Durand-Kerner with
/// leading coefficients negligible at `|t| = 2` dropped. Written with plain arithmetic so
/// that the WGSL kernel runs the same algorithm. Returns `(re, im)` pairs and their count.
pub fn quartic_roots(c: [f64; 5]) -> ([(f64, f64); 4], usize) {
    let (roots, n, _) = quartic_roots_counted(c);
    (roots, n)
}

/// Durand-Kerner start points: for degree `n` (1..=4), `(cos, sin)` of the angles
/// `0.4 + 2πk/n`, `k < n`, computed once (they are the same for every state; computing them
/// per state cost a `sincos` per root, ~5 % of a rotor run's instructions).
fn start_directions() -> &'static [[(f64, f64); 4]; 5] {
    static TABLE: std::sync::OnceLock<[[(f64, f64); 4]; 5]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [[(0.0, 0.0); 4]; 5];
        for (n, row) in t.iter_mut().enumerate().skip(1) {
            for (k, dir) in row.iter_mut().enumerate().take(n) {
                let ang = 0.4 + 2.0 * std::f64::consts::PI * k as f64 / n as f64;
                *dir = (ang.cos(), ang.sin());
            }
        }
        t
    })
}

/// Durand-Kerner sweeps on the monic polynomial of degree `N` with lower coefficients
/// `a[..N]`, from `roots[..N]`; returns the sweeps taken. Written for a fixed degree so the
/// loops unroll and the roots stay in registers; the arithmetic, and its order, is that of
/// the generic loop (bit-identical results).
#[inline]
#[allow(clippy::needless_range_loop)] // the loops mirror the generic algorithm's indices
fn durand_kerner<const N: usize>(a: &[f64; 4], roots: &mut [(f64, f64); 4]) -> usize {
    let mut r = [(0.0, 0.0); N];
    r.copy_from_slice(&roots[..N]);
    let mut sweeps = ROOT_ITERATIONS;
    for sweep in 1..=ROOT_ITERATIONS {
        let mut moved: f64 = 0.0;
        for i in 0..N {
            let z = r[i];
            // p(z), monic, by Horner.
            let mut p = (1.0, 0.0);
            for k in (0..N).rev() {
                p = (p.0 * z.0 - p.1 * z.1 + a[k], p.0 * z.1 + p.1 * z.0);
            }
            let mut q = (1.0, 0.0);
            for (j, w) in r.iter().enumerate() {
                if j != i {
                    let d = (z.0 - w.0, z.1 - w.1);
                    q = (q.0 * d.0 - q.1 * d.1, q.0 * d.1 + q.1 * d.0);
                }
            }
            let den = q.0 * q.0 + q.1 * q.1;
            if den == 0.0 {
                continue;
            }
            let step = ((p.0 * q.0 + p.1 * q.1) / den, (p.1 * q.0 - p.0 * q.1) / den);
            r[i] = (z.0 - step.0, z.1 - step.1);
            moved = moved.max(step.0.abs().max(step.1.abs()) / (1.0 + z.0.abs().max(z.1.abs())));
        }
        if moved < 1e-13 {
            sweeps = sweep;
            break;
        }
    }
    roots[..N].copy_from_slice(&r);
    sweeps
}

/// The degree [`quartic_roots`] keeps: leading terms below rounding at `|t| = 2` dropped
/// (their roots lie far outside).
fn kept_degree(c: &[f64; 5]) -> usize {
    let mut norm: f64 = 0.0;
    let mut scale = 1.0;
    for &ck in c {
        norm = norm.max(ck.abs() * scale);
        scale *= 2.0;
    }
    let mut n = 4;
    while n > 0 && c[n].abs() * 2f64.powi(n as i32) <= 1e-13 * norm {
        n -= 1;
    }
    n
}

/// True when `c[0] + c[1] t + ... + c[n] t^n` provably has no root in the disk
/// `|t| <= radius`. One Graeffe step squares the roots (`p(t) p(−t) = q(t²)`, `q` of degree
/// `n` with coefficients `d_m = Σ_{j+k=2m} (−1)^k c_j c_k`); then `|d_0| > Σ_{m≥1} |d_m| ρ^m`
/// with `ρ = radius²` leaves `q`, hence `p`, without a root in the disk (triangle
/// inequality). Without the Graeffe step this test needs every root beyond ~13 `radius`
/// (degree 4); with it, beyond ~2.3 `radius`. Each `|d_m|` is raised by 1e-14 of the sum
/// of its terms' magnitudes, more than the rounding of the few products (a false "no
/// root" would need rounding to exceed that).
fn no_root_within(c: &[f64; 5], n: usize, radius: f64) -> bool {
    // The kept polynomial: terms above degree n are zero.
    let k = |j: usize| if j <= n { c[j] } else { 0.0 };
    let (c0, c1, c2, c3, c4) = (k(0), k(1), k(2), k(3), k(4));
    let rho = radius * radius;
    // d_m and the magnitude of its terms, m = 1..4 (written out: this runs once per
    // tilted state).
    let terms = [
        (2.0 * c0 * c2 - c1 * c1, 2.0 * (c0 * c2).abs() + c1 * c1),
        (
            2.0 * c0 * c4 - 2.0 * c1 * c3 + c2 * c2,
            2.0 * (c0 * c4).abs() + 2.0 * (c1 * c3).abs() + c2 * c2,
        ),
        (2.0 * c2 * c4 - c3 * c3, 2.0 * (c2 * c4).abs() + c3 * c3),
        (c4 * c4, c4 * c4),
    ];
    let mut rhs = 0.0;
    let mut pw = 1.0;
    for (d, mag) in terms {
        pw *= rho;
        rhs += (d.abs() + 1e-14 * mag) * pw;
    }
    c0 * c0 > rhs
}

/// [`quartic_roots`], also returning the Durand-Kerner sweeps it took (for flop counts).
pub fn quartic_roots_counted(c: [f64; 5]) -> ([(f64, f64); 4], usize, usize) {
    let n = kept_degree(&c);
    durand_kerner_from(c, n)
}

/// Durand-Kerner on the first `n + 1` coefficients of `c` (`n` from [`kept_degree`]).
fn durand_kerner_from(c: [f64; 5], n: usize) -> ([(f64, f64); 4], usize, usize) {
    if n == 0 {
        return ([(0.0, 0.0); 4], 0, 0);
    }
    let (a, mut roots) = durand_kerner_start(&c, n);
    let sweeps = match n {
        1 => durand_kerner::<1>(&a, &mut roots),
        2 => durand_kerner::<2>(&a, &mut roots),
        3 => durand_kerner::<3>(&a, &mut roots),
        _ => durand_kerner::<4>(&a, &mut roots),
    };
    (roots, n, sweeps)
}

/// The monic lower coefficients of `c`'s first `n + 1` (`1 <= n <= 4`) and the
/// Durand-Kerner start points.
fn durand_kerner_start(c: &[f64; 5], n: usize) -> ([f64; 4], [(f64, f64); 4]) {
    let mut roots = [(0.0, 0.0); 4];
    let lead = c[n];
    let mut a = [0.0; 4];
    for (ak, ck) in a.iter_mut().zip(c.iter()).take(n) {
        *ak = ck / lead;
    }
    // Start on a circle of radius ~ the roots' geometric mean, at angles 0.4 + 2πk/n.
    let radius = (a[0].abs() as f32).powf(1.0 / n as f32) as f64;
    let radius = if radius > 0.0 && radius.is_finite() {
        radius
    } else {
        1.0
    };
    for (root, dir) in roots.iter_mut().zip(&start_directions()[n]).take(n) {
        *root = (radius * dir.0, radius * dir.1);
    }
    (a, roots)
}

/// States whose degree-4 root searches [`quartic_roots_lanes`] runs together: eight, one
/// AVX-512 register (two on AVX2). Each Durand-Kerner update waits on the previous one's
/// division, so the search is bound by latency, not by lanes: eight lanes instead of four
/// (issue 28's eighth pass) gave 1.15x the strongly tilted states per second of CPU time
/// on AVX-512 for 2.8 % more instructions (the group runs until its slowest lane
/// converges; BENCHMARKS.md "Issue 28, eighth pass"). The same roots bit for bit.
pub const ROOT_LANES: usize = 8;

/// [`durand_kerner`] for degree 4 on [`ROOT_LANES`] polynomials at once, lane `l` holding
/// the monic lower coefficients `a[k][l]` and the roots `(re[i][l], im[i][l])`. Each lane
/// does the scalar search's operations in its order, and a lane whose search has stopped
/// (or whose step is skipped, `den == 0`) keeps its roots through selects: every lane ends
/// with the scalar search's roots and sweep count bit for bit (tests/rule_root_lanes.rs).
/// The lanes run until the slowest has converged.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lanes indexed across several arrays
fn durand_kerner_lanes_generic(
    a: &[[f64; ROOT_LANES]; 4],
    re: &mut [[f64; ROOT_LANES]; 4],
    im: &mut [[f64; ROOT_LANES]; 4],
    sweeps: &mut [usize; ROOT_LANES],
) {
    let mut active = [true; ROOT_LANES];
    *sweeps = [ROOT_ITERATIONS; ROOT_LANES];
    for sweep in 1..=ROOT_ITERATIONS {
        let mut moved = [0.0_f64; ROOT_LANES];
        // One root at a time, in the scalar order (each update seen by the next root).
        durand_kerner_lane_root::<0>(a, re, im, &active, &mut moved);
        durand_kerner_lane_root::<1>(a, re, im, &active, &mut moved);
        durand_kerner_lane_root::<2>(a, re, im, &active, &mut moved);
        durand_kerner_lane_root::<3>(a, re, im, &active, &mut moved);
        let mut any = false;
        for l in 0..ROOT_LANES {
            if active[l] && moved[l] < 1e-13 {
                sweeps[l] = sweep;
                active[l] = false;
            }
            any |= active[l];
        }
        if !any {
            break;
        }
    }
}

/// One Durand-Kerner update of root `I` in every lane ([`durand_kerner`]'s inner loop for
/// `i = I`; the root index a constant so that the lanes' loop has no branch).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lanes indexed across several arrays
fn durand_kerner_lane_root<const I: usize>(
    a: &[[f64; ROOT_LANES]; 4],
    re: &mut [[f64; ROOT_LANES]; 4],
    im: &mut [[f64; ROOT_LANES]; 4],
    active: &[bool; ROOT_LANES],
    moved: &mut [f64; ROOT_LANES],
) {
    let (zr, zi) = (re[I], im[I]);
    let mut new_r = zr;
    let mut new_i = zi;
    for l in 0..ROOT_LANES {
        let z = (zr[l], zi[l]);
        let mut p = (1.0, 0.0);
        for k in (0..4).rev() {
            p = (p.0 * z.0 - p.1 * z.1 + a[k][l], p.0 * z.1 + p.1 * z.0);
        }
        let mut q = (1.0, 0.0);
        for j in 0..4 {
            if j != I {
                let d = (z.0 - re[j][l], z.1 - im[j][l]);
                q = (q.0 * d.0 - q.1 * d.1, q.0 * d.1 + q.1 * d.0);
            }
        }
        let den = q.0 * q.0 + q.1 * q.1;
        let step = ((p.0 * q.0 + p.1 * q.1) / den, (p.1 * q.0 - p.0 * q.1) / den);
        let take = active[l] & (den != 0.0);
        new_r[l] = if take { z.0 - step.0 } else { z.0 };
        new_i[l] = if take { z.1 - step.1 } else { z.1 };
        let m = moved[l].max(step.0.abs().max(step.1.abs()) / (1.0 + z.0.abs().max(z.1.abs())));
        moved[l] = if take { m } else { moved[l] };
    }
    re[I] = new_r;
    im[I] = new_i;
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn durand_kerner_lanes_avx512(
    a: &[[f64; ROOT_LANES]; 4],
    re: &mut [[f64; ROOT_LANES]; 4],
    im: &mut [[f64; ROOT_LANES]; 4],
    sweeps: &mut [usize; ROOT_LANES],
) {
    durand_kerner_lanes_generic(a, re, im, sweeps)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn durand_kerner_lanes_avx2(
    a: &[[f64; ROOT_LANES]; 4],
    re: &mut [[f64; ROOT_LANES]; 4],
    im: &mut [[f64; ROOT_LANES]; 4],
    sweeps: &mut [usize; ROOT_LANES],
) {
    durand_kerner_lanes_generic(a, re, im, sweeps)
}

/// The roots of [`ROOT_LANES`] degree-4 polynomials `c` (`c[l][4] != 0`, none of them
/// dropped by [`kept_degree`]) found together on instruction set `isa`: the same roots and
/// sweep counts, bit for bit, as [`quartic_roots_counted`] gives for each.
pub fn quartic_roots_lanes(
    isa: LaneIsa,
    c: &[[f64; 5]; ROOT_LANES],
) -> [([(f64, f64); 4], usize); ROOT_LANES] {
    let (mut a, mut re, mut im) = (
        [[0.0; ROOT_LANES]; 4],
        [[0.0; ROOT_LANES]; 4],
        [[0.0; ROOT_LANES]; 4],
    );
    for l in 0..ROOT_LANES {
        let (al, rl) = durand_kerner_start(&c[l], 4);
        for k in 0..4 {
            a[k][l] = al[k];
            re[k][l] = rl[k].0;
            im[k][l] = rl[k].1;
        }
    }
    let mut sweeps = [0; ROOT_LANES];
    match isa {
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: the CPU has AVX-512F (checked just above).
            unsafe { durand_kerner_lanes_avx512(&a, &mut re, &mut im, &mut sweeps) }
        }
        #[cfg(target_arch = "x86_64")]
        LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { durand_kerner_lanes_avx2(&a, &mut re, &mut im, &mut sweeps) }
        }
        _ => durand_kerner_lanes_generic(&a, &mut re, &mut im, &mut sweeps),
    }
    let mut out = [([(0.0, 0.0); 4], 0); ROOT_LANES];
    for l in 0..ROOT_LANES {
        for k in 0..4 {
            out[l].0[k] = (re[k][l], im[k][l]);
        }
        out[l].1 = sweeps[l];
    }
    out
}

/// Radius in `t = s − 1/2` beyond which no arc-end root can end a panel early: a panel
/// starting at `s ∈ [0, 1)` is cut by a root `ρ` at distance `d = |s − ρ|` only if
/// `2 (k d − Δ) / (k² − 1) < 1 − s` ([`Singularities::panel_end`], `k` the
/// `complex_ellipse`, `Δ <= d`), which needs `κ d < 1 − s <= 1` with `κ = 2 / (k + 1)`, and
/// `d >= |ρ − 1/2| − |s − 1/2|`, so roots with `|ρ − 1/2| > 1/2 + 1/κ` never bind (the
/// worst start is `s = 0`). 1 % is added so that the 1e-13 to which Durand-Kerner converges
/// cannot bring a root back inside.
fn far_radius(settings: &RuleSettings) -> f64 {
    let kappa_min = 2.0 / (settings.complex_ellipse + 1.0);
    (0.5 + 1.0 / kappa_min) * 1.01
}

impl Singularities {
    /// Locates the singularities of `state` under `settings`. Arc-end roots that provably
    /// cannot shorten any panel are left out (they are not searched for: see
    /// [`Singularities::of_all_roots`] for the full list).
    pub fn of(state: &PackedState, settings: &RuleSettings) -> Self {
        Self::locate(state, settings, false)
    }

    /// [`Singularities::of`] with every arc-end root found by Durand-Kerner, far or not
    /// (the panel layout is the same; for tests and root statistics).
    pub fn of_all_roots(state: &PackedState, settings: &RuleSettings) -> Self {
        Self::locate(state, settings, true)
    }

    fn locate(state: &PackedState, settings: &RuleSettings, all_roots: bool) -> Self {
        match Self::locate_start(state, settings, all_roots) {
            Located::Done(sing) => sing,
            Located::Search(pending) => {
                let (roots, n, sweeps) = durand_kerner_from(pending.c, pending.n);
                pending.finish(&roots, n, sweeps)
            }
        }
    }

    /// Everything [`Singularities::locate`] does before the Durand-Kerner search, which is
    /// left to the caller when needed (so that [`FilmRule::integrate_many`] can run it for
    /// several states in SIMD lanes).
    fn locate_start(state: &PackedState, settings: &RuleSettings, all_roots: bool) -> Located {
        let [e0x, e0y, ejx, ejy] = state.ecc;
        let [r0x, r0y, rjx, rjy] = state.rate;
        let (e1x, e1y) = (ejx - e0x, ejy - e0y);
        let (r1x, r1y) = (rjx - r0x, rjy - r0y);
        let mut sing = Singularities {
            pole_lo: f64::NEG_INFINITY,
            pole_hi: f64::INFINITY,
            kink_s: f64::NAN,
            complex: [(0.0, 0.0); MAX_COMPLEX_SINGULARITIES],
            complex_count: 0,
            root_work: (0, 0),
        };
        let e1sq = e1x * e1x + e1y * e1y;
        if e1sq > 0.0 {
            let sm = -(e0x * e1x + e0y * e1y) / e1sq;
            let cross = e0x * e1y - e0y * e1x;
            let emin2 = cross * cross / e1sq;
            let half = (1.0 - emin2).max(0.0).sqrt() / e1sq.sqrt();
            // |ε| < 1 on [0, 1] puts the poles outside; keep them there under rounding.
            sing.pole_lo = (sm - half).min(-1e-14);
            sing.pole_hi = (sm + half).max(1.0 + 1e-14);
        }
        let r1sq = r1x * r1x + r1y * r1y;
        // The rate vector's zero when it is graded toward (not a kink): (s_r, d_r).
        let mut rate_zero = None;
        // A (near-)kink of the rate vector, wherever it lies (inside the bearing it is
        // also a panel boundary, `kink_s`).
        let mut kink_at = f64::NAN;
        if r1sq > 0.0 {
            let s_r = -(r0x * r1x + r0y * r1y) / r1sq;
            let d_r = (r0x * r1y - r0y * r1x).abs() / r1sq;
            if d_r >= settings.kink_floor {
                sing.complex[sing.complex_count] = (s_r, d_r);
                sing.complex_count += 1;
                rate_zero = Some((s_r, d_r));
            } else {
                kink_at = s_r;
                if s_r > 0.0 && s_r < 1.0 {
                    sing.kink_s = s_r;
                }
            }
        }
        if kink_at.is_finite() {
            // The rate vector is (nearly) r1 (s − s_r): the quartic below would have a
            // (near-)double root at the kink, which is no singularity of either one-sided
            // integrand, and grading toward it from both sides never reaches it (the
            // panels would run into `max_panels` and one last panel would span the kink
            // and the rest of the bearing). The same holds for a kink just outside the
            // bearing (a journal pivoting about an end face in pure rotation has s_r = 0
            // up to rounding): grading toward a root 1e-17 behind s = 0 costs ~57 panels.
            // On each side the arc ends point along ∓r̂1, so they meet the pole of 1/h³
            // where ε(s)·r̂1 = ±1: two real points, outside [0, 1] because |ε| < 1 there.
            let r1n = r1sq.sqrt();
            let a = e0x * r1x + e0y * r1y;
            let b = e1x * r1x + e1y * r1y;
            if b != 0.0 {
                for target in [r1n, -r1n] {
                    let s_root = (target - a) / b;
                    if s_root.is_finite() {
                        sing.complex[sing.complex_count] = (s_root, 0.0);
                        sing.complex_count += 1;
                    }
                }
            }
            return Located::Done(sing);
        }
        // Arc-end quartic in t = s − 1/2: ε = ec + e1 t, r = rc + r1 t.
        let (ecx, ecy) = (e0x + 0.5 * e1x, e0y + 0.5 * e1y);
        let (rcx, rcy) = (r0x + 0.5 * r1x, r0y + 0.5 * r1y);
        let a0 = ecx * rcx + ecy * rcy;
        let a1 = ecx * r1x + ecy * r1y + e1x * rcx + e1y * rcy;
        let a2 = e1x * r1x + e1y * r1y;
        let b0 = rcx * rcx + rcy * rcy;
        let b1 = 2.0 * (rcx * r1x + rcy * r1y);
        let b2 = r1sq;
        let c = [
            a0 * a0 - b0,
            2.0 * a0 * a1 - b1,
            a1 * a1 + 2.0 * a0 * a2 - b2,
            2.0 * a1 * a2,
            a2 * a2,
        ];
        let n = kept_degree(&c);
        if !all_roots && no_root_within(&c, n, far_radius(settings)) {
            // No root can shorten a panel (see `far_radius`): the panel layout is the one
            // the roots would give, without finding them (bit-identical results; on the
            // rotor workloads of issue 28 nearly every tilted state takes this path).
            sing.root_work = (n, 0);
            return Located::Done(sing);
        }
        Located::Search(PendingRoots {
            sing,
            c,
            n,
            rate_zero,
            e0: (e0x, e0y),
            e1: (e1x, e1y),
        })
    }
}

/// [`Singularities::locate_start`]'s result: the singularities, or a state whose arc-end
/// roots must still be searched.
enum Located {
    Done(Singularities),
    Search(PendingRoots),
}

/// A state waiting for its arc-end roots: the quartic (coefficients `c`, kept degree `n`)
/// and what [`PendingRoots::finish`] needs to place them.
#[derive(Clone, Copy)]
struct PendingRoots {
    sing: Singularities,
    c: [f64; 5],
    n: usize,
    rate_zero: Option<(f64, f64)>,
    e0: (f64, f64),
    e1: (f64, f64),
}

impl PendingRoots {
    /// The singularities with the quartic's roots (degree `n`, found in `sweeps` sweeps).
    fn finish(self, roots: &[(f64, f64); 4], n: usize, sweeps: usize) -> Singularities {
        let PendingRoots {
            mut sing,
            rate_zero,
            e0: (e0x, e0y),
            e1: (e1x, e1y),
            ..
        } = self;
        sing.root_work = (n, sweeps);
        // Near the rate vector's zero s_r ± i d_r two roots of Q cluster. Locally
        // (ε ≈ ε(s_r), r = |r1| (t ê + d_r ê⊥), t = s − s_r) Q/|r1|² is the quadratic
        // t² (ε∥² − 1) + 2 t d_r ε∥ ε⊥ + d_r² (ε⊥² − 1), whose roots are
        // t = d_r (ε∥ ε⊥ ± i √(1 − |ε|²)) / (1 − ε∥²): |Im| >= d_r √(1 − |ε|²) and
        // |t| <= d_r / (1 − |ε|²). But there Q = O(d_r²) is at rounding level for tiny
        // d_r, and Durand-Kerner can return these roots almost real (measured: Im 1.6e-14
        // for d_r = 1.2e-8 at the 1e-12 level), which graded ~100 panels toward nothing,
        // exhausted `max_panels` and left one panel spanning the rest of the bearing
        // (error 5e-5). Such roots get half the local bound as their imaginary part.
        let clamp = rate_zero.map(|(s_r, d_r)| {
            let (ex, ey) = (e0x + e1x * s_r, e0y + e1y * s_r);
            let gap = (1.0 - (ex * ex + ey * ey)).max(0.0);
            (s_r, 2.0 * d_r / gap.max(1e-30), 0.5 * d_r * gap.sqrt())
        });
        for &(re, im) in roots.iter().take(n) {
            if re.is_finite() && im.is_finite() {
                let s = re + 0.5;
                let mut im = im.abs();
                if let Some((s_r, reach, floor)) = clamp {
                    if (s - s_r).abs() <= reach {
                        im = im.max(floor);
                    }
                }
                sing.complex[sing.complex_count] = (s, im);
                sing.complex_count += 1;
            }
        }
        sing
    }
}

impl Singularities {
    /// End of the panel that starts at `s` (at most 1).
    pub fn panel_end(&self, s: f64, settings: &RuleSettings) -> f64 {
        let mut step = 1.0 - s;
        if self.pole_lo.is_finite() {
            step = step.min(settings.kappa_behind * (s - self.pole_lo));
        }
        if self.pole_hi.is_finite() {
            step = step.min(settings.kappa_ahead * (self.pole_hi - s));
        }
        // The longest panel [s, s + L] whose Bernstein ellipse with focal-distance sum k L
        // leaves the singularity c outside: |c − s| + |c − s − L| >= k L, solved for L.
        let k = settings.complex_ellipse;
        let inv = 2.0 / (k * k - 1.0);
        for &(re, im) in &self.complex[..self.complex_count] {
            // sqrt of the sum of squares as in the WGSL kernel (no overflow: |s|, |re|
            // and |im| are of order one where they bind).
            let dx = re - s;
            let d = (dx * dx + im * im).sqrt();
            step = step.min(inv * (k * d - dx));
        }
        let mut end = s + step;
        if self.kink_s > s && self.kink_s < end {
            end = self.kink_s;
        }
        end.min(1.0)
    }
}

/// The film line of packed state `state` (see [`FilmLine`]).
#[inline]
fn film_line(state: &PackedState) -> FilmLine {
    let [e0x, e0y, ejx, ejy] = state.ecc;
    let [r0x, r0y, rjx, rjy] = state.rate;
    [
        e0x,
        e0y,
        ejx - e0x,
        ejy - e0y,
        r0x,
        r0y,
        rjx - r0x,
        rjy - r0y,
    ]
}

/// The sums of one panel's first `m` lanes, node by node (all four sums at each node: the
/// scalar path's order, so the same bits, tests/rule_panel_lanes.rs).
#[inline]
#[allow(clippy::needless_range_loop)] // one node per index across the four sums
fn lane_sums(prod: &[Lanes; 4], m: usize) -> FilmIntegrals {
    let mut acc = [0.0; 4];
    for i in 0..m {
        acc[0] += prod[0][i];
        acc[1] += prod[1][i];
        acc[2] += prod[2][i];
        acc[3] += prod[3][i];
    }
    acc
}

/// The default rule with its Gauss table built once.
#[derive(Clone, Debug)]
pub struct FilmRule {
    settings: RuleSettings,
    gauss: GaussRule,
    /// The Gauss nodes and weights in groups of [`LANES`] (pad lanes: node 0, weight 0),
    /// with the number of real nodes in each group.
    node_lanes: Vec<(Lanes, Lanes, usize)>,
    isa: LaneIsa,
}

impl FilmRule {
    /// Builds the rule for `settings`.
    pub fn new(settings: RuleSettings) -> Self {
        Self::with_isa(settings, LaneIsa::detect())
    }

    /// [`FilmRule::new`] with the slices on instruction set `isa` (the results are the
    /// same bits on every one; for tests and benchmarks).
    pub fn with_isa(settings: RuleSettings, isa: LaneIsa) -> Self {
        let gauss = gauss_legendre_unit(settings.nodes as usize);
        let node_lanes = gauss
            .nodes
            .chunks(LANES)
            .zip(gauss.weights.chunks(LANES))
            .map(|(n, w)| {
                let (mut nl, mut wl) = ([0.0; LANES], [0.0; LANES]);
                nl[..n.len()].copy_from_slice(n);
                wl[..w.len()].copy_from_slice(w);
                (nl, wl, n.len())
            })
            .collect();
        FilmRule {
            gauss,
            node_lanes,
            settings,
            isa,
        }
    }

    /// The rule's parameters.
    pub fn settings(&self) -> &RuleSettings {
        &self.settings
    }

    /// The Gauss-Legendre table on `[0, 1]` used in every panel.
    pub fn gauss(&self) -> &GaussRule {
        &self.gauss
    }

    /// Film integrals of one packed state, and the number of slices evaluated.
    pub fn integrate(&self, state: &PackedState) -> (FilmIntegrals, u32) {
        if let Some(aligned) = Self::aligned(state) {
            return aligned;
        }
        self.panels(state, &Singularities::of(state, &self.settings))
    }

    /// [`FilmRule::integrate`] of every state into `out` (same length), the same bits: the
    /// tilted states' arc-end root searches of degree 4 run [`ROOT_LANES`] states at a
    /// time in SIMD lanes ([`quartic_roots_lanes`]), the rest (and the last few searched
    /// states of the call) as in `integrate`.
    pub fn integrate_many(&self, states: &[PackedState], out: &mut [FilmIntegrals]) {
        assert_eq!(states.len(), out.len(), "one output per state");
        // States waiting for a degree-4 root search: (index, quartic and its context).
        let mut queue: [Option<(usize, PendingRoots)>; ROOT_LANES] = [None; ROOT_LANES];
        let mut queued = 0;
        // A single-panel state waiting for another to share the lanes with.
        let mut waiting = None;
        for (k, state) in states.iter().enumerate() {
            if let Some((v, _)) = Self::aligned(state) {
                out[k] = v;
                continue;
            }
            let located = Singularities::locate_start(state, &self.settings, false);
            // Matched by reference: the singularities (128 bytes) are not copied out of
            // the result for `panels` (~16 instructions a state).
            match &located {
                Located::Done(sing) => self.panels_paired(k, state, sing, &mut waiting, out),
                &Located::Search(p) if p.n == 4 => {
                    queue[queued] = Some((k, p));
                    queued += 1;
                    if queued == ROOT_LANES {
                        let mut c = [[0.0; 5]; ROOT_LANES];
                        for (cl, q) in c.iter_mut().zip(&queue) {
                            *cl = q.expect("queued").1.c;
                        }
                        let found = quartic_roots_lanes(self.isa, &c);
                        for (q, (roots, sweeps)) in queue.iter().zip(found) {
                            let (i, p) = q.expect("queued");
                            let sing = p.finish(&roots, 4, sweeps);
                            self.panels_paired(i, &states[i], &sing, &mut waiting, out);
                        }
                        queued = 0;
                    }
                }
                &Located::Search(p) => {
                    let (roots, n, sweeps) = durand_kerner_from(p.c, p.n);
                    let sing = p.finish(&roots, n, sweeps);
                    self.panels_paired(k, state, &sing, &mut waiting, out);
                }
            }
        }
        for q in &queue[..queued] {
            let (i, p) = q.expect("queued");
            let (roots, n, sweeps) = durand_kerner_from(p.c, p.n);
            let sing = p.finish(&roots, n, sweeps);
            self.panels_paired(i, &states[i], &sing, &mut waiting, out);
        }
        if let Some((i, line)) = waiting {
            let (nodes, weights, m) = &self.node_lanes[0];
            out[i] = lane_sums(&panel_lanes(self.isa, 0.0, 1.0, &line, nodes, weights), *m);
        }
    }

    /// [`FilmRule::panels`] of state `k` into `out[k]`, except that a state whose film is
    /// one panel of one lane group (most states at the 1e-3 to 1e-9 levels) waits in
    /// `waiting` for a second such state, and the two are evaluated together
    /// ([`panel_pair`]): the same bits as `panels` for each.
    fn panels_paired(
        &self,
        k: usize,
        state: &PackedState,
        sing: &Singularities,
        waiting: &mut Option<(usize, FilmLine)>,
        out: &mut [FilmIntegrals],
    ) {
        // `panels`' first panel: `[0, panel_end(0)]`, the whole film when that end is 1.
        let single = self.node_lanes.len() == 1
            && self.settings.max_panels > 1
            && sing.panel_end(0.0, &self.settings) >= 1.0;
        if !single {
            out[k] = self.panels(state, sing).0;
            return;
        }
        let line = film_line(state);
        match waiting.take() {
            None => *waiting = Some((k, line)),
            Some((j, other)) => {
                let (nodes, weights, m) = &self.node_lanes[0];
                let [a, b] = panel_pair(self.isa, [1.0, 1.0], [&other, &line], nodes, weights);
                out[j] = lane_sums(&a, *m);
                out[k] = lane_sums(&b, *m);
            }
        }
    }

    /// An aligned state's integrals (one slice), `None` for a tilted one.
    fn aligned(state: &PackedState) -> Option<(FilmIntegrals, u32)> {
        let [e0x, e0y, ejx, ejy] = state.ecc;
        let [r0x, r0y, rjx, rjy] = state.rate;
        let (e1x, e1y, r1x, r1y) = (ejx - e0x, ejy - e0y, rjx - r0x, rjy - r0y);
        if e1x == 0.0 && e1y == 0.0 && r1x == 0.0 && r1y == 0.0 {
            // Aligned: the slice loads are constant, ∫ s(1−s) ds = 1/6, ∫ s²(1−s) ds = 1/12.
            let [c, s] = slice_integrals(e0x, e0y, r0x, r0y);
            return Some(([c / 6.0, s / 6.0, c / 12.0, s / 12.0], 1));
        }
        None
    }

    /// A tilted state's integrals over the panels `sing` lays out, and the slices. Each
    /// panel's node setup, slices and weighted products run in SIMD lanes
    /// ([`panel_lanes`]); the products are summed node by node in the order of the scalar
    /// loop this replaced (the same bits, tests/rule_panel_lanes.rs).
    fn panels(&self, state: &PackedState, sing: &Singularities) -> (FilmIntegrals, u32) {
        let line = film_line(state);
        let mut acc = [0.0; 4];
        let mut slices = 0;
        let mut s = 0.0;
        let mut panels = 0;
        while s < 1.0 {
            panels += 1;
            let end = if panels >= self.settings.max_panels {
                1.0
            } else {
                sing.panel_end(s, &self.settings)
            };
            let len = end - s;
            for (nodes, weights, m) in &self.node_lanes {
                let prod = panel_lanes(self.isa, s, len, &line, nodes, weights);
                // Node by node, all four sums at each node: the scalar path's order, so
                // the bits are the same (tests/rule_panel_lanes.rs).
                #[allow(clippy::needless_range_loop)]
                for i in 0..*m {
                    acc[0] += prod[0][i];
                    acc[1] += prod[1][i];
                    acc[2] += prod[2][i];
                    acc[3] += prod[3][i];
                }
            }
            slices += self.settings.nodes;
            s = end;
        }
        (acc, slices)
    }
}
