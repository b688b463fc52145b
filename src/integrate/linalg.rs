//! The implicit method's Newton matrices: small dense LU factorisations with partial
//! pivoting of `σ I − J` for a real shift (`σ` real) and a complex one (`σ = σr + i σi`,
//! the complex matrix kept as its real and imaginary parts), written out for the rotor's
//! small Jacobians (no allocation per factorisation, no generic matrix layer; the rotor's
//! reduced 9 x 9 systems get a copy of each kernel compiled for that size), plus the
//! singularity test the step logic needs.

/// `P (σ I − J) = L U` for a real shift `σ`, `J` row-major `n x n`, kept for repeated
/// solves.
#[derive(Clone, Debug, Default)]
pub(crate) struct RealLu {
    n: usize,
    /// `L` (unit diagonal, below) and `U` (above the diagonal; on it the reciprocals of
    /// `U`'s diagonal, the pivots), row-major.
    a: Vec<f64>,
    /// Row exchanged with row `k` at step `k`.
    piv: Vec<usize>,
    /// The last factorisation met a zero pivot or a non-finite entry.
    pub singular: bool,
}

impl RealLu {
    /// Factorises `shift I − jac` (`jac` row-major `n x n`, `n² = jac.len()`): the full
    /// system, the reference of `super::reduced`'s tests.
    #[cfg(test)]
    pub(crate) fn factor_shifted(&mut self, shift: f64, jac: &[f64], n: usize) {
        debug_assert_eq!(jac.len(), n * n);
        self.n = n;
        self.a.clear();
        self.a.extend(jac.iter().map(|&v| -v));
        for k in 0..n {
            self.a[k * n + k] += shift;
        }
        self.eliminate();
    }

    /// Factorises the `n x n` row-major matrix `a` (moved in: its storage is reused).
    pub(crate) fn factor_matrix(&mut self, a: &mut Vec<f64>, n: usize) {
        debug_assert_eq!(a.len(), n * n);
        self.n = n;
        std::mem::swap(&mut self.a, a);
        self.eliminate();
    }

    /// LU with partial pivoting of `self.a` in place.
    fn eliminate(&mut self) {
        // The rotor's reduced systems are 9 x 9: that size gets its own copy of the loops
        // with the bounds known at compile time (unrolled, no bounds checks; the same
        // operations in the same order, so the same bits).
        self.singular = match self.n {
            ROTOR_N => real_eliminate(ROTOR_N, &mut self.a, &mut self.piv),
            n => real_eliminate(n, &mut self.a, &mut self.piv),
        };
    }

    /// Solves `(σ I − J) x = b` in place (`b` becomes `x`) with the last factorisation.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        match self.n {
            ROTOR_N => real_solve(ROTOR_N, &self.a, &self.piv, b),
            n => real_solve(n, &self.a, &self.piv, b),
        }
    }
}

/// `P (σ I − J) = L U` for a complex shift `σ = σr + i σi` and a real `J`, the factors
/// kept as real and imaginary parts, for repeated solves.
#[derive(Clone, Debug, Default)]
pub(crate) struct ComplexLu {
    n: usize,
    re: Vec<f64>,
    im: Vec<f64>,
    piv: Vec<usize>,
    /// The last factorisation met a zero pivot or a non-finite entry.
    pub singular: bool,
}

impl ComplexLu {
    /// Factorises `(shift_re + i shift_im) I − jac` (`jac` row-major `n x n`): the full
    /// system, the reference of `super::reduced`'s tests.
    #[cfg(test)]
    pub(crate) fn factor_shifted(&mut self, shift_re: f64, shift_im: f64, jac: &[f64], n: usize) {
        debug_assert_eq!(jac.len(), n * n);
        self.n = n;
        self.re.clear();
        self.re.extend(jac.iter().map(|&v| -v));
        self.im.clear();
        self.im.resize(n * n, 0.0);
        for k in 0..n {
            self.re[k * n + k] += shift_re;
            self.im[k * n + k] = shift_im;
        }
        self.eliminate();
    }

