//! Radau IIA of order 5 (3 stages, L-stable) in lockstep, after Hairer and Wanner's
//! RADAU5: simplified Newton on `I - h A (x) J`, solved as RADAU5 does in the eigenbasis of
//! `A^-1` (one real `n x n` system `(gamma/h I - J)` and one complex one
//! `((alpha - i beta)/h I - J)` instead of the real `3n x 3n` one: the same Newton
//! iterates up to rounding at about a fifth of the factorisation work), the embedded
//! error estimate `(mu/h I - J)^-1 (f0 + (e . Z)/h)`, Jacobians from the system's own
//! structure where it forms them ([`BatchSystem::jacobians`]: a rotor's from its bearings'
//! inputs), else by forward differences
//! (backward for a column whose forward probe leaves the domain, e.g. through the wall)
//! where each column is ONE batched call over all variants that need a Jacobian, Newton
//! stage calls batched over all variants (3 entries each), cubic collocation dense output.
//! Jacobians are reused while Newton converges fast (contraction <= 0.1), except on a
//! variant whose reuses mostly fail (then <= 1e-3, Hairer's default). What a system
//! declares of its structure is used: kinematic rows and quadratures are eliminated from
//! the Newton systems in closed form (`super::reduced`), and one column of a
//! scale-invariant block is derived from the others by Euler's relation instead of
//! evaluated ([`BatchSystem::scale_invariant_block`]).

// Index loops mirror the tableau's subscripts.
#![allow(clippy::needless_range_loop)]

use std::time::Instant;

use nalgebra::Matrix3;

use super::common::{
    admit, end, end_with_fault, err_norm, finite, h_floor, initial_step, notify,
    status_after_accepted, step_to_try, Packed, Track,
};
use super::jacobian::Jacobians;
use super::newton::{Judged, Newton, Rate};
use super::reduced::{NewtonLu, Reduction, MAX_PAIRS};
use super::system::{BatchSystem, Settings, Stats, Status};

const SQ6: f64 = 2.449_489_742_783_178;
/// Nodes.
const C: [f64; 3] = [(4.0 - SQ6) / 10.0, (4.0 + SQ6) / 10.0, 1.0];
/// Runge-Kutta matrix of Radau IIA (s = 3).
const A: [[f64; 3]; 3] = [
    [
        (88.0 - 7.0 * SQ6) / 360.0,
        (296.0 - 169.0 * SQ6) / 1800.0,
        (-2.0 + 3.0 * SQ6) / 225.0,
    ],
    [
        (296.0 + 169.0 * SQ6) / 1800.0,
        (88.0 + 7.0 * SQ6) / 360.0,
        (-2.0 - 3.0 * SQ6) / 225.0,
    ],
    [(16.0 - SQ6) / 36.0, (16.0 + SQ6) / 36.0, 1.0 / 9.0],
];
/// Weights of `Z` in the error estimate (Hairer-Wanner IV.8, `dd` of RADAU5).
const EZ: [f64; 3] = [
    -(13.0 + 7.0 * SQ6) / 3.0,
    (-13.0 + 7.0 * SQ6) / 3.0,
    -1.0 / 3.0,
];
/// Newton iterations allowed per step.
const MAX_NEWTON: usize = 7;
/// Newton contraction above which the Jacobian is recomputed after the step: Hairer's
/// choice for Jacobians that are expensive next to a Newton iteration (his default 1e-3
/// is for cheap ones). A rotor's Jacobian costs 13 right-hand sides, an iteration 3; with
/// 1e-3 nearly every step formed one (3 884 Jacobians in 3 997 steps on issue 28's grid9
/// workload), with 0.1 two in five, for 1.6-1.7x fewer right-hand sides at the same error
/// (BENCHMARKS.md "Issue 28, fourth pass").
const THETA_JAC: f64 = 0.1;
/// A variant whose steps on reused Jacobians mostly fail (Newton diverges, the step is
/// retried with a fresh Jacobian and the failed iterations are wasted) forms one after
/// every step instead, unless Newton contracted by this much (Hairer's default for cheap
/// Jacobians). A failed reuse costs ~2 iterations (6 right-hand sides) plus the Jacobian
/// (10) against the Jacobian alone, so reuse pays while it fails less than ~60 % of the
/// time; [`REUSE_FAILING`] switches at half. On `sweeps/clearance-viscosity.json`'s
/// stiffest variants (δ = 1e-4 m) nearly every step reused a Jacobian, failed, and formed
/// one anyway (BENCHMARKS.md "Issue 28, ninth pass").
const THETA_JAC_MIN: f64 = 1e-3;
/// The failure rate of reuse (a moving average, weight [`REUSE_MEMORY`] on the past)
/// above which a variant stops reusing Jacobians ([`THETA_JAC_MIN`]).
const REUSE_FAILING: f64 = 0.5;
/// Weight of the past in a variant's failure rate of reuse: about the last five reuses.
const REUSE_MEMORY: f64 = 0.8;
/// Newton stops when its estimated remaining error is below this fraction of the local
/// error tolerance (the error norm's unit): Hairer's cap on `fnewt`. (His tolerance
/// transformation `rtol' = 0.1 rtol^(2/3)` makes his stopping level about 3 % of the
/// user's tolerance at rtol 1e-6 to 1e-3 as well; this used `min(0.03, √rtol)` of the
/// untransformed tolerance, 0.1 % at rtol 1e-6, which cost ~1 extra iteration per step.)
const NEWTON_FRACTION: f64 = 0.03;

