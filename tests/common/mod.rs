//! Shared test support: one checker for load vectors, a deterministic PRNG, and
//! generators of bearing states (random and special families) and of test models with
//! closed-form solutions (MODEL.md section 7).
//!
//! Every integration-test crate includes this module; not all of them use every item.
#![allow(dead_code)]

use bearing_sweep::bearing::{
    pack_state, BearingParams, BearingState, ClearanceConvention, FilmIntegrals, PackedState,
};

/// The packed (solver-side) form of a state that must be valid.
pub fn packed(p: &BearingParams, s: &BearingState) -> PackedState {
    pack_state(p, s).expect("valid state").state
}

/// The bits of film integrals, for bit-for-bit comparisons.
pub fn integral_bits(v: &[FilmIntegrals]) -> Vec<[u64; 4]> {
    v.iter().map(|x| x.map(f64::to_bits)).collect()
}

/// Random states of every family and eccentricity bound 0.5, 0.95 and 0.99 (60 per family
/// and bound, over the test geometries, aligned ones included), then `n_bench` of
/// `bench loads`'s strongly tilted states of the paper's bearing; all packed.
pub fn mixed_packed_states(seed: u64, n_bench: usize) -> Vec<PackedState> {
    let geoms = geometries();
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    for family in FAMILIES {
        for emax in [0.5, 0.95, 0.99] {
            for k in 0..60 {
                let (_, p) = &geoms[k % geoms.len()];
                out.push(packed(p, &random_state(&mut rng, p, family, emax)));
            }
        }
    }
    let p = BearingParams::paper_table2();
    out.extend(
        bearing_sweep::bench::bench_states(&p, n_bench)
            .iter()
            .map(|s| packed(&p, s)),
    );
    out
}

/// Euclidean norm.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Norm-wise relative error `|a − e| / |e|` (absolute `|a − e|` when `e = 0`).
pub fn rel_error(actual: &[f64], expected: &[f64]) -> f64 {
    assert_eq!(actual.len(), expected.len(), "vector lengths differ");
    let diff: Vec<f64> = actual.iter().zip(expected).map(|(a, e)| a - e).collect();
    let scale = norm(expected);
    if scale > 0.0 {
        norm(&diff) / scale
    } else {
        norm(&diff)
    }
}

/// The one checker: `|actual − expected| <= atol + rtol |expected|` in the Euclidean
/// norm (the load-vector error measure of the issue). On failure prints the label, the
/// case index, both vectors, the error and the tolerance.
#[track_caller]
pub fn assert_close(
    label: &str,
    index: usize,
    actual: &[f64],
    expected: &[f64],
    rtol: f64,
    atol: f64,
) {
    assert_eq!(
        actual.len(),
        expected.len(),
        "{label} [{index}]: lengths differ"
    );
    let diff: Vec<f64> = actual.iter().zip(expected).map(|(a, e)| a - e).collect();
    let err = norm(&diff);
    let tol = atol + rtol * norm(expected);
    let finite = actual.iter().all(|x| x.is_finite());
    assert!(
        finite && err <= tol,
        "{label} [{index}]: norm-wise check failed\n  actual   = {actual:?}\n  expected = {expected:?}\n  \
         |a-e| = {err:.3e}, relative {rel:.3e}; tolerance {tol:.3e} (rtol {rtol:.1e}, atol {atol:.1e})",
        rel = rel_error(actual, expected),
    );
}

/// Componentwise variant: `|a_k − e_k| <= atol + rtol |e_k|` for every `k`.
#[track_caller]
pub fn assert_close_each(
    label: &str,
    index: usize,
    actual: &[f64],
    expected: &[f64],
    rtol: f64,
    atol: f64,
) {
    assert_eq!(
        actual.len(),
        expected.len(),
        "{label} [{index}]: lengths differ"
    );
    for (k, (a, e)) in actual.iter().zip(expected).enumerate() {
        let tol = atol + rtol * e.abs();
        assert!(
            a.is_finite() && (a - e).abs() <= tol,
            "{label} [{index}] component {k}: actual {a:e}, expected {e:e}, |a-e| = {:.3e} > \
             tolerance {tol:.3e} (rtol {rtol:.1e}, atol {atol:.1e})\n  actual   = {actual:?}\n  \
             expected = {expected:?}",
            (a - e).abs()
        );
    }
}