    /// Factorises the `n x n` row-major complex matrix `re + i im` (moved in: their
    /// storage is reused).
    pub(crate) fn factor_matrix(&mut self, re: &mut Vec<f64>, im: &mut Vec<f64>, n: usize) {
        debug_assert!(re.len() == n * n && im.len() == n * n);
        self.n = n;
        std::mem::swap(&mut self.re, re);
        std::mem::swap(&mut self.im, im);
        self.eliminate();
    }

    /// LU with partial pivoting of `self.re + i self.im` in place.
    fn eliminate(&mut self) {
        // As [`RealLu`]'s: the rotor's size gets its own copy of the loops.
        self.singular = match self.n {
            ROTOR_N => complex_eliminate(ROTOR_N, &mut self.re, &mut self.im, &mut self.piv),
            n => complex_eliminate(n, &mut self.re, &mut self.im, &mut self.piv),
        };
    }

    /// Solves `(σ I − J) x = b` in place for `b = br + i bi`.
    pub(crate) fn solve(&self, br: &mut [f64], bi: &mut [f64]) {
        match self.n {
            ROTOR_N => complex_solve(ROTOR_N, &self.re, &self.im, &self.piv, br, bi),
            n => complex_solve(n, &self.re, &self.im, &self.piv, br, bi),
        }
    }
}

/// Size of the rotor's reduced Newton systems (12 components less two positions and the
/// work: `super::reduced`), which gets its own compiled copy of each kernel below.
const ROTOR_N: usize = 9;

/// LU with partial pivoting of the `n x n` row-major `a` in place, pivots into `piv`;
/// returns whether a zero pivot or a non-finite entry was met. Inlined into each caller
/// so that a constant `n` gives loops of known length.
#[inline(always)]
fn real_eliminate(n: usize, a: &mut [f64], piv: &mut Vec<usize>) -> bool {
    let a = &mut a[..n * n];
    piv.clear();
    piv.resize(n, 0);
    // A non-finite entry (a Jacobian probe gone bad) makes the factors meaningless even
    // where no pivot is exactly zero.
    let mut singular = !a.iter().all(|v| v.is_finite());
    for k in 0..n {
        let mut p = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        piv[k] = p;
        if best == 0.0 {
            singular = true;
            // The solve multiplies by ±∞ here, as it divided by ±0 before.
            a[k * n + k] = 1.0 / a[k * n + k];
            continue;
        }
        if p != k {
            let (top, bottom) = a.split_at_mut(p * n);
            top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
        }
        let inv = 1.0 / a[k * n + k];
        // Kept in place of the pivot, which nothing else reads: the solve multiplies by
        // it instead of dividing (issue 28, sixteenth pass).
        a[k * n + k] = inv;
        // Row slices instead of indices (no bounds checks in the inner loop; the same
        // operations in the same order).
        let (top, bottom) = a.split_at_mut((k + 1) * n);
        let pivot_row = &top[k * n + k + 1..];
        for row in bottom.chunks_exact_mut(n) {
            let l = row[k] * inv;
            row[k] = l;
            if l != 0.0 {
                for (x, &u) in row[k + 1..].iter_mut().zip(pivot_row) {
                    *x -= l * u;
                }
            }
        }
    }
    singular
}

/// Forward and back substitution with [`real_eliminate`]'s factors (`b` becomes `x`).
#[inline(always)]
fn real_solve(n: usize, a: &[f64], piv: &[usize], b: &mut [f64]) {
    let (a, piv, b) = (&a[..n * n], &piv[..n], &mut b[..n]);
    for (k, &p) in piv.iter().enumerate() {
        b.swap(k, p);
    }
    for i in 1..n {
        let (done, rest) = b.split_at_mut(i);
        let mut s = rest[0];
        for (&l, &x) in a[i * n..i * n + i].iter().zip(done.iter()) {
            s -= l * x;
        }
        rest[0] = s;
    }
    for i in (0..n).rev() {
        let (head, tail) = b.split_at_mut(i + 1);
        let mut s = head[i];
        // From the last unknown back, so that the one just solved for comes last: each
        // row waits on its predecessor for one multiply-subtract, not for its whole sum
        // (a 9 x 9 solve was a chain of ~80 dependent operations; issue 28, sixteenth
        // pass).
        for (&u, &x) in a[i * n + i + 1..(i + 1) * n].iter().zip(tail.iter()).rev() {
            s -= u * x;
        }
        // The pivot's reciprocal (kept by `real_eliminate`).
        head[i] = s * a[i * n + i];
    }
}

