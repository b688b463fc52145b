//! Radau5's Newton matrices `σ I − J` solved on the components that need a dense LU.
//!
//! Two kinds of components are eliminated in closed form before the factorisation:
//!
//! - **kinematic** ones, `f_i = y_j` exactly ([`BatchSystem::kinematic_pairs`], e.g. a
//!   rotor's position whose rate is its velocity): row `i` of `(σ I − J) x = b` is
//!   `σ x_i − x_j = b_i`, so `x_i = (b_i + x_j) / σ`, and substituting it into the other
//!   rows adds `−J_{r i} / σ` to their column `j` and `J_{r i} b_i / σ` to their right-hand
//!   side;
//! - **quadratures** (components from [`BatchSystem::jacobian_dim`] on, which `f` does not
//!   depend on, e.g. the work done): their columns of `J` are zero, so `σ I − J` is block
//!   lower triangular and `x_q = (b_q + Σ_c J_{q c} x_c) / σ` once the others are known.
//!
//! What is left (the rotor's 12 components less two positions and the work: 9) goes
//! through the dense LU of [`super::linalg`]: `(9/12)³` of its factorisation work and
//! `(9/12)²` of its solves. The solution is the same as the full system's up to rounding
//! (unit tests: `1e-12` relative on random Jacobians with this structure).
//!
//! [`BatchSystem::kinematic_pairs`]: super::system::BatchSystem::kinematic_pairs
//! [`BatchSystem::jacobian_dim`]: super::system::BatchSystem::jacobian_dim

use super::linalg::{ComplexLu, RealLu};

/// Which components of a `d`-dimensional system are eliminated, and the order of the rest.
#[derive(Clone, Debug)]
pub(crate) struct Reduction {
    d: usize,
    /// Components `f` depends on (`0..jd`); the rest are quadratures.
    jd: usize,
    /// `(i, j)`: `f_i = y_j`, `i` eliminated, `j` kept.
    kin: Vec<(usize, usize)>,
    /// Kept components, ascending: reduced index `a` is component `keep[a]`.
    keep: Vec<usize>,
    /// Reduced index of each component (`usize::MAX` if eliminated).
    pos: Vec<usize>,
}

impl Reduction {
    /// The reduction of a `d`-dimensional system whose `f` depends on components
    /// `0..jd` only, with kinematic pairs `pairs`. Pairs that do not fit (out of range,
    /// `i == j`, `i` repeated, `j` itself eliminated or a quadrature) are ignored, so a
    /// system that declares nothing usable is solved in full (`0..jd` kept).
    pub(crate) fn new(d: usize, jd: usize, pairs: &[(usize, usize)]) -> Self {
        let jd = jd.min(d);
        let mut kin: Vec<(usize, usize)> = Vec::new();
        for &(i, j) in pairs {
            let fits =
                i < jd && j < jd && i != j && !kin.iter().any(|&(a, b)| a == i || b == i || a == j);
            if fits {
                kin.push((i, j));
            }
        }
        let keep: Vec<usize> = (0..jd).filter(|c| !kin.iter().any(|k| k.0 == *c)).collect();
        let mut pos = vec![usize::MAX; d];
        for (a, &c) in keep.iter().enumerate() {
            pos[c] = a;
        }
        Reduction {
            d,
            jd,
            kin,
            keep,
            pos,
        }
    }

    /// Size of the system factorised.
    pub(crate) fn size(&self) -> usize {
        self.keep.len()
    }
}

/// Complex shifts a [`NewtonLu`] holds at most: one for radau5 (3 stages), two for
/// radau9 (5 stages: one real eigenvalue and two complex pairs).
pub(crate) const MAX_PAIRS: usize = 2;

/// The factorisations of one variant's `γ I − J` (real `γ`) and `(α_k + iβ_k) I − J` for
/// each complex shift `k` (one for radau5, two for radau9), with the Jacobian entries the
/// eliminations need.
#[derive(Clone, Debug, Default)]
pub(crate) struct NewtonLu {
    real: RealLu,
    cplx: [ComplexLu; MAX_PAIRS],
    /// The real shift `γ` and the complex ones `(α_k, β_k)` of the last factorisation.
    gamma: f64,
    shifts: [(f64, f64); MAX_PAIRS],
    /// Complex shifts factorised.
    pairs: usize,
    /// `J_{keep[a], i}` for each kinematic pair `(i, _)`, row-major `size x kin.len()`.
    jk: Vec<f64>,
    /// The quadrature rows of `J`, columns `0..jd`, row-major.
    jq: Vec<f64>,
    /// Scratch: `−J_RR`, matrices being built, reduced right-hand sides.
    base: Vec<f64>,
    m_re: Vec<f64>,
    m_im: Vec<f64>,
    r_re: Vec<f64>,
    r_im: Vec<f64>,
    /// Scratch: the eliminated components' right-hand sides over the shift.
    q_re: Vec<f64>,
    q_im: Vec<f64>,
}