/// Scalar shorthand for [`assert_close_each`].
#[track_caller]
pub fn assert_scalar(label: &str, index: usize, actual: f64, expected: f64, rtol: f64, atol: f64) {
    assert_close_each(label, index, &[actual], &[expected], rtol, atol);
}

/// xorshift64* (Vigna): deterministic, fast, good enough for test inputs.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a nonzero seed (zero is mapped to a fixed constant).
    pub fn new(seed: u64) -> Self {
        Rng(if seed == 0 {
            0x9E37_79B9_7F4A_7C15
        } else {
            seed
        })
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }

    /// A uniform angle in `[0, 2π)`.
    pub fn angle(&mut self) -> f64 {
        self.range(0.0, std::f64::consts::TAU)
    }

    /// A uniform point in the disc of radius `r`.
    pub fn in_disc(&mut self, r: f64) -> (f64, f64) {
        let rho = r * self.uniform().sqrt();
        let a = self.angle();
        (rho * a.cos(), rho * a.sin())
    }

    /// `+1` or `−1`.
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() & 1 == 0 {
            1.0
        } else {
            -1.0
        }
    }
}

/// The paper's Table 2 bearing.
pub fn table2() -> BearingParams {
    BearingParams::paper_table2()
}

/// Test geometries: Table 2, a very short bearing and a long one (B / 2r0 = 1), with
/// different clearances and viscosities so that no scale factor cancels by accident.
pub fn geometries() -> Vec<(&'static str, BearingParams)> {
    vec![
        ("table2", table2()),
        (
            "short",
            BearingParams {
                radius: 0.05,
                length: 0.01,
                clearance: 5e-5,
                viscosity: 0.01,
                clearance_convention: ClearanceConvention::Paper,
                ..BearingParams::paper_table2()
            },
        ),
        (
            "square",
            BearingParams {
                radius: 0.015,
                length: 0.03,
                clearance: 2e-4,
                viscosity: 0.1,
                clearance_convention: ClearanceConvention::Vogelpohl,
                ..BearingParams::paper_table2()
            },
        ),
    ]
}

/// Families of bearing states, each exercising a different feature of the rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Tilted journal, random squeeze velocities at both ends, spin of either sign.
    General,
    /// Tilted journal, pure rotation (no squeeze).
    RotationTilted,
    /// Tilt about the mid-plane: the journal axis crosses the bore axis at `z = B/2`
    /// (the rate vector vanishes there: a real kink), with a conical whirl `v_i = −v_j`.
    MidplaneTilt,
    /// A slice at a random `z` whirls at `ω0/2`: its rate vector is zero (a real kink).
    HalfWhirl,
    /// `ω0 = 0`, random squeeze.
    SqueezeOnly,
    /// A mid-plane tilt with a tiny squeeze that moves the rate vector's zero off the real
    /// axis by `1e-8 .. 1e-2` (in `s = z/B`): a near-kink.
    NearKink,
    /// A half-whirl state whose rate zero is moved off the real axis by `1e-8 .. 1e-2`
    /// (a near-kink where the film may be thin).
    NearKinkWhirl,
    /// Nearly aligned: the ends differ by `1e-12 .. 1e-2` in eccentricity and velocity
    /// (the singularities recede to infinity; one panel).
    NearlyAligned,
    /// `ω0 = 0` with `v_j = −c v_i`: the squeeze velocity, hence the rate vector, vanishes
    /// inside the bearing (a kink without spin).
    SqueezeKink,
    /// A half-whirl kink or near-kink within 0.02 of an end face, inside or outside.
    KinkNearEnd,
    /// Both ends near the wall in unrelated directions, large squeeze.
    WallBothEnds,
}