/// The Newton stopping level in the error norm's unit: [`NEWTON_FRACTION`], raised to
/// `10 ε / rtol` where rounding would not let the iteration get there.
fn newton_tolerance(rtol: f64) -> f64 {
    (10.0 * f64::EPSILON / rtol).max(NEWTON_FRACTION)
}
/// `f(y)` at an accepted step's end, where no Jacobian is formed there, is not evaluated:
/// the converged Newton iteration evaluated `f` at its last stage-3 state `s3`, which is
/// the step's end up to the last Newton correction (and the quaternion projection), so
/// `f(y_new) ≈ f(s3) + J (y_new − s3)` with the step's Jacobian, correct to second order
/// in that correction. `f(y)` enters only the next step's error estimate
/// (`(γ/h − J)^-1 (f(y) + e·Z/h)`, a difference the correction's size bounds); where a
/// Jacobian is formed at `y` (its finite differences, or a system's own, compare against
/// `f(y)`) it is evaluated (also later, when a reused Jacobian fails at that state). One
/// right-hand side fewer on most accepted steps, at the same steps and errors: −4 % load
/// evaluations on issue 28's grid9, −5.7 % on spin256 (BENCHMARKS.md "Issue 28, eleventh
/// pass").
fn share_f0() -> bool {
    #[cfg(test)]
    {
        !tests::EXACT_F0.with(|c| c.get())
    }
    #[cfg(not(test))]
    {
        true
    }
}

/// Safety factor of the step-size proposal `SAFETY (2 MAX_NEWTON + 1) / (2 MAX_NEWTON +
/// iterations) · err^(-1/4)`. Hairer's RADAU5 uses 0.9; this aims the error estimate at
/// `0.7^4 ≈ 0.24` of the tolerance instead of `0.9^4 ≈ 0.66`, so the same error is
/// reached at a ~3x looser tolerance and with it a ~3x looser Newton stop
/// ([`NEWTON_FRACTION`] of the tolerance): fewer iterations a step at about the same
/// steps. At equal error 10-13 % fewer load evaluations than 0.9 on issue 28's grid9 and
/// spin256; at the same tolerance up to 8 % more for a 1.7-2.7x smaller error
/// (BENCHMARKS.md "Issue 28, eleventh pass"). 0.6 gains a little more there but on the stiffest film of
/// `sweeps/clearance-viscosity.json` (δ = 1e-4 m, μ = 0.1 Pa·s) its smaller steps let
/// reused Jacobians converge often enough to keep reusing them, with a failed reuse
/// every fourth step (184 retries in 677 steps, `tests/rotor_jacobian_reuse.rs`).
const SAFETY: f64 = 0.7;
/// Keep the step (and the LU) when the proposed growth factor is within [1, 1.2].
const KEEP_H_MAX: f64 = 1.2;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 8.0;

/// Step shrink after a right-hand-side fault or a Newton failure with a fresh Jacobian.
const FAULT_SHRINK: f64 = 0.25;
const NEWTON_SHRINK: f64 = 0.5;

/// The real eigenvalue `mu` of `A^-1` (= 3 + 3^(2/3) - 3^(1/3)); [`eigenbasis`]'s `gamma`
/// (unit test).
#[cfg(test)]
fn mu_real() -> f64 {
    3.0 + 3f64.powf(2.0 / 3.0) - 3f64.powf(1.0 / 3.0)
}

/// The eigenbasis of `A^-1` in which the Newton system decouples (Hairer-Wanner IV.8):
/// `T^-1 A^-1 T = [[gamma, 0, 0], [0, alpha, beta], [0, -beta, alpha]]`, `T`'s columns the
/// real eigenvector and the real and imaginary parts of a complex one.
#[derive(Clone, Copy, Debug)]
struct Eigenbasis {
    t: [[f64; 3]; 3],
    ti: [[f64; 3]; 3],
    gamma: f64,
    alpha: f64,
    beta: f64,
}

/// Complex product.
fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

/// A null vector of the rank-2 complex `3 x 3` matrix with rows `r`: the (bilinear) cross
/// product of the pair of rows that gives the largest one.
fn null_vector(r: [[(f64, f64); 3]; 3]) -> [(f64, f64); 3] {
    let cross = |a: [(f64, f64); 3], b: [(f64, f64); 3]| {
        let sub = |x: (f64, f64), y: (f64, f64)| (x.0 - y.0, x.1 - y.1);
        [
            sub(cmul(a[1], b[2]), cmul(a[2], b[1])),
            sub(cmul(a[2], b[0]), cmul(a[0], b[2])),
            sub(cmul(a[0], b[1]), cmul(a[1], b[0])),
        ]
    };
    let size = |v: &[(f64, f64); 3]| v.iter().map(|c| c.0 * c.0 + c.1 * c.1).sum::<f64>();
    [cross(r[0], r[1]), cross(r[0], r[2]), cross(r[1], r[2])]
        .into_iter()
        .max_by(|a, b| size(a).total_cmp(&size(b)))
        .expect("three candidates")
}