impl NewtonLu {
    /// Factorises `γ I − J` and `(α_k + iβ_k) I − J` for each `(α_k, β_k)` of `pairs`
    /// (at most [`MAX_PAIRS`]; `jac` row-major `d x d`) reduced by `red`.
    pub(crate) fn factor(
        &mut self,
        red: &Reduction,
        gamma: f64,
        pairs: &[(f64, f64)],
        jac: &[f64],
    ) {
        let (d, n, nk) = (red.d, red.size(), red.kin.len());
        debug_assert_eq!(jac.len(), d * d);
        assert!(
            pairs.len() <= MAX_PAIRS,
            "at most {MAX_PAIRS} complex shifts"
        );
        self.gamma = gamma;
        self.pairs = pairs.len();
        self.shifts[..pairs.len()].copy_from_slice(pairs);
        self.jk.clear();
        for &r in &red.keep {
            for &(i, _) in &red.kin {
                self.jk.push(jac[r * d + i]);
            }
        }
        self.jq.clear();
        for q in red.jd..d {
            self.jq.extend_from_slice(&jac[q * d..q * d + red.jd]);
        }
        // −J_RR gathered once (`base`), then per shift: the diagonal, and −J_{r i} / σ into
        // column j of each pair.
        if n == 0 {
            // Nothing to factorise (no component `f` depends on).
            return;
        }
        self.base.clear();
        self.base.resize(n * n, 0.0);
        for (row, &r) in self.base.chunks_exact_mut(n).zip(&red.keep) {
            let jrow = &jac[r * d..(r + 1) * d];
            for (o, &c) in row.iter_mut().zip(&red.keep) {
                *o = -jrow[c];
            }
        }
        // Real: γ I − J_RR − Σ J_{R i} e_jᵀ / γ.
        self.m_re.clear();
        self.m_re.extend_from_slice(&self.base);
        for (a, row) in self.m_re.chunks_exact_mut(n).enumerate() {
            row[a] += gamma;
            let jk = &self.jk[a * nk..(a + 1) * nk];
            for (&jv, &(_, j)) in jk.iter().zip(&red.kin) {
                row[red.pos[j]] -= jv / gamma;
            }
        }
        self.real.factor_matrix(&mut self.m_re, n);
        for (k, &(alpha, beta)) in pairs.iter().enumerate() {
            // Complex: σ = α + iβ, 1/σ = (α − iβ) / (α² + β²).
            let den = alpha * alpha + beta * beta;
            let (ir, ii) = (alpha / den, -beta / den);
            self.m_re.clear();
            self.m_re.extend_from_slice(&self.base);
            self.m_im.clear();
            self.m_im.resize(n * n, 0.0);
            let rows = self
                .m_re
                .chunks_exact_mut(n)
                .zip(self.m_im.chunks_exact_mut(n));
            for (a, (row_r, row_i)) in rows.enumerate() {
                row_r[a] += alpha;
                row_i[a] = beta;
                let jk = &self.jk[a * nk..(a + 1) * nk];
                for (&jv, &(_, j)) in jk.iter().zip(&red.kin) {
                    row_r[red.pos[j]] -= jv * ir;
                    row_i[red.pos[j]] -= jv * ii;
                }
            }
            self.cplx[k].factor_matrix(&mut self.m_re, &mut self.m_im, n);
        }
    }

    /// The last factorisation met a zero pivot or a non-finite entry.
    pub(crate) fn singular(&self) -> bool {
        self.real.singular || self.cplx[..self.pairs].iter().any(|c| c.singular)
    }