/// All families, for loops.
pub const FAMILIES: [Family; 11] = [
    Family::General,
    Family::RotationTilted,
    Family::MidplaneTilt,
    Family::HalfWhirl,
    Family::SqueezeOnly,
    Family::NearKink,
    Family::NearKinkWhirl,
    Family::NearlyAligned,
    Family::SqueezeKink,
    Family::KinkNearEnd,
    Family::WallBothEnds,
];

/// Builds a state from nondimensional end eccentricity vectors (`ε = e/δ`) and end
/// velocities in units of `δ |ω|` (or of `δ · 100/s` when `ω = 0`).
fn dimensional(
    p: &BearingParams,
    ei: (f64, f64),
    ej: (f64, f64),
    vi: (f64, f64),
    vj: (f64, f64),
    omega: f64,
) -> BearingState {
    let d = p.clearance;
    let vscale = d * if omega != 0.0 { omega.abs() } else { 100.0 };
    BearingState {
        xi: ei.0 * d,
        yi: ei.1 * d,
        xj: ej.0 * d,
        yj: ej.1 * d,
        vxi: vi.0 * vscale,
        vyi: vi.1 * vscale,
        vxj: vj.0 * vscale,
        vyj: vj.1 * vscale,
        omega,
    }
}

/// Larger end eccentricity ratio of a state.
pub fn max_ecc(p: &BearingParams, s: &BearingState) -> f64 {
    let (a, b) = s.eccentricity_ratios(p.clearance);
    a.max(b)
}

