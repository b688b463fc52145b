//! Radau IIA's constants for any odd number of stages `s`, derived from their definition
//! (Hairer and Wanner, vol. II, §IV.5 and §IV.8): the nodes are the zeros of
//! `d^(s−1)/dx^(s−1) [x^(s−1) (x − 1)^s]` (the last one is 1), the Runge-Kutta matrix
//! makes the method collocation at them (`Σ_j a_ij c_j^(k−1) = c_i^k / k`, `k = 1..s`),
//! the Newton systems decouple in the eigenbasis of `A^-1` (one real eigenvalue and
//! `(s − 1)/2` complex pairs), and the embedded error estimate is RADAU's: a method of
//! order `s` with the extra node 0 of weight `1/γ` (`γ` the real eigenvalue of `A^-1`),
//! whose difference to the Radau solution is `(I − h/γ J)^-1`-filtered.
//! radau5 keeps its closed forms (`super::radau`); these are radau9's (`s = 5`) and
//! the unit tests' check of both against each other at `s = 3`.

use nalgebra::{Complex, DMatrix, DVector};

/// The constants of the `s`-stage Radau IIA method, row-major where a matrix.
#[derive(Clone, Debug)]
pub(crate) struct RadauCoefficients {
    /// Nodes `c_1 < … < c_s = 1`.
    pub c: Vec<f64>,
    /// Runge-Kutta matrix `A` (its last row is the weights `b`: stiffly accurate). The
    /// step uses `T`, `γ` and the pairs instead; the unit tests check `A` itself.
    #[cfg_attr(not(test), allow(dead_code))]
    pub a: Vec<Vec<f64>>,
    /// `T`: `T^-1 A^-1 T = diag(γ, [[α_1, β_1], [−β_1, α_1]], …)`, its columns the real
    /// eigenvector of `A^-1` and the real and imaginary parts of one of each complex pair.
    pub t: Vec<Vec<f64>>,
    /// `T^-1`.
    pub ti: Vec<Vec<f64>>,
    /// The real eigenvalue `γ` of `A^-1`.
    pub gamma: f64,
    /// `(α_k, β_k)` of each complex block of `T^-1 A^-1 T`, as above.
    pub pairs: Vec<(f64, f64)>,
    /// Weights of the stage increments `Z_j` in the error estimate
    /// `(γ/h I − J)^-1 (f(y_0) + Σ_j e_j Z_j / h)`.
    pub ez: Vec<f64>,
    /// Inverse of `V_ij = c_i^(j+1)`: stage increments to the coefficients of the
    /// collocation polynomial `z(θ) = Σ_k a_k θ^k`, `k = 1..s`.
    pub vinv: Vec<Vec<f64>>,
}

/// `p(x)` for coefficients `p[k]` of `x^k` (Horner).
fn poly(p: &[f64], x: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, &a| acc * x + a)
}