fn eigenbasis() -> Eigenbasis {
    let m = Matrix3::from_fn(|i, j| A[i][j])
        .try_inverse()
        .expect("the Radau IIA matrix is invertible");
    // Eigenvalues of A (Hairer-Wanner IV.8, RADAU5's constants): the real one
    // (6 + 81^(1/3) - 9^(1/3)) / 30 and the pair (12 - 81^(1/3) + 9^(1/3)) / 60
    // ± i √3 (81^(1/3) + 9^(1/3)) / 60; those of A^-1 are their reciprocals.
    let (c81, c9) = (81f64.cbrt(), 9f64.cbrt());
    let gamma = 30.0 / (6.0 + c81 - c9);
    let (ar, ai) = ((12.0 - c81 + c9) / 60.0, 3f64.sqrt() * (c81 + c9) / 60.0);
    let norm = ar * ar + ai * ai;
    // 1 / (ar + i ai) = (ar - i ai) / norm: the eigenvector of A^-1 for ar/norm - i ai/norm.
    let sigma = (ar / norm, -ai / norm);
    let rows = |shift: (f64, f64)| {
        let mut r = [[(0.0, 0.0); 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (m[(i, j)], 0.0);
            }
            r[i][i] = (m[(i, i)] - shift.0, -shift.1);
        }
        r
    };
    let v1 = null_vector(rows((gamma, 0.0)));
    let v2 = null_vector(rows(sigma));
    let tm = Matrix3::from_fn(|i, j| match j {
        0 => v1[i].0,
        1 => v2[i].0,
        _ => v2[i].1,
    });
    let tim = tm
        .try_inverse()
        .expect("eigenvectors of distinct eigenvalues");
    // T^-1 A^-1 T's 2 x 2 block: [[alpha, beta], [-beta, alpha]] (unit test).
    let lam = tim * m * tm;
    Eigenbasis {
        t: std::array::from_fn(|i| std::array::from_fn(|j| tm[(i, j)])),
        ti: std::array::from_fn(|i| std::array::from_fn(|j| tim[(i, j)])),
        gamma,
        alpha: lam[(1, 1)],
        beta: lam[(1, 2)],
    }
}

/// Inverse of `V[i][j] = c_i^(j+1)`: maps stage values `z_i` to the coefficients of the
/// collocation polynomial `z(theta) = a1 theta + a2 theta^2 + a3 theta^3`.
fn collocation_inverse() -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| C[i].powi(j as i32 + 1))
        .try_inverse()
        .expect("distinct nodes make the Vandermonde matrix invertible")
}

/// Which Radau IIA method runs: 3 stages (radau5, order 5) or 5 (radau9, order 9).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stages {
    Three,
    Five,
}

/// What the step needs of an `NS`-stage Radau IIA method: radau5's closed forms
/// ([`Tableau::radau5`]) or radau9's derived constants ([`Tableau::radau9`]).
struct Tableau<const NS: usize> {
    /// Nodes (the last is 1).
    c: [f64; NS],
    /// Weights of `Z` in the error estimate.
    ez: [f64; NS],
    /// The eigenbasis of `A^-1` and its inverse ([`Eigenbasis`]).
    t: [[f64; NS]; NS],
    ti: [[f64; NS]; NS],
    /// The real eigenvalue of `A^-1`.
    gamma: f64,
    /// `(α_k, β_k)` of `T^-1 A^-1 T`'s complex blocks `[[α, β], [−β, α]]`, the first
    /// `(NS − 1)/2` used.
    pairs: [(f64, f64); MAX_PAIRS],
    /// Stage increments to the collocation polynomial's coefficients.
    vinv: [[f64; NS]; NS],
    /// Exponent of the step proposal `err^expo`: the error estimate is `O(h^(NS+1))`.
    expo: f64,
}

impl Tableau<3> {
    fn radau5() -> Self {
        let eb = eigenbasis();
        let vinv = collocation_inverse();
        let mut pairs = [(0.0, 0.0); MAX_PAIRS];
        pairs[0] = (eb.alpha, eb.beta);
        Tableau {
            c: C,
            ez: EZ,
            t: eb.t,
            ti: eb.ti,
            gamma: eb.gamma,
            pairs,
            vinv: std::array::from_fn(|i| std::array::from_fn(|j| vinv[(i, j)])),
            expo: -0.25,
        }
    }
}

impl Tableau<5> {
    /// Radau IIA with 5 stages (order 9), from [`super::tableau::radau_iia`].
    fn radau9() -> Self {
        let k = super::tableau::radau_iia(5);
        let arr = |v: &[f64]| -> [f64; 5] { std::array::from_fn(|i| v[i]) };
        let mat = |m: &[Vec<f64>]| -> [[f64; 5]; 5] { std::array::from_fn(|i| arr(&m[i])) };
        let mut pairs = [(0.0, 0.0); MAX_PAIRS];
        pairs[..2].copy_from_slice(&k.pairs);
        Tableau {
            c: arr(&k.c),
            ez: arr(&k.ez),
            t: mat(&k.t),
            ti: mat(&k.ti),
            gamma: k.gamma,
            pairs,
            vinv: mat(&k.vinv),
            expo: -1.0 / 6.0,
        }
    }
}

struct Var {
    need_f0: bool,
    need_jac: bool,
    jac_current: bool,
    need_lu: bool,
    h_lu: f64,
    have_dense: bool,
    h_old: f64,
    newton: Newton,
    iters: usize,
    /// Newton's convergence rate, carried across steps.
    rate: Rate,
    /// Moving average of the outcome of steps on reused Jacobians (1: Newton failed),
    /// see [`THETA_JAC_MIN`].
    reuse_fails: f64,
    /// The converged iteration's stage-3 state and `f` there are in `s3` / `f3`.
    have_f3: bool,
    /// `f0` is the shared estimate ([`share_f0`]), not `f(y)`: a Jacobian formed at `y`
    /// (after a failed reuse) evaluates `f(y)` first.
    f0_shared: bool,
}

pub(crate) fn run<S: BatchSystem>(
    sys: &mut S,
    y0: &[f64],
    settings: &[Settings],
    start: Instant,
    stages: Stages,
) -> Vec<(Status<S::Fault>, Stats)> {
    let d = sys.dim();
    let mut tracks: Vec<Track<S::Fault>> = settings.iter().map(Track::new).collect();
    let mut y = y0.to_vec();
    let mut rec = Packed::new();
    let mut ended = Vec::new();
    let active = admit(&mut tracks, settings, &y, d, &mut rec, &mut ended, start);
    rec.flush_records(sys);
    notify(sys, &tracks, &mut ended);
    continue_from(sys, &mut y, settings, &mut tracks, active, start, stages);
    tracks.into_iter().map(|t| (t.status, t.stats)).collect()
}