/// A random state of `family` whose larger end eccentricity ratio lies in
/// `[0.3 emax, emax]`, biased toward `emax` (where the rule works hardest).
pub fn random_state(rng: &mut Rng, p: &BearingParams, family: Family, emax: f64) -> BearingState {
    // Larger end ratio: emax (1 − 0.7 u²), half the draws within 10 % of emax.
    let u = rng.uniform();
    let big = emax * (1.0 - 0.7 * u * u);
    let a = rng.angle();
    let e_big = (big * a.cos(), big * a.sin());
    let omega = rng.sign() * rng.range(10.0, 1000.0);
    let rand_v = |rng: &mut Rng, scale: f64| {
        let (x, y) = rng.in_disc(scale);
        (x, y)
    };
    match family {
        Family::General | Family::RotationTilted | Family::SqueezeOnly => {
            let e_other = rng.in_disc(big);
            let (ei, ej) = if rng.sign() > 0.0 {
                (e_big, e_other)
            } else {
                (e_other, e_big)
            };
            let (vi, vj, omega) = match family {
                Family::RotationTilted => ((0.0, 0.0), (0.0, 0.0), omega),
                Family::SqueezeOnly => (rand_v(rng, 1.0), rand_v(rng, 1.0), 0.0),
                _ => (rand_v(rng, 1.0), rand_v(rng, 1.0), omega),
            };
            dimensional(p, ei, ej, vi, vj, omega)
        }
        Family::MidplaneTilt => {
            // ε(s) = e_big (1 − 2s) or its reverse: zero at s = 1/2. Conical whirl
            // v(s) ∝ (1 − 2s) keeps the rate vector's zero at the mid-plane.
            let v = rand_v(rng, 1.0);
            dimensional(p, e_big, (-e_big.0, -e_big.1), v, (-v.0, -v.1), omega)
        }
        Family::NearKink => {
            // Mid-plane tilt ε(s) = e (1 − 2s) with a uniform squeeze velocity v (units δ|ω|):
            // r(s)/|ω| = sg e (1 − 2s) + 2 J v, J (x, y) = (−y, x). Writing 2 J v = a ê + b ê⊥
            // (|e| = E), r vanishes at s = 1/2 + sg a/(2E) ± i |b|/(2E): b sets the distance
            // d of the near-kink from the real axis, a shifts it along z by Δ.
            let d = 10f64.powf(rng.range(-8.0, -2.0));
            let shift = rng.range(-0.3, 0.3);
            let sg = omega.signum();
            let e = big;
            let (ux, uy) = (e_big.0 / e, e_big.1 / e);
            let (a, b) = (sg * 2.0 * e * shift, rng.sign() * 2.0 * e * d);
            // 2 J v = a (ux, uy) + b (−uy, ux)  ⇒  v = −J (that) / 2, −J (x, y) = (y, −x).
            let jv = (a * ux - b * uy, a * uy + b * ux);
            let v = (0.5 * jv.1, -0.5 * jv.0);
            dimensional(p, e_big, (-e_big.0, -e_big.1), v, v, omega)
        }
        Family::HalfWhirl => {
            let (ei, ej, vi, vj, _) = half_whirl(rng, big, e_big, omega);
            dimensional(p, ei, ej, vi, vj, omega)
        }
        Family::NearKinkWhirl => {
            // A half-whirl state (rate r(s) = r1 (s − s*), velocities in δ|ω|) plus a uniform
            // velocity w with 2 J w = ±d |r1| r̂1⊥: the zero moves to s* ± i d.
            let (ei, ej, vi, vj, r1) = half_whirl(rng, big, e_big, omega);
            let d = 10f64.powf(rng.range(-8.0, -2.0));
            let sgn = rng.sign();
            let jw = (-r1.1 * d * 0.5 * sgn, r1.0 * d * 0.5 * sgn);
            let w = (jw.1, -jw.0);
            dimensional(
                p,
                ei,
                ej,
                (vi.0 + w.0, vi.1 + w.1),
                (vj.0 + w.0, vj.1 + w.1),
                omega,
            )
        }
        Family::NearlyAligned => {
            let pert = 10f64.powf(rng.range(-12.0, -2.0));
            let dir = rng.angle();
            // Move the other end inward so that its ratio stays below `big`.
            let ej = (
                e_big.0 - pert * dir.cos().abs() * e_big.0.signum(),
                e_big.1 - pert * dir.sin().abs() * e_big.1.signum(),
            );
            let v = rng.in_disc(1.0);
            let dv = rng.in_disc(pert);
            dimensional(p, e_big, ej, v, (v.0 + dv.0, v.1 + dv.1), omega)
        }
        Family::SqueezeKink => {
            let e_other = rng.in_disc(big);
            let v = rng.in_disc(1.0);
            let c = 10f64.powf(rng.range(-2.0, 2.0));
            dimensional(p, e_big, e_other, v, (-c * v.0, -c * v.1), 0.0)
        }
        Family::KinkNearEnd => {
            let e_other = rng.in_disc(big);
            let s_star = if rng.sign() > 0.0 {
                rng.range(-0.02, 0.02)
            } else {
                1.0 + rng.range(-0.02, 0.02)
            };
            let es = (
                e_big.0 + (e_other.0 - e_big.0) * s_star,
                e_big.1 + (e_other.1 - e_big.1) * s_star,
            );
            // Velocities in δ|ω|: v* = (sg/2) J e(s*), gradient g; a uniform w moves the
            // zero off the axis by d (or not at all).
            let sg = omega.signum();
            let v_star = (-0.5 * sg * es.1, 0.5 * sg * es.0);
            let g = rng.in_disc(0.5);
            let d = if rng.sign() > 0.0 {
                0.0
            } else {
                10f64.powf(rng.range(-10.0, -3.0))
            };
            let w = (g.1 * d, -g.0 * d);
            let vi = (v_star.0 - g.0 * s_star + w.0, v_star.1 - g.1 * s_star + w.1);
            let vj = (
                v_star.0 + g.0 * (1.0 - s_star) + w.0,
                v_star.1 + g.1 * (1.0 - s_star) + w.1,
            );
            dimensional(p, e_big, e_other, vi, vj, omega)
        }
        Family::WallBothEnds => {
            let b = rng.angle();
            let big2 = big * (1.0 - 0.05 * rng.uniform());
            let ej = (big2 * b.cos(), big2 * b.sin());
            dimensional(p, e_big, ej, rng.in_disc(3.0), rng.in_disc(3.0), omega)
        }
    }
}

