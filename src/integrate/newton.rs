//! Simplified Newton's bookkeeping shared by the implicit methods (radau5/radau9 and BDF):
//! where a step's iteration stands, and Hairer's convergence-rate tests (Hairer-Wanner
//! IV.8: the contraction `θ` of successive corrections, `η = θ / (1 − θ)` to estimate the
//! remaining error, carried from one step to the next).

/// Where a variant's Newton iteration stands in the current step attempt.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Newton {
    Iterating,
    Converged,
    Failed,
    /// The right-hand side faulted at an iterate.
    Fault,
}

/// The verdict on one Newton correction ([`Rate::judge`]).
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Judged {
    /// Contraction too slow or diverging: the iteration failed (correction not applied).
    Diverging,
    /// Apply the correction and iterate again.
    Continue,
    /// Apply the correction: the iteration has converged.
    Converged,
    /// Apply the correction: the last allowed iteration did not converge.
    Exhausted,
}

/// A variant's convergence-rate state across iterations and steps.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rate {
    /// `θ / (1 − θ)` of the last contraction measured (1 before any).
    pub eta: f64,
    /// Contraction of the last iteration judged (0 after a first iteration).
    pub theta: f64,
    /// Norm of the previous correction.
    norm_old: f64,
}

impl Default for Rate {
    fn default() -> Self {
        Rate {
            eta: 1.0,
            theta: 0.0,
            norm_old: 0.0,
        }
    }
}

impl Rate {
    /// At a step attempt's start: the carried `η` decays (`η^0.8`, Hairer's RADAU5), so a
    /// first correction below the tolerance over `η` stops the iteration at once.
    #[inline(always)]
    pub(crate) fn start_step(&mut self) {
        self.eta = self.eta.max(f64::EPSILON).powf(0.8);
    }

    /// Judges iteration `iter` (from 0, at most `max`) whose correction has the finite
    /// norm `norm` (error-weight units) against the stopping level `tol`: from the second
    /// iteration on, a contraction `θ ≥ 0.99`, or one too slow to reach `tol` in the
    /// iterations left, is [`Judged::Diverging`].
    #[inline(always)]
    pub(crate) fn judge(&mut self, iter: usize, max: usize, norm: f64, tol: f64) -> Judged {
        if iter > 0 {
            let theta = norm / self.norm_old;
            self.theta = theta;
            if theta >= 0.99 {
                return Judged::Diverging;
            }
            self.eta = theta / (1.0 - theta);
            let left = (max - 1 - iter) as i32;
            if theta.powi(left) / (1.0 - theta) * norm > tol {
                return Judged::Diverging;
            }
        } else {
            self.theta = 0.0;
        }
        self.norm_old = norm.max(f64::MIN_POSITIVE);
        if norm == 0.0 || self.eta * norm <= tol {
            Judged::Converged
        } else if iter + 1 == max {
            Judged::Exhausted
        } else {
            Judged::Continue
        }
    }
}
