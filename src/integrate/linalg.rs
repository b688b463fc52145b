//! The implicit method's Newton matrices factorised by nalgebra's LU with partial pivoting,
//! plus the singularity test the step logic needs.

use nalgebra::{DMatrix, DVectorViewMut, Dyn, LU};

/// An `n x n` factorisation `P A = L U` kept for repeated solves.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lu {
    lu: Option<LU<f64, Dyn, Dyn>>,
    /// The last factorisation met a zero pivot or a non-finite entry.
    pub singular: bool,
}

impl Lu {
    /// Factorises `a` (replacing the previous factorisation).
    pub(crate) fn factor(&mut self, a: DMatrix<f64>) {
        // A non-finite entry (a Jacobian probe gone bad) makes the factors meaningless
        // even where no pivot is exactly zero.
        let finite = a.iter().all(|v| v.is_finite());
        let lu = LU::new(a);
        self.singular = !finite || !lu.is_invertible();
        self.lu = Some(lu);
    }

    /// Solves `A x = b` in place (`b` becomes `x`) with the last factorisation.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let lu = self.lu.as_ref().expect("Lu::solve after Lu::factor");
        let n = b.len();
        lu.solve_mut(&mut DVectorViewMut::from_slice(b, n));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_pivoting_system() {
        let mut lu = Lu::default();
        lu.factor(DMatrix::from_row_slice(
            3,
            3,
            &[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0],
        ));
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
    fn flags_singular_and_non_finite_matrices() {
        let mut lu = Lu::default();
        lu.factor(DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]));
        assert!(lu.singular, "rank-1 matrix not flagged");
        lu.factor(DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0]));
        assert!(lu.singular, "NaN entry not flagged");
        lu.factor(DMatrix::identity(2, 2));
        assert!(!lu.singular, "identity flagged singular");
    }
}