/// Nondimensional end eccentricities and velocities (units `δ|ω|`) of a tilted journal
/// whose slice at a random `s*` whirls at `ω0/2` (its rate vector is zero), and the
/// rate-vector slope `r1` (units `|ω|`): `r(s) = r1 (s − s*)`.
#[allow(clippy::type_complexity)]
fn half_whirl(
    rng: &mut Rng,
    big: f64,
    e_big: (f64, f64),
    omega: f64,
) -> ((f64, f64), (f64, f64), (f64, f64), (f64, f64), (f64, f64)) {
    let e_other = rng.in_disc(big);
    let (ei, ej) = if rng.sign() > 0.0 {
        (e_big, e_other)
    } else {
        (e_other, e_big)
    };
    let s_star = rng.range(0.05, 0.95);
    let es = (ei.0 + (ej.0 - ei.0) * s_star, ei.1 + (ej.1 - ei.1) * s_star);
    // v* = (ω/2) ẑ × e(s*), in units of δ|ω|.
    let sg = omega.signum();
    let v_star = (-0.5 * sg * es.1, 0.5 * sg * es.0);
    let grad = rng.in_disc(1.0);
    let vi = (v_star.0 - grad.0 * s_star, v_star.1 - grad.1 * s_star);
    let vj = (
        v_star.0 + grad.0 * (1.0 - s_star),
        v_star.1 + grad.1 * (1.0 - s_star),
    );
    // r/|ω| = sg ε + 2 J v, J (x, y) = (−y, x).
    let r1 = (
        sg * (ej.0 - ei.0) - 2.0 * grad.1,
        sg * (ej.1 - ei.1) + 2.0 * grad.0,
    );
    (ei, ej, vi, vj, r1)
}

/// An aligned journal at eccentricity ratio `eps` along `+x`, spinning at `omega > 0`,
/// and its Ocvirk loads `[W_x, W_y, M_x, M_y]` (MODEL.md section 7).
pub fn ocvirk_model(p: &BearingParams, eps: f64, omega: f64) -> (BearingState, [f64; 4]) {
    let state = BearingState {
        xi: eps * p.clearance,
        xj: eps * p.clearance,
        omega,
        ..Default::default()
    };
    (state, ocvirk_loads(p, eps, omega))
}

/// Ocvirk short-bearing loads for an aligned journal displaced along `+x` (ω0 > 0).
pub fn ocvirk_loads(p: &BearingParams, eps: f64, omega: f64) -> [f64; 4] {
    let (mu, r0, b, d) = (p.viscosity, p.radius, p.length, p.clearance);
    let one = 1.0 - eps * eps;
    let wx = -mu * omega * r0 * b.powi(3) * eps * eps / (d * d * one * one);
    let wy =
        std::f64::consts::PI * mu * omega * r0 * b.powi(3) * eps / (4.0 * d * d * one.powf(1.5));
    [wx, wy, -0.5 * b * wy, 0.5 * b * wx]
}

/// The load vector `(W_x, W_y, M_x/B, M_y/B)` from `[W_x, W_y, M_x, M_y]`.
pub fn load_vector(v: [f64; 4], length: f64) -> [f64; 4] {
    [v[0], v[1], v[2] / length, v[3] / length]
}