    /// Whether `red` is the rigid rotor's reduction (12 components, 11 in the Jacobian, two
    /// kinematic pairs, 9 kept): the solves then run [`NewtonLu::solve_real_sized`] and
    /// [`NewtonLu::solve_complex_sized`] with these sizes as constants.
    fn rotor_sized(red: &Reduction, len: usize) -> bool {
        red.d == 12 && red.jd == 11 && red.kin.len() == 2 && red.keep.len() == 9 && len == 12
    }

    /// Solves `(γ I − J) x = b` in place (`b`, length `d`, becomes `x`).
    pub(crate) fn solve_real(&mut self, red: &Reduction, b: &mut [f64]) {
        if Self::rotor_sized(red, b.len()) {
            // The same operations in the same order with the sizes known (issue 28, tenth
            // pass: the general loops' bookkeeping was ~40 % of a solve).
            return self.solve_real_sized::<9, 2, 12, 11>(red, b);
        }
        let (n, nk, g) = (red.size(), red.kin.len(), self.gamma);
        // `b_i / γ` of each eliminated component, once (the same quotient every row used).
        self.q_re.clear();
        self.q_re.extend(red.kin.iter().map(|&(i, _)| b[i] / g));
        self.r_re.clear();
        for (a, &r) in red.keep.iter().enumerate() {
            let mut s = b[r];
            for (&jv, &q) in self.jk[a * nk..(a + 1) * nk].iter().zip(&self.q_re) {
                s += jv * q;
            }
            self.r_re.push(s);
        }
        self.real.solve(&mut self.r_re);
        for (a, &r) in red.keep.iter().enumerate() {
            b[r] = self.r_re[a];
        }
        for &(i, j) in &red.kin {
            b[i] = (b[i] + b[j]) / g;
        }
        for (q, row) in (red.jd..red.d).zip(self.jq.chunks_exact(red.jd.max(1))) {
            let mut s = b[q];
            for (c, &jv) in row.iter().enumerate() {
                s += jv * b[c];
            }
            b[q] = s / g;
        }
        debug_assert_eq!(self.r_re.len(), n);
    }

    /// [`NewtonLu::solve_real`] with `N` kept components, `NK` kinematic pairs, `D`
    /// components and `JD` in the Jacobian as constants (the caller checked them): the
    /// same operations in the same order, on arrays.
    #[inline(always)]
    fn solve_real_sized<const N: usize, const NK: usize, const D: usize, const JD: usize>(
        &mut self,
        red: &Reduction,
        b: &mut [f64],
    ) {
        let g = self.gamma;
        let b: &mut [f64; D] = b.try_into().expect("checked by rotor_sized");
        let kin: &[(usize, usize); NK] = red.kin[..].try_into().expect("checked");
        let keep: &[usize; N] = red.keep[..].try_into().expect("checked");
        let jk = &self.jk[..N * NK];
        let mut q = [0.0; NK];
        for k in 0..NK {
            q[k] = b[kin[k].0] / g;
        }
        let mut r = [0.0; N];
        for a in 0..N {
            let mut s = b[keep[a]];
            for k in 0..NK {
                s += jk[a * NK + k] * q[k];
            }
            r[a] = s;
        }
        self.real.solve(&mut r);
        for a in 0..N {
            b[keep[a]] = r[a];
        }
        for &(i, j) in kin {
            b[i] = (b[i] + b[j]) / g;
        }
        for qc in JD..D {
            let row: &[f64; JD] = self.jq[(qc - JD) * JD..(qc - JD + 1) * JD]
                .try_into()
                .expect("JD entries a row");
            let mut s = b[qc];
            for c in 0..JD {
                s += row[c] * b[c];
            }
            b[qc] = s / g;
        }
    }