/// LU with partial pivoting of the `n x n` row-major complex matrix `re + i im` in
/// place (as [`real_eliminate`]).
#[inline(always)]
fn complex_eliminate(n: usize, re: &mut [f64], im: &mut [f64], piv: &mut Vec<usize>) -> bool {
    let (re, im) = (&mut re[..n * n], &mut im[..n * n]);
    piv.clear();
    piv.resize(n, 0);
    let mut singular = !re.iter().chain(im.iter()).all(|v| v.is_finite());
    for k in 0..n {
        // Pivot: the largest |re| + |im| in the column (any norm serves).
        let mut p = k;
        let mut best = re[k * n + k].abs() + im[k * n + k].abs();
        for i in k + 1..n {
            let v = re[i * n + k].abs() + im[i * n + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        piv[k] = p;
        if best == 0.0 {
            singular = true;
            continue;
        }
        if p != k {
            let (top, bottom) = re.split_at_mut(p * n);
            top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
            let (top, bottom) = im.split_at_mut(p * n);
            top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
        }
        // 1 / pivot.
        let (pr, pi) = (re[k * n + k], im[k * n + k]);
        let den = pr * pr + pi * pi;
        let (ir, ii) = (pr / den, -pi / den);
        let (re_top, re_bottom) = re.split_at_mut((k + 1) * n);
        let (im_top, im_bottom) = im.split_at_mut((k + 1) * n);
        let (pr_row, pi_row) = (&re_top[k * n + k + 1..], &im_top[k * n + k + 1..]);
        for (row_r, row_i) in re_bottom
            .chunks_exact_mut(n)
            .zip(im_bottom.chunks_exact_mut(n))
        {
            let (ar, ai) = (row_r[k], row_i[k]);
            let (lr, li) = (ar * ir - ai * ii, ar * ii + ai * ir);
            row_r[k] = lr;
            row_i[k] = li;
            if lr != 0.0 || li != 0.0 {
                let pivot = pr_row.iter().zip(pi_row);
                for ((xr, xi), (&ur, &ui)) in row_r[k + 1..]
                    .iter_mut()
                    .zip(row_i[k + 1..].iter_mut())
                    .zip(pivot)
                {
                    *xr -= lr * ur - li * ui;
                    *xi -= lr * ui + li * ur;
                }
            }
        }
    }
    singular
}

/// Forward and back substitution with [`complex_eliminate`]'s factors for
/// `b = br + i bi` (becomes `x`).
#[inline(always)]
fn complex_solve(n: usize, re: &[f64], im: &[f64], piv: &[usize], br: &mut [f64], bi: &mut [f64]) {
    let (re, im, piv) = (&re[..n * n], &im[..n * n], &piv[..n]);
    let (br, bi) = (&mut br[..n], &mut bi[..n]);
    for (k, &p) in piv.iter().enumerate() {
        br.swap(k, p);
        bi.swap(k, p);
    }
    for i in 1..n {
        let (done_r, rest_r) = br.split_at_mut(i);
        let (done_i, rest_i) = bi.split_at_mut(i);
        let (mut sr, mut si) = (rest_r[0], rest_i[0]);
        let row = re[i * n..i * n + i].iter().zip(&im[i * n..i * n + i]);
        for ((&lr, &li), (&xr, &xi)) in row.zip(done_r.iter().zip(done_i.iter())) {
            sr -= lr * xr - li * xi;
            si -= lr * xi + li * xr;
        }
        rest_r[0] = sr;
        rest_i[0] = si;
    }
    for i in (0..n).rev() {
        let (head_r, tail_r) = br.split_at_mut(i + 1);
        let (head_i, tail_i) = bi.split_at_mut(i + 1);
        let (mut sr, mut si) = (head_r[i], head_i[i]);
        let row = re[i * n + i + 1..(i + 1) * n]
            .iter()
            .zip(&im[i * n + i + 1..(i + 1) * n]);
        for ((&ur, &ui), (&xr, &xi)) in row.zip(tail_r.iter().zip(tail_i.iter())) {
            sr -= ur * xr - ui * xi;
            si -= ur * xi + ui * xr;
        }
        let (pr, pi) = (re[i * n + i], im[i * n + i]);
        let den = pr * pr + pi * pi;
        head_r[i] = (sr * pr + si * pi) / den;
        head_i[i] = (si * pr - sr * pi) / den;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Residual max |(σ I − J) x − b| for a complex shift.
    fn residual(
        sr: f64,
        si: f64,
        j: &[f64],
        n: usize,
        x: (&[f64], &[f64]),
        b: (&[f64], &[f64]),
    ) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let mut rr = sr * x.0[i] - si * x.1[i];
            let mut ri = sr * x.1[i] + si * x.0[i];
            for k in 0..n {
                rr -= j[i * n + k] * x.0[k];
                ri -= j[i * n + k] * x.1[k];
            }
            worst = worst.max((rr - b.0[i]).abs()).max((ri - b.1[i]).abs());
        }
        worst
    }

    #[test]
    fn real_lu_solves_a_pivoting_system() {
        // σ I − J with σ = 1 equals [[0, 2, 1], [1, 1, 0], [3, 0, 1]] (a zero first pivot).
        let a = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let mut j = [0.0; 9];
        for k in 0..9 {
            j[k] = -a[k];
        }
        for k in 0..3 {
            j[k * 3 + k] += 1.0;
        }
        let mut lu = RealLu::default();
        lu.factor_shifted(1.0, &j, 3);
        assert!(!lu.singular);
        // A x = b for x = (1, 2, 3).
        let mut b = [7.0, 3.0, 6.0];
        lu.solve(&mut b);
        for (k, (got, want)) in b.iter().zip([1.0, 2.0, 3.0]).enumerate() {
            assert!(
                (got - want).abs() < 1e-14,
                "x[{k}] = {got}, want {want}, tolerance 1e-14"
            );
        }
    }

    #[test]
    fn complex_lu_solves_random_systems_and_matches_the_real_one() {
        let n = 13;
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..20 {
            let j: Vec<f64> = (0..n * n).map(|_| 10.0 * rnd()).collect();
            let (sr, si) = (5.0 * rnd(), 5.0 * rnd());
            let b0: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let b1: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut lu = ComplexLu::default();
            lu.factor_shifted(sr, si, &j, n);
            assert!(!lu.singular);
            let (mut xr, mut xi) = (b0.clone(), b1.clone());
            lu.solve(&mut xr, &mut xi);
            let res = residual(sr, si, &j, n, (&xr, &xi), (&b0, &b1));
            let size = xr.iter().chain(&xi).fold(1.0_f64, |m, v| m.max(v.abs()));
            assert!(
                res < 1e-12 * size * 100.0,
                "complex residual {res:.3e}, |x| {size:.3e}"
            );
            // A zero imaginary shift: the same solution as the real factorisation.
            let mut real = RealLu::default();
            real.factor_shifted(sr, &j, n);
            let mut xr = b0.clone();
            real.solve(&mut xr);
            let (mut cr, mut ci) = (b0.clone(), vec![0.0; n]);
            lu.factor_shifted(sr, 0.0, &j, n);
            lu.solve(&mut cr, &mut ci);
            for k in 0..n {
                assert!(
                    (xr[k] - cr[k]).abs() <= 1e-10 * size.max(xr[k].abs()),
                    "x[{k}]"
                );
                assert!(ci[k] == 0.0, "imaginary part {} from a real system", ci[k]);
            }
        }
    }

    #[test]
    fn the_rotor_sized_copies_give_the_same_bits_as_the_general_loops() {
        // `RealLu` and `ComplexLu` at n = ROTOR_N run the copies compiled for that size;
        // the free functions called with an opaque n run the general loops.
        let n = ROTOR_N;
        let opaque = std::hint::black_box(n);
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for case in 0..50 {
            // Every tenth matrix with a zero column, so that a zero pivot is met too.
            let mut j: Vec<f64> = (0..n * n).map(|_| 1e4 * rnd()).collect();
            if case % 10 == 0 {
                for r in 0..n {
                    j[r * n + 4] = 0.0;
                }
            }
            let (sr, si) = if case % 10 == 0 {
                (0.0, 0.0)
            } else {
                (1e3 * rnd(), 1e3 * rnd())
            };
            let b0: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let b1: Vec<f64> = (0..n).map(|_| rnd()).collect();

            let mut lu = RealLu::default();
            lu.factor_shifted(sr, &j, n);
            let mut a: Vec<f64> = j.iter().map(|&v| -v).collect();
            for k in 0..n {
                a[k * n + k] += sr;
            }
            let mut piv = Vec::new();
            let singular = real_eliminate(opaque, &mut a, &mut piv);
            assert_eq!(lu.singular, singular, "case {case}: singular flag");
            assert_eq!(lu.piv, piv, "case {case}: pivots");
            assert!(
                lu.a.iter().zip(&a).all(|(x, y)| x.to_bits() == y.to_bits()),
                "case {case}: real factors differ"
            );
            let (mut x, mut y) = (b0.clone(), b0.clone());
            lu.solve(&mut x);
            real_solve(opaque, &a, &piv, &mut y);
            assert!(
                x.iter().zip(&y).all(|(u, v)| u.to_bits() == v.to_bits()),
                "case {case}: real solutions differ"
            );

            let mut c = ComplexLu::default();
            c.factor_shifted(sr, si, &j, n);
            let mut re: Vec<f64> = j.iter().map(|&v| -v).collect();
            let mut im = vec![0.0; n * n];
            for k in 0..n {
                re[k * n + k] += sr;
                im[k * n + k] = si;
            }
            let mut piv = Vec::new();
            let singular = complex_eliminate(opaque, &mut re, &mut im, &mut piv);
            assert_eq!(c.singular, singular, "case {case}: complex singular flag");
            assert_eq!(c.piv, piv, "case {case}: complex pivots");
            let same =
                |p: &[f64], q: &[f64]| p.iter().zip(q).all(|(u, v)| u.to_bits() == v.to_bits());
            assert!(
                same(&c.re, &re) && same(&c.im, &im),
                "case {case}: complex factors differ"
            );
            let (mut xr, mut xi) = (b0.clone(), b1.clone());
            let (mut yr, mut yi) = (b0.clone(), b1.clone());
            c.solve(&mut xr, &mut xi);
            complex_solve(opaque, &re, &im, &piv, &mut yr, &mut yi);
            assert!(
                same(&xr, &yr) && same(&xi, &yi),
                "case {case}: complex solutions differ"
            );
        }
    }

    #[test]
    fn flags_singular_and_non_finite_matrices() {
        let mut lu = RealLu::default();
        // σ = 0: −J = [[1, 2], [2, 4]], rank 1.
        lu.factor_shifted(0.0, &[-1.0, -2.0, -2.0, -4.0], 2);
        assert!(lu.singular, "rank-1 matrix not flagged");
        lu.factor_shifted(1.0, &[0.0, f64::NAN, 0.0, 0.0], 2);
        assert!(lu.singular, "NaN entry not flagged");
        lu.factor_shifted(1.0, &[0.0; 4], 2);
        assert!(!lu.singular, "identity flagged singular");
        let mut c = ComplexLu::default();
        c.factor_shifted(0.0, 0.0, &[-1.0, -2.0, -2.0, -4.0], 2);
        assert!(c.singular, "complex: rank-1 matrix not flagged");
        c.factor_shifted(1.0, 1.0, &[0.0, f64::INFINITY, 0.0, 0.0], 2);
        assert!(c.singular, "complex: infinite entry not flagged");
        c.factor_shifted(0.0, 1.0, &[0.0; 4], 2);
        assert!(!c.singular, "i I flagged singular");
    }
}