/// Rotates a state by angle `a` about the bore axis.
pub fn rotate_state(s: &BearingState, a: f64) -> BearingState {
    let (sn, c) = a.sin_cos();
    let rot = |x: f64, y: f64| (c * x - sn * y, sn * x + c * y);
    let (xi, yi) = rot(s.xi, s.yi);
    let (xj, yj) = rot(s.xj, s.yj);
    let (vxi, vyi) = rot(s.vxi, s.vyi);
    let (vxj, vyj) = rot(s.vxj, s.vyj);
    BearingState {
        xi,
        yi,
        xj,
        yj,
        vxi,
        vyi,
        vxj,
        vyj,
        omega: s.omega,
    }
}

/// Rotates a load vector `[W_x, W_y, M_x, M_y]` by angle `a` about `z`.
pub fn rotate_loads(v: [f64; 4], a: f64) -> [f64; 4] {
    let (sn, c) = a.sin_cos();
    [
        c * v[0] - sn * v[1],
        sn * v[0] + c * v[1],
        c * v[2] - sn * v[3],
        sn * v[2] + c * v[3],
    ]
}

/// `[1.0e-3, 2.5e-7, ...]`: a list of errors for messages.
pub fn sci(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:.2e}")).collect();
    format!("[{}]", items.join(", "))
}

/// The GPU backend in f64 at the default accuracy, or `None` with a notice that the
/// `what` cases are skipped when no adapter exists (a failure under
/// BEARING_SWEEP_REQUIRE_GPU=1, as `.ci/run` sets).
pub fn gpu_f64_or_skip(what: &str) -> Option<bearing_sweep::backend::GpuBackend> {
    use bearing_sweep::backend::{GpuBackend, GpuOptions, Precision};
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    match GpuBackend::new(bearing_sweep::bearing::Accuracy::default(), options) {
        Ok(b) => Some(b),
        Err(e) if std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
            panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}")
        }
        Err(e) => {
            eprintln!("notice: skipping the {what} cases: {e}");
            None
        }
    }
}

/// Loads, reports and fields of a finite-film solve on a backend.
pub type FiniteSolved = (
    Vec<FilmIntegrals>,
    Vec<bearing_sweep::bearing::finite::SolveReport>,
    Vec<Vec<f64>>,
);

/// Loads, reports and fields of `states` solved cold by `backend`'s finite-film path at the
/// bearing's grid (explicit or accuracy mode, as `p.finite` says).
pub fn solve_finite_cold<B: bearing_sweep::backend::FilmBackend>(
    backend: &mut B,
    p: &BearingParams,
    states: &[BearingState],
) -> FiniteSolved {
    use bearing_sweep::bearing::finite::{FiniteGrid, FiniteJob};
    let jobs: Vec<FiniteJob> = states
        .iter()
        .map(|s| FiniteJob::of_state(p, &pack_state(p, s).unwrap(), s.omega))
        .collect();
    let grid = FiniteGrid::for_bearing(p);
    let mut fields = vec![Vec::new(); jobs.len()];
    let (mut out, mut reports) = (Vec::new(), Vec::new());
    backend
        .integrate_finite(&jobs, &grid, &mut fields, &mut out, &mut reports)
        .expect("the finite-film solve runs");
    (out, reports, fields)
}

/// Two states of the paper's bearing for the multigrid kernel's equal-result tests: an
/// aligned journal at ε ≈ 0.81, and a tilted, squeezed one.
pub fn two_finite_states() -> [BearingState; 2] {
    let d = BearingParams::paper_table2().clearance;
    [
        BearingState {
            xi: 0.8 * d,
            yi: 0.1 * d,
            xj: 0.8 * d,
            yj: 0.1 * d,
            omega: 100.0,
            ..BearingState::default()
        },
        BearingState {
            xi: 0.4 * d,
            yi: -0.2 * d,
            xj: -0.1 * d,
            yj: -0.5 * d,
            vyi: -0.1 * d * 100.0,
            omega: 100.0,
            ..BearingState::default()
        },
    ]
}