/// The interior nodes: zeros in (0, 1) of `d^(s−1)/dx^(s−1) [x^(s−1) (x − 1)^s]`, by
/// bisection between the sign changes on a fine grid (they are simple and at least
/// `~1/s²` apart).
fn interior_nodes(s: usize) -> Vec<f64> {
    // x^(s−1) (x − 1)^s = Σ_k C(s, k) (−1)^(s−k) x^(k + s − 1).
    let mut p = vec![0.0; 2 * s];
    let mut binom = 1.0;
    for k in 0..=s {
        let sign = if (s - k).is_multiple_of(2) { 1.0 } else { -1.0 };
        p[k + s - 1] = sign * binom;
        binom = binom * (s - k) as f64 / (k + 1) as f64;
    }
    for _ in 0..s - 1 {
        p = p
            .iter()
            .enumerate()
            .skip(1)
            .map(|(k, &a)| k as f64 * a)
            .collect();
    }
    // 4 000 cells over [0, 0.999]: far finer than the nodes' spacing (0.057 at s = 5,
    // 0.021 at s = 9), and short of the zero at 1 (the largest interior node is 0.86 at
    // s = 5, 0.97 at s = 9), which the caller appends.
    let (cells, top) = (4000, 0.999);
    let mut roots = Vec::new();
    for i in 0..cells {
        let (mut lo, mut hi) = (
            top * i as f64 / cells as f64,
            top * (i + 1) as f64 / cells as f64,
        );
        let (plo, phi) = (poly(&p, lo), poly(&p, hi));
        if plo == 0.0 {
            roots.push(lo);
            continue;
        }
        if plo * phi >= 0.0 {
            continue;
        }
        let slo = plo.signum();
        while 0.5 * (lo + hi) > lo && 0.5 * (lo + hi) < hi {
            let mid = 0.5 * (lo + hi);
            if poly(&p, mid).signum() == slo {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        roots.push(if poly(&p, hi).abs() < poly(&p, lo).abs() {
            hi
        } else {
            lo
        });
    }
    roots
}

/// The eigenvector of `m` for the eigenvalue `lam`, by two steps of inverse iteration at
/// a shift `1e-10` relative away from it (the matrix is then invertible and the iteration
/// converges by the factor `1e-10 / gap` a step).
fn eigenvector(m: &DMatrix<f64>, lam: Complex<f64>) -> DVector<Complex<f64>> {
    let n = m.nrows();
    let shift = lam * (1.0 + 1e-10);
    let b = DMatrix::from_fn(n, n, |i, j| {
        Complex::new(m[(i, j)], 0.0)
            - if i == j {
                shift
            } else {
                Complex::new(0.0, 0.0)
            }
    });
    let lu = b.lu();
    let mut v = DVector::from_element(n, Complex::new(1.0, 0.0));
    for _ in 0..2 {
        v = lu.solve(&v).expect("the shifted matrix is invertible");
        let big = v
            .iter()
            .copied()
            .max_by(|x, y| x.norm().total_cmp(&y.norm()))
            .expect("n > 0");
        v /= big;
    }
    v
}

/// The `s`-stage Radau IIA method's constants (`s` odd, 1 to 9).
pub(crate) fn radau_iia(s: usize) -> RadauCoefficients {
    assert!(
        s % 2 == 1 && (1..=9).contains(&s),
        "odd stage counts 1 to 9"
    );
    let mut c = interior_nodes(s);
    c.push(1.0);
    assert_eq!(c.len(), s, "{s} nodes, found {c:?}");
    // Collocation: A^T = M^-1 R with M_kj = c_j^k, R_ki = c_i^(k+1) / (k + 1).
    let m = DMatrix::from_fn(s, s, |k, j| c[j].powi(k as i32));
    let r = DMatrix::from_fn(s, s, |k, i| c[i].powi(k as i32 + 1) / (k + 1) as f64);
    let at = m.clone().lu().solve(&r).expect("distinct nodes");
    let a = DMatrix::from_fn(s, s, |i, j| at[(j, i)]);
    let ainv = a
        .clone()
        .try_inverse()
        .expect("Radau IIA's matrix is invertible");
    // Eigenvalues of A^-1: one real, (s − 1)/2 pairs; one of each pair (negative
    // imaginary part, as RADAU5's constants), by increasing real part.
    let mut eig: Vec<Complex<f64>> = ainv.complex_eigenvalues().iter().copied().collect();
    eig.sort_by(|x, y| x.re.total_cmp(&y.re));
    let scale = eig.iter().map(|z| z.norm()).fold(0.0, f64::max);
    let (real, cplx): (Vec<Complex<f64>>, Vec<Complex<f64>>) =
        eig.into_iter().partition(|z| z.im.abs() <= 1e-9 * scale);
    assert_eq!(real.len(), 1, "one real eigenvalue of A^-1, found {real:?}");
    let cplx: Vec<Complex<f64>> = cplx.into_iter().filter(|z| z.im < 0.0).collect();
    assert_eq!(cplx.len(), (s - 1) / 2, "conjugate pairs");
    let mut tm = DMatrix::zeros(s, s);
    let v0 = eigenvector(&ainv, Complex::new(real[0].re, 0.0));
    for i in 0..s {
        tm[(i, 0)] = v0[i].re;
    }
    for (k, &z) in cplx.iter().enumerate() {
        let v = eigenvector(&ainv, z);
        for i in 0..s {
            tm[(i, 1 + 2 * k)] = v[i].re;
            tm[(i, 2 + 2 * k)] = v[i].im;
        }
    }
    let tim = tm
        .clone()
        .try_inverse()
        .expect("eigenvectors of distinct eigenvalues");
    let lam = &tim * &ainv * &tm;
    let gamma = lam[(0, 0)];
    let pairs: Vec<(f64, f64)> = (0..(s - 1) / 2)
        .map(|k| (lam[(1 + 2 * k, 1 + 2 * k)], lam[(1 + 2 * k, 2 + 2 * k)]))
        .collect();
    // The embedded method: weight 1/γ at the node 0 and b̂ at the nodes, of order s:
    // 1/γ [k = 1] + Σ_i b̂_i c_i^(k−1) = 1/k, k = 1..s.
    let rhs = DVector::from_fn(s, |k, _| {
        1.0 / (k + 1) as f64 - if k == 0 { 1.0 / gamma } else { 0.0 }
    });
    let bhat = m.lu().solve(&rhs).expect("distinct nodes");
    // ŷ − y = h/γ f_0 + Σ_i (b̂_i − b_i) h f_i, h f_i = Σ_j (A^-1)_ij Z_j; divided by h/γ.
    let ez: Vec<f64> = (0..s)
        .map(|j| {
            gamma
                * (0..s)
                    .map(|i| (bhat[i] - a[(s - 1, i)]) * ainv[(i, j)])
                    .sum::<f64>()
        })
        .collect();
    let vinv = DMatrix::from_fn(s, s, |i, j| c[i].powi(j as i32 + 1))
        .try_inverse()
        .expect("distinct nodes");
    let rows = |x: &DMatrix<f64>| -> Vec<Vec<f64>> {
        (0..s)
            .map(|i| (0..s).map(|j| x[(i, j)]).collect())
            .collect()
    };
    RadauCoefficients {
        c,
        a: rows(&a),
        t: rows(&tm),
        ti: rows(&tim),
        gamma,
        pairs,
        ez,
        vinv: rows(&vinv),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 5-stage method's quadrature is of order 9 (`Σ b_j c_j^(k−1) = 1/k`, k ≤ 9, and
    /// not k = 10), its stages of order 5 (`Σ_j a_ij c_j^(k−1) = c_i^k / k`, k ≤ 5), its
    /// nodes the published ones, the eigenbasis block-diagonalises `A^-1`, and the
    /// embedded estimate is of order 5 exactly.
    #[test]
    fn radau9_constants_meet_their_order_conditions() {
        let k = radau_iia(5);
        let s = 5;
        // Hairer-Wanner IV.5, Table 5.6 (s = 5): c_1 = 0.05710419611451768,
        // c_2 = 0.27684301363812383, c_3 = 0.5835904323689168, c_4 = 0.8602401356562195.
        let want = [
            0.057_104_196_114_517_68,
            0.276_843_013_638_123_8,
            0.583_590_432_368_916_8,
            0.860_240_135_656_219_5,
            1.0,
        ];
        for (c, w) in k.c.iter().zip(want) {
            assert!((c - w).abs() < 1e-14, "node {c} against {w}");
        }
        let b = &k.a[s - 1];
        for q in 1..=10 {
            let sum: f64 = (0..s).map(|j| b[j] * k.c[j].powi(q - 1)).sum();
            let off = (sum - 1.0 / q as f64).abs();
            if q <= 9 {
                assert!(off < 1e-14, "B({q}): off by {off:.3e}");
            } else {
                assert!(off > 1e-6, "B(10) holds: the order would be 10");
            }
        }
        for i in 0..s {
            for q in 1..=5 {
                let sum: f64 = (0..s).map(|j| k.a[i][j] * k.c[j].powi(q - 1)).sum();
                let off = (sum - k.c[i].powi(q) / q as f64).abs();
                assert!(off < 1e-14, "C({q}) at stage {i}: off by {off:.3e}");
            }
        }
        // T Λ T^-1 = A^-1.
        let a = DMatrix::from_fn(s, s, |i, j| k.a[i][j]);
        let ainv = a.try_inverse().unwrap();
        let t = DMatrix::from_fn(s, s, |i, j| k.t[i][j]);
        let ti = DMatrix::from_fn(s, s, |i, j| k.ti[i][j]);
        let mut lam = DMatrix::zeros(s, s);
        lam[(0, 0)] = k.gamma;
        for (q, &(al, be)) in k.pairs.iter().enumerate() {
            let i = 1 + 2 * q;
            lam[(i, i)] = al;
            lam[(i, i + 1)] = be;
            lam[(i + 1, i)] = -be;
            lam[(i + 1, i + 1)] = al;
        }
        let res = (&t * &lam * &ti - &ainv).abs().max();
        assert!(
            res < 1e-11 * ainv.abs().max(),
            "|T Λ T^-1 − A^-1| = {res:.3e}"
        );
        // Hairer-Wanner IV.8 (RADAU, s = 5): A^-1's real eigenvalue 7.2934...,
        // the pairs 6.7033 ± 3.4856 i? and 4.2933 ± 5.3181 i? (checked as A's eigenvalues'
        // reciprocals by the characteristic polynomial below instead of quoted).
        let charpoly = |z: Complex<f64>| {
            let m = DMatrix::from_fn(s, s, |i, j| {
                Complex::new(ainv[(i, j)], 0.0) - if i == j { z } else { Complex::new(0.0, 0.0) }
            });
            m.determinant().norm()
        };
        assert!(charpoly(Complex::new(k.gamma, 0.0)) < 1e-8 * ainv.abs().max().powi(5));
        for &(al, be) in &k.pairs {
            assert!(charpoly(Complex::new(al, be)) < 1e-8 * ainv.abs().max().powi(5));
        }
        // The embedded method (weight 1/γ at 0, b̂ = b + γ^-1 Σ_j ez_j A_j·... ) integrates
        // polynomials of degree ≤ 4 exactly: with Z_j = h Σ_l a_jl f_l, its difference to
        // the Radau solution for f = t^(q−1) (q ≤ 5) is zero, for q = 6 it is not.
        for q in 1..=6 {
            // f(t) = t^(q−1), y' = f, y(0) = 0, h = 1: Z_j = c_j^q / q, f_0 = [q = 1].
            let f0 = if q == 1 { 1.0 } else { 0.0 };
            let est: f64 = f0
                + (0..s)
                    .map(|j| k.ez[j] * k.c[j].powi(q) / q as f64)
                    .sum::<f64>();
            if q <= 5 {
                assert!(est.abs() < 1e-12, "estimate for t^{}: {est:.3e}", q - 1);
            } else {
                assert!(est.abs() > 1e-6, "the estimate is of order 6");
            }
        }
        // Collocation polynomial coefficients: V · vinv = I.
        for i in 0..s {
            for j in 0..s {
                let v: f64 = (0..s)
                    .map(|l| k.c[i].powi(l as i32 + 1) * k.vinv[l][j])
                    .sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-12, "V vinv [{i}][{j}] = {v}");
            }
        }
    }
}