/// Integrates the variants in `active` from where their tracks stand (`tracks[id].t`,
/// state `y[id * dim..]`, samples from `tracks[id].next_sample` on) to their ends. A
/// track with a step size already set (a variant handed over from dopri5 by
/// [`super::Method::Auto`]) starts with that step; a fresh one (`h = 0`) gets the
/// initial-step heuristic.
pub(crate) fn continue_from<S: BatchSystem>(
    sys: &mut S,
    y: &mut [f64],
    settings: &[Settings],
    tracks: &mut [Track<S::Fault>],
    active: Vec<usize>,
    start: Instant,
    stages: Stages,
) {
    match stages {
        Stages::Three => continue_with(&Tableau::radau5(), sys, y, settings, tracks, active, start),
        Stages::Five => continue_with(&Tableau::radau9(), sys, y, settings, tracks, active, start),
    }
}

/// The `NS` consecutive slices of length `d` of a stage-major vector `v` (`NS * d` long).
#[inline(always)]
fn stage_slices<const NS: usize>(v: &[f64], d: usize) -> [&[f64]; NS] {
    std::array::from_fn(|k| &v[k * d..(k + 1) * d])
}

/// [`continue_from`] by the `NS`-stage method `tab`.
fn continue_with<S: BatchSystem, const NS: usize>(
    tab: &Tableau<NS>,
    sys: &mut S,
    y: &mut [f64],
    settings: &[Settings],
    tracks: &mut [Track<S::Fault>],
    mut active: Vec<usize>,
    start: Instant,
) {
    let n = settings.len();
    let d = sys.dim();
    let jd = sys.jacobian_dim().min(d);
    let d3 = NS * d;
    let np = (NS - 1) / 2;
    // The Newton systems on the components that need a dense LU (positions whose rate is
    // a velocity and quadratures eliminated in closed form: `super::reduced`).
    let red = Reduction::new(d, jd, sys.kinematic_pairs());
    let mut f0 = vec![0.0; n * d];
    // Row-major d x d per variant.
    let mut jac: Vec<Vec<f64>> = vec![vec![0.0; d * d]; n];
    let mut z = vec![0.0; n * d3];
    let mut dense = vec![0.0; n * d3];
    let mut scale = vec![1.0; n * d];
    // Newton's error weights `atol · scale + rtol · |y|` of the step under way.
    let mut wts = vec![1.0; n * d];
    for id in 0..n {
        sys.scales(id, &mut scale[id * d..(id + 1) * d]);
    }
    // gamma/h I - J (also the error estimate's matrix) and (alpha - i beta)/h I - J.
    let mut lus: Vec<NewtonLu> = vec![NewtonLu::default(); n];
    let mut vars: Vec<Var> = (0..n)
        .map(|_| Var {
            need_f0: true,
            need_jac: true,
            jac_current: false,
            need_lu: true,
            h_lu: 0.0,
            have_dense: false,
            h_old: 0.0,
            newton: Newton::Iterating,
            iters: 0,
            rate: Rate::default(),
            reuse_fails: 0.0,
            have_f3: false,
            f0_shared: false,
        })
        .collect();
    let mut hs = vec![0.0; n];
    // Per variant: the converged Newton iteration's last stage-3 state and `f` there
    // ([`share_f0`]).
    let mut s3 = vec![0.0; n * d];
    let mut f3 = vec![0.0; n * d];
    let mut dz = vec![0.0; d3];
    let mut dw = vec![0.0; d3];
    let mut errv = vec![0.0; d];
    let mut ynew = vec![0.0; d];
    let mut buf = Packed::new();
    let mut rec = Packed::new();
    let mut ended = Vec::new();
    let mut work: Vec<usize> = Vec::new();
    // Variants whose Jacobian is formed this round, and the Jacobians' scratch.
    let mut formed: Vec<usize> = Vec::new();
    let mut jacs = Jacobians::new(sys, n);

    while !active.is_empty() {
        // 1. f(t, y) where the state is new.
        buf.clear();
        for &id in &active {
            let v = &vars[id];
            if v.need_f0 || (v.need_jac && v.f0_shared) {
                buf.push_from(id, tracks[id].t, y[id * d..(id + 1) * d].iter().copied());
            }
        }
        buf.eval(sys, tracks);
        for e in 0..buf.len() {
            let id = buf.ids[e];
            vars[id].need_f0 = false;
            vars[id].f0_shared = false;
            if let Some(f) = &buf.faults[e] {
                end_with_fault(tracks, id, f, start, &mut ended);
            } else {
                f0[id * d..(id + 1) * d].copy_from_slice(&buf.dys[e * d..(e + 1) * d]);
            }
        }
        active.retain(|&id| matches!(tracks[id].status, Status::Running));
        for &id in &active {
            if tracks[id].h == 0.0 {
                let s = &settings[id];
                let r = id * d..(id + 1) * d;
                tracks[id].h = s
                    .fixed_step
                    .unwrap_or_else(|| initial_step(&y[r.clone()], &f0[r.clone()], &scale[r], s));
            }
        }
        // 2. Jacobians: from the system's structure where it forms them
        // ([`BatchSystem::jacobians`]), else one batched call per column.
        work.clear();
        work.extend(active.iter().copied().filter(|&id| vars[id].need_jac));
        formed.clear();
        formed.extend_from_slice(&work);
        jacs.form(
            sys, tracks, y, &f0, &scale, &mut jac, &mut work, &mut ended, start,
        );
        for &id in &formed {
            let v = &mut vars[id];
            v.need_jac = false;
            v.jac_current = true;
            v.need_lu = true;
            tracks[id].stats.jacobians += 1;
        }
        active.retain(|&id| matches!(tracks[id].status, Status::Running));
        // 3. Step sizes and factorisations.
        work.clear();
        for &id in &active {
            let s = &settings[id];
            let tr = &tracks[id];
            let h = step_to_try(tr, s);
            hs[id] = h;
            let v = &mut vars[id];
            if v.need_lu || h != v.h_lu {
                let mut shifts = [(0.0, 0.0); MAX_PAIRS];
                for (o, &(a, b)) in shifts.iter_mut().zip(&tab.pairs[..np]) {
                    *o = (a / h, -b / h);
                }
                lus[id].factor(&red, tab.gamma / h, &shifts[..np], &jac[id]);
                tracks[id].stats.factorizations += 1;
                v.need_lu = false;
                v.h_lu = h;
            }
            // Newton start: the previous collocation polynomial, extrapolated.
            let zb = &mut z[id * d3..(id + 1) * d3];
            if v.have_dense {
                let al = stage_slices::<NS>(&dense[id * d3..(id + 1) * d3], d);
                for (i, zi) in zb.chunks_exact_mut(d).enumerate() {
                    let th = 1.0 + tab.c[i] * h / v.h_old;
                    for (p, o) in zi[..d].iter_mut().enumerate() {
                        // t (a_1 + t (a_2 + … t a_NS)).
                        let q = |t: f64| {
                            let mut acc = al[NS - 1][p];
                            for r in (0..NS - 1).rev() {
                                acc = al[r][p] + t * acc;
                            }
                            t * acc
                        };
                        *o = q(th) - q(1.0);
                    }
                }
            } else {
                zb.fill(0.0);
            }
            v.newton = if lus[id].singular() {
                Newton::Failed
            } else {
                Newton::Iterating
            };
            v.iters = 0;
            v.have_f3 = false;
            v.rate.start_step();
            // Newton's error weights: the state does not move during the iteration.
            for p in 0..d {
                wts[id * d + p] = s.atol * scale[id * d + p] + s.rtol * y[id * d + p].abs();
            }
            work.push(id);
        }
        // 4. Newton, all variants' stages in one call per iteration.
        for iter in 0..MAX_NEWTON {
            buf.clear();
            for &id in &work {
                if vars[id].newton != Newton::Iterating {
                    continue;
                }
                let yb = &y[id * d..(id + 1) * d];
                for (i, zi) in z[id * d3..(id + 1) * d3].chunks_exact(d).enumerate() {
                    let t = tracks[id].t + tab.c[i] * hs[id];
                    buf.push_from(id, t, yb.iter().zip(zi).map(|(&yv, &zv)| yv + zv));
                }
            }
            if buf.len() == 0 {
                break;
            }
            buf.eval(sys, tracks);
            let mut e = 0;
            while e < buf.len() {
                let id = buf.ids[e];
                let s = &settings[id];
                let h = hs[id];
                let v = &mut vars[id];
                let fault = (0..NS).find_map(|i| buf.faults[e + i].clone());
                if let Some(f) = fault {
                    tracks[id].fault = Some(f);
                    v.newton = Newton::Fault;
                    e += NS;
                    continue;
                }
                let fs = &buf.dys[e * d..(e + NS) * d];
                let zb = &mut z[id * d3..(id + 1) * d3];
                // (I - h A (x) J) dZ = -Z + h (A (x) I) F in the eigenbasis: with
                // W = (T^-1 (x) I) Z and G = (T^-1 (x) I) F, (Lambda/h (x) I - I (x) J) dW =
                // G - (Lambda/h (x) I) W, one real and (NS - 1)/2 complex n x n systems;
                // dZ = T dW.
                let ti = &tab.ti;
                let gh = tab.gamma / h;
                let mut sh = [(0.0, 0.0); MAX_PAIRS];
                for (o, &(a, b)) in sh.iter_mut().zip(&tab.pairs[..np]) {
                    *o = (a / h, b / h);
                }
                // Row · vector, summed from the first term (the same operations as
                // radau5's written-out sums).
                let tr = |row: &[f64; NS], v: &[f64; NS]| {
                    let mut acc = row[0] * v[0];
                    for k in 1..NS {
                        acc += row[k] * v[k];
                    }
                    acc
                };
                {
                    // Each stage's slice of length `d`, so that the loop below indexes
                    // within them (no bounds checks).
                    let zs_k = stage_slices::<NS>(zb, d);
                    let fs_k = stage_slices::<NS>(fs, d);
                    let mut chunks = dw[..d3].chunks_exact_mut(d);
                    let ws: [&mut [f64]; NS] =
                        std::array::from_fn(|_| chunks.next().expect("NS stages"));
                    for p in 0..d {
                        let zs: [f64; NS] = std::array::from_fn(|k| zs_k[k][p]);
                        let f: [f64; NS] = std::array::from_fn(|k| fs_k[k][p]);
                        let wz: [f64; NS] = std::array::from_fn(|k| tr(&ti[k], &zs));
                        ws[0][p] = tr(&ti[0], &f) - gh * wz[0];
                        for (q, &(ah, bh)) in sh[..np].iter().enumerate() {
                            let i = 1 + 2 * q;
                            ws[i][p] = tr(&ti[i], &f) - (ah * wz[i] + bh * wz[i + 1]);
                            ws[i + 1][p] = tr(&ti[i + 1], &f) - (ah * wz[i + 1] - bh * wz[i]);
                        }
                    }
                    let (w1, mut rest) = dw.split_at_mut(d);
                    lus[id].solve_real(&red, w1);
                    for q in 0..np {
                        let (wr, tail) = rest.split_at_mut(d);
                        let (wi, tail) = tail.split_at_mut(d);
                        lus[id].solve_complex(&red, q, wr, wi);
                        rest = tail;
                    }
                }
                let t = &tab.t;
                {
                    let ws = stage_slices::<NS>(&dw, d);
                    let mut chunks = dz[..d3].chunks_exact_mut(d);
                    let ds: [&mut [f64]; NS] =
                        std::array::from_fn(|_| chunks.next().expect("NS stages"));
                    for p in 0..d {
                        let w: [f64; NS] = std::array::from_fn(|k| ws[k][p]);
                        for i in 0..NS {
                            ds[i][p] = tr(&t[i], &w);
                        }
                    }
                }
                let mut sum = 0.0;
                let wb = &wts[id * d..(id + 1) * d];
                for di in dz.chunks_exact(d) {
                    for (&dv, &wv) in di.iter().zip(wb) {
                        sum += (dv / wv).powi(2);
                    }
                }
                let norm = (sum / d3 as f64).sqrt();
                let tol = newton_tolerance(s.rtol);
                v.iters = iter + 1;
                if !norm.is_finite() {
                    v.newton = Newton::Failed;
                    e += NS;
                    continue;
                }
                let judged = v.rate.judge(iter, MAX_NEWTON, norm, tol);
                if judged == Judged::Diverging {
                    v.newton = Newton::Failed;
                    e += NS;
                    continue;
                }
                for (zv, dv) in zb.iter_mut().zip(dz.iter()) {
                    *zv += dv;
                }
                if judged == Judged::Converged {
                    v.newton = Newton::Converged;
                    // The last stage-3 point and `f` there ([`share_f0`]).
                    s3[id * d..(id + 1) * d]
                        .copy_from_slice(&buf.ys[(e + NS - 1) * d..(e + NS) * d]);
                    f3[id * d..(id + 1) * d].copy_from_slice(&fs[(NS - 1) * d..NS * d]);
                    v.have_f3 = true;
                } else if judged == Judged::Exhausted {
                    v.newton = Newton::Failed;
                }
                e += NS;
            }
        }
        // 5. Error estimate, accept or reject.
        for &id in &work {
            let s = &settings[id];
            let tr = &mut tracks[id];
            let v = &mut vars[id];
            let h = hs[id];
            let t0 = tr.t;
            let floor = h_floor(t0, s.t_end);
            let fixed = s.fixed_step.is_some();
            match v.newton {
                Newton::Fault => {
                    tr.stats.rejected += 1;
                    tr.h = h * FAULT_SHRINK;
                    if fixed || tr.h < floor {
                        let fault = tr.fault.clone().expect("fault recorded");
                        end(tr, Status::Fault { time: t0, fault }, start);
                        ended.push(id);
                    }
                    continue;
                }
                Newton::Failed | Newton::Iterating => {
                    tr.stats.rejected += 1;
                    if !v.jac_current {
                        v.need_jac = true;
                        v.reuse_fails = REUSE_MEMORY * v.reuse_fails + (1.0 - REUSE_MEMORY);
                    } else {
                        tr.h = h * NEWTON_SHRINK;
                        if fixed || tr.h < floor {
                            end(
                                tr,
                                Status::StepSizeTooSmall {
                                    time: t0,
                                    step: tr.h,
                                },
                                start,
                            );
                            ended.push(id);
                        }
                    }
                    continue;
                }
                Newton::Converged => {}
            }
            let zb = &z[id * d3..(id + 1) * d3];
            let yb = &y[id * d..(id + 1) * d];
            {
                let zs = stage_slices::<NS>(zb, d);
                let (ynew, errv, f0v) = (&mut ynew[..d], &mut errv[..d], &f0[id * d..(id + 1) * d]);
                for p in 0..d {
                    ynew[p] = yb[p] + zs[NS - 1][p];
                    let mut ze = tab.ez[0] * zs[0][p];
                    for k in 1..NS {
                        ze += tab.ez[k] * zs[k][p];
                    }
                    errv[p] = f0v[p] + ze / h;
                }
            }
            lus[id].solve_real(&red, &mut errv);
            let norm = if fixed {
                0.0
            } else {
                err_norm(&errv, yb, &ynew, &scale[id * d..(id + 1) * d], s)
            };
            if !norm.is_finite() || !finite(&ynew) {
                tr.stats.rejected += 1;
                tr.h = h * FAC_MIN;
                if fixed || tr.h < floor {
                    end(tr, Status::NonFinite { time: t0 }, start);
                    ended.push(id);
                }
                continue;
            }
            let safety = SAFETY * (2 * MAX_NEWTON + 1) as f64 / (2 * MAX_NEWTON + v.iters) as f64;
            if norm <= 1.0 {
                {
                    let zs = stage_slices::<NS>(zb, d);
                    let mut chunks = dense[id * d3..(id + 1) * d3].chunks_exact_mut(d);
                    let al: [&mut [f64]; NS] =
                        std::array::from_fn(|_| chunks.next().expect("NS stages"));
                    for p in 0..d {
                        for r in 0..NS {
                            al[r][p] = (0..NS).map(|i| tab.vinv[r][i] * zs[i][p]).sum();
                        }
                    }
                }
                {
                    let al = stage_slices::<NS>(&dense[id * d3..(id + 1) * d3], d);
                    tr.emit(id, s, t0, h, d, &mut rec, |th, out| {
                        for (p, o) in out[..d].iter_mut().enumerate() {
                            let mut acc = al[NS - 1][p];
                            for r in (0..NS - 1).rev() {
                                acc = al[r][p] + th * acc;
                            }
                            *o = yb[p] + th * acc;
                        }
                    });
                }
                y[id * d..(id + 1) * d].copy_from_slice(&ynew);
                sys.project(id, &mut y[id * d..(id + 1) * d]);
                tr.t = if h == s.t_end - t0 { s.t_end } else { t0 + h };
                tr.stats.steps += 1;
                tr.last_rejected = false;
                v.have_dense = true;
                v.h_old = h;
                v.need_f0 = true;
                if !v.jac_current {
                    // Converged on a reused Jacobian.
                    v.reuse_fails *= REUSE_MEMORY;
                }
                v.jac_current = false;
                let theta_jac = if v.reuse_fails > REUSE_FAILING {
                    THETA_JAC_MIN
                } else {
                    THETA_JAC
                };
                v.need_jac = v.rate.theta > theta_jac;
                if v.have_f3 && !v.need_jac && share_f0() {
                    // f(y_new) ≈ f(s3) + J (y_new − s3) ([`share_f0`]).
                    let yn = &y[id * d..(id + 1) * d];
                    let (sv, fv) = (&s3[id * d..(id + 1) * d], &f3[id * d..(id + 1) * d]);
                    let jm = &jac[id];
                    for p in 0..d {
                        let row = &jm[p * d..p * d + jd];
                        let lin: f64 = row
                            .iter()
                            .zip(&yn[..jd])
                            .zip(&sv[..jd])
                            .map(|((&j, &a), &b)| j * (a - b))
                            .sum();
                        f0[id * d + p] = fv[p] + lin;
                    }
                    v.need_f0 = false;
                    v.f0_shared = true;
                }
                let fac = if norm == 0.0 {
                    FAC_MAX
                } else {
                    (safety * norm.powf(tab.expo)).clamp(FAC_MIN, FAC_MAX)
                };
                tr.h = if fixed {
                    s.fixed_step.unwrap_or(h)
                } else if !v.need_jac && (1.0..=KEEP_H_MAX).contains(&fac) {
                    h
                } else {
                    h * fac
                };
                if let Some(status) = status_after_accepted(tr, s) {
                    end(tr, status, start);
                    ended.push(id);
                }
            } else {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * (safety * norm.powf(tab.expo)).max(FAC_MIN);
                if tr.h < floor {
                    let step = tr.h;
                    end(tr, Status::StepSizeTooSmall { time: t0, step }, start);
                    ended.push(id);
                }
            }
        }
        active.retain(|&id| matches!(tracks[id].status, Status::Running));
        rec.flush_records(sys);
        notify(sys, tracks, &mut ended);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        /// Evaluate `f(y)` after every accepted step ([`share_f0`] off), for comparisons.
        pub(super) static EXACT_F0: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    /// Van der Pol oscillators `y0' = y1`, `y1' = μ ((1 − y0²) y1 − y0)` with their
    /// samples, for [`share_f0`]'s test.
    struct VdP {
        mu: Vec<f64>,
        samples: Vec<Vec<[f64; 2]>>,
    }

    impl BatchSystem for VdP {
        type Fault = String;
        fn dim(&self) -> usize {
            2
        }
        fn eval(
            &mut self,
            ids: &[usize],
            _ts: &[f64],
            ys: &[f64],
            dys: &mut [f64],
            _faults: &mut [Option<String>],
        ) {
            for (k, &id) in ids.iter().enumerate() {
                let (a, b) = (ys[2 * k], ys[2 * k + 1]);
                dys[2 * k] = b;
                dys[2 * k + 1] = self.mu[id] * ((1.0 - a * a) * b - a);
            }
        }
        fn record(&mut self, ids: &[usize], _ts: &[f64], ys: &[f64]) {
            for (k, &id) in ids.iter().enumerate() {
                self.samples[id].push([ys[2 * k], ys[2 * k + 1]]);
            }
        }
        fn finished(&mut self, _id: usize, _status: &Status<String>, _stats: &Stats) {}
    }

    /// Runs the oscillators (μ = 10, 100, 1000 from (2, 0) over 1.5 time units; the
    /// stiff ones cross a relaxation jump) by `method` at `tol`, with `f(y)` evaluated
    /// after every step or shared ([`share_f0`]): samples and counters.
    fn vdp(method: crate::integrate::Method, tol: f64, exact: bool) -> (VdP, Vec<Stats>) {
        let mu = vec![10.0, 100.0, 1000.0];
        let n = mu.len();
        let mut sys = VdP {
            mu,
            samples: vec![Vec::new(); n],
        };
        let s = Settings {
            t_end: 1.5,
            sample_interval: 0.01,
            rtol: tol,
            atol: tol,
            ..Settings::default()
        };
        let y0: Vec<f64> = (0..n).flat_map(|_| [2.0, 0.0]).collect();
        EXACT_F0.with(|c| c.set(exact));
        let out = crate::integrate::run_batch(method, &mut sys, &y0, &vec![s; n]);
        EXACT_F0.with(|c| c.set(false));
        for (st, _) in &out {
            assert!(matches!(st, Status::Finished), "{st:?}");
        }
        (sys, out.into_iter().map(|(_, s)| s).collect())
    }

    /// The largest sample distance of each variant to the reference's.
    fn errors(a: &VdP, r: &VdP) -> Vec<f64> {
        a.samples
            .iter()
            .zip(&r.samples)
            .map(|(x, y)| {
                assert_eq!(x.len(), y.len());
                x.iter()
                    .zip(y)
                    .map(|(p, q)| (p[0] - q[0]).abs().max((p[1] - q[1]).abs() / 1e3))
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    #[test]
    fn sharing_f_of_the_step_end_keeps_the_steps_and_the_error_with_fewer_evaluations() {
        use crate::integrate::Method;
        let (reference, _) = vdp(Method::Radau5, 1e-12, true);
        // Neighbouring tolerances per decade: through the relaxation jumps the error
        // at one tolerance scatters by up to 4x with any change of the step sequence
        // (the exact runs: 9.0e-6, 3.0e-5, 3.9e-5 m at 1e-5, 1.1e-5, 1.2e-5 for μ = 1000).
        for group in [&[1e-5, 1.1e-5, 1.2e-5][..], &[1e-6, 1.1e-6], &[1e-7]] {
            let mut worst = [[0.0f64; 3]; 2];
            for &tol in group {
                let (exact, se) = vdp(Method::Radau5, tol, true);
                let (shared, ss) = vdp(Method::Radau5, tol, false);
                for (w, run) in worst.iter_mut().zip([&exact, &shared]) {
                    for (m, e) in w.iter_mut().zip(errors(run, &reference)) {
                        *m = m.max(e);
                    }
                }
                for (k, (a, b)) in se.iter().zip(&ss).enumerate() {
                    // The same step sequence to 2 % and a few rejections: the shared
                    // f(y) steers the error estimate as f(y) does. One right-hand side
                    // fewer per accepted step without a Jacobian at its end (at least
                    // half of those, as rejections and Jacobians move a little).
                    assert!(
                        b.steps.abs_diff(a.steps) * 50 <= a.steps && b.rejected <= a.rejected + 3,
                        "tol {tol}, variant {k}: steps {} / rejected {} shared against {} / {} exact",
                        b.steps,
                        b.rejected,
                        a.steps,
                        a.rejected
                    );
                    let saved = a.rhs_evaluations as f64 - b.rhs_evaluations as f64;
                    let expected = (b.steps - b.jacobians.min(b.steps)) as f64;
                    assert!(
                        saved >= 0.5 * expected,
                        "tol {tol}, variant {k}: {} right-hand sides shared against {} exact \
                         ({} steps, {} Jacobians)",
                        b.rhs_evaluations,
                        a.rhs_evaluations,
                        b.steps,
                        b.jacobians
                    );
                }
            }
            // The error within the exact runs' scatter: at most twice their worst or the
            // tolerance. (A Jacobian formed against the shared estimate instead of f(y)
            // took μ = 10 to an error of 2.2.)
            let top = group.iter().copied().fold(0.0, f64::max);
            for k in 0..3 {
                let (e, s) = (worst[0][k], worst[1][k]);
                assert!(
                    s <= (2.0 * e).max(top),
                    "tolerances {group:?}, variant {k}: worst error {s:.3e} shared against \
                     {e:.3e} exact"
                );
                assert!(
                    e <= 30.0 * top,
                    "variant {k}: exact error {e:.3e} at {group:?}"
                );
            }
        }
    }

    /// radau5's closed forms against [`super::super::tableau::radau_iia`] at 3 stages:
    /// the derivation radau9 uses reproduces them.
    #[test]
    fn derived_constants_reproduce_radau5s_closed_forms() {
        let k = super::super::tableau::radau_iia(3);
        let tab = Tableau::radau5();
        for i in 0..3 {
            assert!((k.c[i] - C[i]).abs() < 1e-15, "c[{i}]");
            assert!(
                (k.ez[i] - EZ[i]).abs() < 1e-12 * EZ[i].abs(),
                "ez[{i}]: {} against {}",
                k.ez[i],
                EZ[i]
            );
            for j in 0..3 {
                assert!((k.a[i][j] - A[i][j]).abs() < 1e-15, "a[{i}][{j}]");
                assert!(
                    (k.vinv[i][j] - tab.vinv[i][j]).abs() < 1e-12,
                    "vinv[{i}][{j}]"
                );
            }
        }
        assert!((k.gamma - tab.gamma).abs() < 1e-13, "gamma");
        assert!((k.pairs[0].0 - tab.pairs[0].0).abs() < 1e-13, "alpha");
        assert!(
            (k.pairs[0].1.abs() - tab.pairs[0].1.abs()).abs() < 1e-13,
            "beta"
        );
    }

    #[test]
    fn eigenbasis_diagonalises_the_inverse_radau_matrix() {
        let eb = eigenbasis();
        let m = Matrix3::from_fn(|i, j| A[i][j]).try_inverse().unwrap();
        let t = Matrix3::from_fn(|i, j| eb.t[i][j]);
        let ti = Matrix3::from_fn(|i, j| eb.ti[i][j]);
        let lam = Matrix3::new(
            eb.gamma, 0.0, 0.0, 0.0, eb.alpha, eb.beta, 0.0, -eb.beta, eb.alpha,
        );
        let res = (m * t - t * lam).abs().max();
        assert!(
            res < 1e-12,
            "|A^-1 T - T Lambda| = {res:.3e}, tolerance 1e-12"
        );
        let inv = (ti * t - Matrix3::identity()).abs().max();
        assert!(inv < 1e-13, "|T^-1 T - I| = {inv:.3e}, tolerance 1e-13");
        assert!(
            (eb.gamma - mu_real()).abs() < 1e-13,
            "gamma {} against 3 + 3^(2/3) - 3^(1/3) = {}",
            eb.gamma,
            mu_real()
        );
        // Hairer-Wanner IV.8: A^-1's complex pair is 2.6811 ± 3.0504 i.
        assert!(
            (eb.alpha - 2.681_082_873_627_752).abs() < 1e-12,
            "alpha {}",
            eb.alpha
        );
        assert!(
            (eb.beta.abs() - 3.050_430_199_247_41).abs() < 1e-12,
            "beta {}",
            eb.beta
        );
    }
}
