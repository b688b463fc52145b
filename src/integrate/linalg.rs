//! Dense LU with partial pivoting on a row-major square matrix, in place (no allocation
//! after construction): the Newton matrices of the implicit method.

/// An `n x n` LU factorisation `P A = L U` stored in place.
#[derive(Clone, Debug)]
pub(crate) struct Lu {
    n: usize,
    a: Vec<f64>,
    piv: Vec<usize>,
    /// The last factorisation met a zero pivot.
    pub singular: bool,
}

impl Lu {
    pub(crate) fn new(n: usize) -> Self {
        Lu {
            n,
            a: vec![0.0; n * n],
            piv: vec![0; n],
            singular: false,
        }
    }

    /// The matrix to fill (row-major) before [`Lu::factor`].
    pub(crate) fn matrix_mut(&mut self) -> &mut [f64] {
        &mut self.a
    }

    /// Factorises the matrix in place.
    pub(crate) fn factor(&mut self) {
        let n = self.n;
        let a = &mut self.a;
        self.singular = false;
        for col in 0..n {
            let mut p = col;
            let mut best = a[col * n + col].abs();
            for r in col + 1..n {
                let v = a[r * n + col].abs();
                if v > best {
                    best = v;
                    p = r;
                }
            }
            self.piv[col] = p;
            if best == 0.0 || !best.is_finite() {
                self.singular = true;
                continue;
            }
            if p != col {
                for c in 0..n {
                    a.swap(col * n + c, p * n + c);
                }
            }
            let inv = 1.0 / a[col * n + col];
            for r in col + 1..n {
                let f = a[r * n + col] * inv;
                a[r * n + col] = f;
                if f != 0.0 {
                    for c in col + 1..n {
                        a[r * n + c] -= f * a[col * n + c];
                    }
                }
            }
        }
    }

    /// Solves `A x = b` in place (`b` becomes `x`).
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        let a = &self.a;
        for col in 0..n {
            let p = self.piv[col];
            if p != col {
                b.swap(col, p);
            }
        }
        for r in 0..n {
            let mut acc = b[r];
            for c in 0..r {
                acc -= a[r * n + c] * b[c];
            }
            b[r] = acc;
        }
        for r in (0..n).rev() {
            let mut acc = b[r];
            for c in r + 1..n {
                acc -= a[r * n + c] * b[c];
            }
            b[r] = acc / a[r * n + r];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_pivoting_system() {
        let mut lu = Lu::new(3);
        lu.matrix_mut()
            .copy_from_slice(&[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0]);
        lu.factor();
        assert!(!lu.singular);
        // A x = b for x = (1, 2, 3).
        let mut b = [7.0, 3.0, 6.0];
        lu.solve(&mut b);
        for (k, (got, want)) in b.iter().zip([1.0, 2.0, 3.0]).enumerate() {
            assert!((got - want).abs() < 1e-14, "x[{k}] = {got}, want {want}");
        }
    }
}