    /// [`NewtonLu::solve_complex`] with the sizes as constants, as
    /// [`NewtonLu::solve_real_sized`].
    #[inline(always)]
    fn solve_complex_sized<const N: usize, const NK: usize, const D: usize, const JD: usize>(
        &mut self,
        red: &Reduction,
        pair: usize,
        br: &mut [f64],
        bi: &mut [f64],
    ) {
        let (alpha, beta) = self.shifts[pair];
        let den = alpha * alpha + beta * beta;
        let (ir, ii) = (alpha / den, -beta / den);
        let over = |u: f64, v: f64| (u * ir - v * ii, u * ii + v * ir);
        let br: &mut [f64; D] = br.try_into().expect("checked by rotor_sized");
        let bi: &mut [f64; D] = bi.try_into().expect("checked by rotor_sized");
        let kin: &[(usize, usize); NK] = red.kin[..].try_into().expect("checked");
        let keep: &[usize; N] = red.keep[..].try_into().expect("checked");
        let jk = &self.jk[..N * NK];
        let (mut q_re, mut q_im) = ([0.0; NK], [0.0; NK]);
        for k in 0..NK {
            let i = kin[k].0;
            (q_re[k], q_im[k]) = over(br[i], bi[i]);
        }
        let (mut r_re, mut r_im) = ([0.0; N], [0.0; N]);
        for a in 0..N {
            let (mut sr, mut si) = (br[keep[a]], bi[keep[a]]);
            for k in 0..NK {
                let jv = jk[a * NK + k];
                sr += jv * q_re[k];
                si += jv * q_im[k];
            }
            r_re[a] = sr;
            r_im[a] = si;
        }
        self.cplx[pair].solve(&mut r_re, &mut r_im);
        for a in 0..N {
            br[keep[a]] = r_re[a];
            bi[keep[a]] = r_im[a];
        }
        for &(i, j) in kin {
            let (qr, qi) = over(br[i] + br[j], bi[i] + bi[j]);
            br[i] = qr;
            bi[i] = qi;
        }
        for qc in JD..D {
            let row: &[f64; JD] = self.jq[(qc - JD) * JD..(qc - JD + 1) * JD]
                .try_into()
                .expect("JD entries a row");
            let (mut sr, mut si) = (br[qc], bi[qc]);
            for c in 0..JD {
                sr += row[c] * br[c];
                si += row[c] * bi[c];
            }
            let (qr, qi) = over(sr, si);
            br[qc] = qr;
            bi[qc] = qi;
        }
    }

