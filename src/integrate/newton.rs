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
    /// `θ / (1 − θ)` of the last contraction measured (1 before any), before the
    /// `pending` decays of the step attempts since.
    eta: f64,
    /// Decays `η ← max(η, ε)^0.8` owed to `eta`, applied only when a first correction's
    /// test needs the value (a `pow` at every step attempt was 2.5 % of a BDF rotor run;
    /// issue 28, seventeenth pass).
    pending: u32,
    /// Contraction of the last iteration judged (0 after a first iteration).
    pub theta: f64,
    /// Norm of the previous correction.
    norm_old: f64,
}

/// The exponent of `η`'s decay at each step attempt's start (Hairer's RADAU5).
const ETA_DECAY: f64 = 0.8;

impl Default for Rate {
    fn default() -> Self {
        Rate {
            eta: 1.0,
            pending: 0,
            theta: 0.0,
            norm_old: 0.0,
        }
    }
}

impl Rate {
    /// At a step attempt's start: the carried `η` decays (`η^0.8`, Hairer's RADAU5), so a
    /// first correction below the tolerance over `η` stops the iteration at once. The
    /// decay is owed, not applied: see [`Rate::eta`].
    #[inline(always)]
    pub(crate) fn start_step(&mut self) {
        self.pending = self.pending.saturating_add(1);
    }

    /// The carried `η` with every owed decay applied: `n` decays at once as
    /// `max(η, ε)^(0.8^n)` (one `pow`, not `n`; the same value up to roundings, since a
    /// decayed `η` is above `ε` already).
    fn eta(&mut self) -> f64 {
        if self.pending > 0 {
            // 0.8^n underflows to 0 after ~3 300 decays: η is 1 by then.
            let exponent = ETA_DECAY.powi(self.pending.min(i32::MAX as u32) as i32);
            self.eta = self.eta.max(f64::EPSILON).powf(exponent);
            self.pending = 0;
        }
        self.eta
    }

    /// Whether `η · norm ≤ tol` with the carried `η`. The owed decays move a positive
    /// `η` towards 1 without passing it (`x^p`, `0 ≤ p ≤ 1`, lies between `x` and 1, and
    /// so does its faithful rounding; a value below `ε` is first raised to `ε`, which
    /// only raises it), so they leave `η` between `min(η, 1)` and `max(η, 1)`, and only
    /// a test those bounds do not settle needs them applied.
    #[inline(always)]
    fn eta_times_within(&mut self, norm: f64, tol: f64) -> bool {
        if self.pending > 0 {
            // Rounded products are monotone in the factor (norm ≥ 0).
            if self.eta.max(1.0) * norm <= tol {
                return true;
            }
            if self.eta.min(1.0) * norm > tol {
                return false;
            }
        }
        self.eta() * norm <= tol
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
            self.pending = 0;
            let left = (max - 1 - iter) as i32;
            if theta.powi(left) / (1.0 - theta) * norm > tol {
                return Judged::Diverging;
            }
        } else {
            self.theta = 0.0;
        }
        self.norm_old = norm.max(f64::MIN_POSITIVE);
        if norm == 0.0 || self.eta_times_within(norm, tol) {
            Judged::Converged
        } else if iter + 1 == max {
            Judged::Exhausted
        } else {
            Judged::Continue
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hairer's bookkeeping with the decay applied at every step's start (as before the
    /// decays were owed): the reference the lazy [`Rate`] must agree with.
    struct Eager {
        eta: f64,
        norm_old: f64,
    }

    impl Eager {
        fn judge(&mut self, iter: usize, max: usize, norm: f64, tol: f64) -> Judged {
            if iter > 0 {
                let theta = norm / self.norm_old;
                if theta >= 0.99 {
                    return Judged::Diverging;
                }
                self.eta = theta / (1.0 - theta);
                let left = (max - 1 - iter) as i32;
                if theta.powi(left) / (1.0 - theta) * norm > tol {
                    return Judged::Diverging;
                }
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

    /// A small deterministic generator (xorshift64*), uniform in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state >> 12;
        *state ^= *state << 25;
        *state ^= *state >> 27;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn owed_decays_give_the_verdicts_and_eta_of_decaying_at_every_step() {
        const MAX: usize = 4;
        let (mut lazy, mut eager) = (
            Rate::default(),
            Eager {
                eta: 1.0,
                norm_old: 0.0,
            },
        );
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let (mut verdicts, mut decided_by_bounds, mut near_ties) = (0, 0, 0);
        for step in 0..20_000 {
            if step % 97 == 0 {
                // An η far below ε (θ ≈ 0) for the lower clamp.
                lazy.eta();
                lazy.eta = 1e-300;
                eager.eta = 1e-300;
            }
            lazy.start_step();
            eager.eta = eager.eta.max(f64::EPSILON).powf(ETA_DECAY);
            // Runs of steps whose first correction settles them (η only decays), then
            // iterations that measure a new contraction; tolerances over 8 decades.
            let tol = 10f64.powf(-8.0 * uniform(&mut seed));
            let mut norm = tol * 10f64.powf(3.0 * uniform(&mut seed) - 1.5);
            for iter in 0..MAX {
                let pending = lazy.pending;
                let want = eager.judge(iter, MAX, norm, tol);
                let got = lazy.judge(iter, MAX, norm, tol);
                verdicts += 1;
                if pending > 0 && lazy.pending == pending {
                    decided_by_bounds += 1;
                }
                // One `pow` for n decays rounds differently from n `pow`s: a verdict
                // may differ only where η·norm and tol agree to 1e-12.
                if got != want {
                    let rel = (eager.eta * norm - tol).abs() / tol;
                    assert!(
                        rel < 1e-12,
                        "step {step}, iteration {iter}: verdicts differ away from a tie \
                         (eager η {}, norm {norm}, tol {tol}, relative gap {rel})",
                        eager.eta
                    );
                    near_ties += 1;
                    break;
                }
                if got != Judged::Continue {
                    break;
                }
                norm *= 0.6 * uniform(&mut seed);
            }
            let (a, b) = (lazy.eta(), eager.eta);
            assert!(
                (a - b).abs() <= 1e-13 * b,
                "step {step}: η {a} owed against {b} decayed at each step"
            );
        }
        // The bounds settle some tests without a `pow`, and most without a tie.
        assert!(
            decided_by_bounds > 1000,
            "{decided_by_bounds} of {verdicts}"
        );
        assert!(near_ties < 10, "{near_ties} near ties");
    }
}