    /// Solves `((α_k + iβ_k) I − J) x = b` in place for `b = br + i bi` (length `d` each),
    /// `k = pair` (below the number of shifts factorised).
    pub(crate) fn solve_complex(
        &mut self,
        red: &Reduction,
        pair: usize,
        br: &mut [f64],
        bi: &mut [f64],
    ) {
        debug_assert!(pair < self.pairs);
        if Self::rotor_sized(red, br.len()) && bi.len() == 12 {
            return self.solve_complex_sized::<9, 2, 12, 11>(red, pair, br, bi);
        }
        let nk = red.kin.len();
        let (alpha, beta) = self.shifts[pair];
        let den = alpha * alpha + beta * beta;
        let (ir, ii) = (alpha / den, -beta / den);
        // (u + iv) / σ.
        let over = |u: f64, v: f64| (u * ir - v * ii, u * ii + v * ir);
        // `b_i / σ` of each eliminated component, once (the same quotient every row used).
        self.q_re.clear();
        self.q_im.clear();
        for &(i, _) in &red.kin {
            let (qr, qi) = over(br[i], bi[i]);
            self.q_re.push(qr);
            self.q_im.push(qi);
        }
        self.r_re.clear();
        self.r_im.clear();
        for (a, &r) in red.keep.iter().enumerate() {
            let (mut sr, mut si) = (br[r], bi[r]);
            let q = self.q_re.iter().zip(&self.q_im);
            for (&jv, (&qr, &qi)) in self.jk[a * nk..(a + 1) * nk].iter().zip(q) {
                sr += jv * qr;
                si += jv * qi;
            }
            self.r_re.push(sr);
            self.r_im.push(si);
        }
        self.cplx[pair].solve(&mut self.r_re, &mut self.r_im);
        for (a, &r) in red.keep.iter().enumerate() {
            br[r] = self.r_re[a];
            bi[r] = self.r_im[a];
        }
        for &(i, j) in &red.kin {
            let (qr, qi) = over(br[i] + br[j], bi[i] + bi[j]);
            br[i] = qr;
            bi[i] = qi;
        }
        for (q, row) in (red.jd..red.d).zip(self.jq.chunks_exact(red.jd.max(1))) {
            let (mut sr, mut si) = (br[q], bi[q]);
            for (c, &jv) in row.iter().enumerate() {
                sr += jv * br[c];
                si += jv * bi[c];
            }
            let (qr, qi) = over(sr, si);
            br[q] = qr;
            bi[q] = qi;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// A random `d x d` Jacobian with the rotor's structure: `f_0 = y_2`, `f_1 = y_3`,
    /// column `d − 1` zero (a quadrature).
    fn structured(d: usize, seed: &mut u64) -> Vec<f64> {
        let mut j: Vec<f64> = (0..d * d).map(|_| 10.0 * rng(seed)).collect();
        for r in 0..d {
            j[r * d + d - 1] = 0.0;
        }
        for (i, jj) in [(0, 2), (1, 3)] {
            for c in 0..d {
                j[i * d + c] = if c == jj { 1.0 } else { 0.0 };
            }
        }
        j
    }

    #[test]
    fn reduced_solves_equal_the_full_ones() {
        let d = 12;
        let mut seed = 0x1234_5678_9abc_def1_u64;
        let red = Reduction::new(d, d - 1, &[(0, 2), (1, 3)]);
        assert_eq!(red.size(), 9);
        for case in 0..50 {
            let j = structured(d, &mut seed);
            // Shifts of the size radau5 uses (γ/h, (α, β)/h for h from 1e-5 to 1).
            let h = 10f64.powf(-5.0 * (rng(&mut seed) + 1.0) / 2.0);
            let (g, a, b) = (3.637 / h, 2.681 / h, 3.050 / h);
            let mut lu = NewtonLu::default();
            // The second shift as radau9's second pair (a different matrix).
            lu.factor(&red, g, &[(a, b), (0.5 * a, 2.0 * b)], &j);
            assert!(!lu.singular());
            let b0: Vec<f64> = (0..d).map(|_| rng(&mut seed)).collect();
            let b1: Vec<f64> = (0..d).map(|_| rng(&mut seed)).collect();
            let mut full = RealLu::default();
            full.factor_shifted(g, &j, d);
            let (mut want, mut got) = (b0.clone(), b0.clone());
            full.solve(&mut want);
            lu.solve_real(&red, &mut got);
            let size = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            for k in 0..d {
                assert!(
                    (got[k] - want[k]).abs() <= 1e-12 * size,
                    "case {case}, real x[{k}]: {} against {}",
                    got[k],
                    want[k]
                );
            }
            for (pair, (sa, sb)) in [(a, b), (0.5 * a, 2.0 * b)].into_iter().enumerate() {
                let mut fc = ComplexLu::default();
                fc.factor_shifted(sa, sb, &j, d);
                let (mut wr, mut wi) = (b0.clone(), b1.clone());
                fc.solve(&mut wr, &mut wi);
                let (mut gr, mut gi) = (b0.clone(), b1.clone());
                lu.solve_complex(&red, pair, &mut gr, &mut gi);
                let size = wr.iter().chain(&wi).fold(0.0_f64, |m, v| m.max(v.abs()));
                for k in 0..d {
                    assert!(
                        (gr[k] - wr[k]).abs() <= 1e-12 * size
                            && (gi[k] - wi[k]).abs() <= 1e-12 * size,
                        "case {case}, pair {pair}, complex x[{k}]: ({}, {}) against ({}, {})",
                        gr[k],
                        gi[k],
                        wr[k],
                        wi[k]
                    );
                }
            }
        }
    }

    #[test]
    fn unusable_pairs_are_ignored_and_singular_matrices_flagged() {
        // Out of range, i == j, a chain (3 -> 0 while 0 is eliminated), a repeat.
        let red = Reduction::new(6, 5, &[(0, 1), (7, 1), (2, 2), (3, 0), (0, 4), (4, 5)]);
        assert_eq!(red.kin, vec![(0, 1)]);
        assert_eq!(red.keep, vec![1, 2, 3, 4]);
        // No pairs, no quadratures: the full system.
        let full = Reduction::new(4, 4, &[]);
        assert_eq!(full.size(), 4);
        let mut lu = NewtonLu::default();
        let mut j = vec![0.0; 16];
        j[5] = f64::NAN;
        lu.factor(&full, 1.0, &[(1.0, 1.0)], &j);
        assert!(lu.singular(), "NaN entry not flagged");
        // γ I − J singular: J = γ I.
        let j: Vec<f64> = (0..16)
            .map(|k| if k % 5 == 0 { 2.0 } else { 0.0 })
            .collect();
        lu.factor(&full, 2.0, &[(1.0, 1.0)], &j);
        assert!(lu.singular(), "zero pivot not flagged");
    }
}
