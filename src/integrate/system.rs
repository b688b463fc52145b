//! The batched-system interface, per-variant settings, statuses and counters.

use std::time::Instant;

use serde::{Deserialize, Serialize};

/// Integration method of a batch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Dormand-Prince 5(4): explicit, adaptive (PI control), 4th-order dense output;
    /// 6 right-hand-side evaluations per step (first-same-as-last).
    #[default]
    Dopri5,
    /// Radau IIA, 3 stages, order 5, L-stable; simplified Newton on the 3n real system,
    /// Jacobians from the system's structure where it forms them
    /// ([`BatchSystem::jacobians`]), else by forward differences (one batched call per
    /// state component), cubic collocation dense output.
    Radau5,
    /// Dopri5 with Hairer's stiffness test per variant: a variant whose steps sit near
    /// dopri5's stability boundary (15 accepted steps with `h |λ| > 2.5`) is handed to
    /// radau5 from that point on ([`Stats::stiff_switch_time`]); the others stay dopri5,
    /// step for step the same as [`Method::Dopri5`].
    Auto,
    /// Classical 4th-order Runge-Kutta at the fixed step `Settings::fixed_step`, with its
    /// 3rd-order continuous extension for samples; 4 evaluations per step.
    Rk4,
    /// Dormand-Prince 8(5,3) (Hairer's DOP853): explicit, adaptive (PI control, the
    /// combined 5th/3rd-order error estimate), 7th-order dense output; 12 evaluations per
    /// step (first-same-as-last) and 3 more on steps with a sample inside. For tight
    /// tolerances, where its order 8 takes far fewer steps than dopri5.
    Dop853,
    /// Radau IIA, 5 stages, order 9, L-stable: radau5's machinery (simplified Newton in
    /// the eigenbasis of `A^-1`, here one real and two complex `n x n` systems, the same
    /// Jacobians and their reuse) with RADAU's embedded order-5 error estimate and
    /// quintic collocation dense output. For tight tolerances on stiff variants: on the
    /// rotor its steps are held by Newton's convergence near 25 a revolution, so it
    /// takes 2-2.6x fewer right-hand sides than radau5 at rtol 1e-8 to 1e-9 and none
    /// fewer at 1e-6 (BENCHMARKS.md "Issue 28, twelfth pass").
    Radau9,
    /// Variable-order BDF (orders 1-5, Shampine's quasi-constant step form), simplified
    /// Newton with Jacobians kept across steps: one right-hand side per Newton iteration.
    Bdf,
}

impl Method {
    /// Name used in scenes and reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Dopri5 => "dopri5",
            Method::Radau5 => "radau5",
            Method::Auto => "auto",
            Method::Rk4 => "rk4",
            Method::Dop853 => "dop853",
            Method::Radau9 => "radau9",
            Method::Bdf => "bdf",
        }
    }
}

/// Settings of one variant. Times in the system's time unit (s for rotors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// End time (the start is 0).
    pub t_end: f64,
    /// Interval between output samples (samples at `k * sample_interval <= t_end`).
    pub sample_interval: f64,
    /// Relative tolerance of the local error.
    pub rtol: f64,
    /// Absolute tolerance, in units of each component's scale ([`BatchSystem::scales`]).
    pub atol: f64,
    /// Fixed step: required meaning for `Rk4` (default there: `sample_interval`); for the
    /// adaptive methods it switches error control off (every step accepted; for order
    /// studies).
    pub fixed_step: Option<f64>,
    /// First step of an adaptive method (default: a heuristic from `|y| / |f|`).
    pub initial_step: Option<f64>,
    /// Largest step (default: unbounded).
    pub max_step: Option<f64>,
    /// Accepted steps after which the variant stops with `MaxSteps`.
    pub max_steps: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            t_end: 1.0,
            sample_interval: 0.1,
            rtol: 1e-6,
            atol: 1e-6,
            fixed_step: None,
            initial_step: None,
            max_step: None,
            max_steps: 1_000_000,
        }
    }
}

/// Where a variant stands. `F` is the system's fault type (physical context).
#[derive(Clone, Debug, PartialEq)]
pub enum Status<F> {
    /// Still integrating.
    Running,
    /// Reached `t_end`.
    Finished,
    /// The right-hand side reported `fault` at `time` and no smaller step avoided it.
    Fault {
        /// Start of the step that could not be completed.
        time: f64,
        /// What the system reported.
        fault: F,
    },
    /// The step size fell below the floor `1e-12 * max(t_end, |t|)` (error control).
    StepSizeTooSmall {
        /// Time reached.
        time: f64,
        /// Step size at that point.
        step: f64,
    },
    /// The solution or its error estimate became NaN or infinite.
    NonFinite {
        /// Time reached.
        time: f64,
    },
    /// `max_steps` accepted steps were taken before `t_end`.
    MaxSteps {
        /// Time reached.
        time: f64,
        /// Steps taken.
        steps: u64,
    },
}

/// Counters of one variant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts (error too large, Newton failure, or a right-hand-side fault).
    pub rejected: u64,
    /// Right-hand-side evaluations of this variant (stages, Jacobian columns, `f(y0)`).
    pub rhs_evaluations: u64,
    /// Jacobians formed (Radau5).
    pub jacobians: u64,
    /// LU factorisations (Radau5).
    pub factorizations: u64,
    /// Wall time from the start of the batch to this variant's end, s.
    pub wall_time_s: f64,
    /// [`Method::Auto`]: the time at which the variant was handed from dopri5 to radau5
    /// (`None`: it was not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiff_switch_time: Option<f64>,
}

/// A batch of ODE systems of a common dimension, `y' = f(t, y)`, identified by index.
pub trait BatchSystem {
    /// Why an evaluation has no derivative (physical context, e.g. film breakdown).
    type Fault: Clone + std::fmt::Debug;

    /// Dimension of every variant's state.
    fn dim(&self) -> usize;

    /// Components `0..jacobian_dim()` are those `f` depends on; later ones (quadratures
    /// such as accumulated work) get no Jacobian column. Default: all.
    fn jacobian_dim(&self) -> usize {
        self.dim()
    }

    /// Pairs `(i, j)` with `f_i = y_j` exactly for every variant (a position whose rate
    /// is a velocity component): radau5 eliminates component `i` from its Newton systems
    /// in closed form instead of factorising it (`super::reduced`). Default: none.
    fn kinematic_pairs(&self) -> &[(usize, usize)] {
        &[]
    }

    /// A block of components `(start, len)` whose overall scale `f` ignores (a
    /// quaternion normalised in every use): with `y_B` replaced by `λ y_B` (`λ > 0`), `f_r`
    /// is unchanged for `r` outside the block and multiplied by `λ` inside it (its own rate
    /// linear in it). Euler's relation `Σ_{c ∈ B} y_c ∂f_r/∂y_c = [r ∈ B] f_r` then gives
    /// one of the block's Jacobian columns from the others, so radau5 evaluates one column
    /// fewer per Jacobian. Default: none.
    fn scale_invariant_block(&self) -> Option<(usize, usize)> {
        None
    }

    /// Whether [`BatchSystem::jacobians`] forms any Jacobians (radau5 asks it before
    /// packing the states for it). Default: `false`.
    fn has_jacobians(&self) -> bool {
        false
    }

    /// Jacobians `∂f/∂y` from the system's own structure, for the variants `ids[k]` at
    /// time `ts[k]` and state `ys[k * dim..]`, whose derivative there is `f0s[k * dim..]`
    /// (this call's state was evaluated just before, `f` unchanged since). Where it forms
    /// one, it writes columns `0..jacobian_dim()` of every row of `jac[k * dim * dim..]`
    /// (row-major `dim x dim`) and sets `cost[k]` to the right-hand sides' worth of work it
    /// took (counted in the variant's [`Stats::rhs_evaluations`]); where it leaves
    /// `cost[k] = None` (as it arrives), radau5 takes forward differences of `f` as
    /// without this hook. The Jacobian only steers Newton: it has to be close, not exact.
    /// Default: forms none.
    fn jacobians(
        &mut self,
        _ids: &[usize],
        _ts: &[f64],
        _ys: &[f64],
        _f0s: &[f64],
        _jac: &mut [f64],
        _cost: &mut [Option<u64>],
    ) {
    }

    /// Typical magnitude of each component of variant `id` (the unit of `atol`).
    fn scales(&self, _id: usize, out: &mut [f64]) {
        out.fill(1.0);
    }

    /// Magnitudes in which [`Method::Auto`]'s stiffness test measures `‖Δf‖ / ‖Δy‖` for
    /// variant `id`: the components' natural sizes, so that the stiffest mode shows
    /// whatever the error weights emphasise. Default: [`BatchSystem::scales`].
    fn stiffness_scales(&self, id: usize, out: &mut [f64]) {
        self.scales(id, out);
    }

    /// Derivatives of `ys.len() / dim` packed states; entry `k` belongs to variant
    /// `ids[k]` (a variant may appear several times) at time `ts[k]`. Writes `dys` and,
    /// where an entry has no derivative, `faults[k] = Some(..)` (`faults` arrives all
    /// `None`). One call per stage: this is where a backend sees the whole batch.
    fn eval(
        &mut self,
        ids: &[usize],
        ts: &[f64],
        ys: &[f64],
        dys: &mut [f64],
        faults: &mut [Option<Self::Fault>],
    );

    /// Projection onto invariants after an accepted step (e.g. unit quaternion).
    fn project(&self, _id: usize, _y: &mut [f64]) {}

    /// Output samples produced in one round, packed like [`BatchSystem::eval`]'s input
    /// (times ascending per variant).
    fn record(&mut self, ids: &[usize], ts: &[f64], ys: &[f64]);

    /// Variant `id` has ended (called once, after its last samples were recorded).
    fn finished(&mut self, id: usize, status: &Status<Self::Fault>, stats: &Stats);
}

/// Integrates every variant from `t = 0`, state `y0[id * dim..]`, with its own settings,
/// by `method`, calling the system back for derivatives, samples and ends. Returns each
/// variant's status and counters. A variant that fails ends alone; the others go on.
pub fn run_batch<S: BatchSystem>(
    method: Method,
    sys: &mut S,
    y0: &[f64],
    settings: &[Settings],
) -> Vec<(Status<S::Fault>, Stats)> {
    let start = Instant::now();
    assert_eq!(
        y0.len(),
        settings.len() * sys.dim(),
        "y0 must hold one state per variant"
    );
    match method {
        Method::Dopri5 => super::dopri::run(sys, y0, settings, start, false),
        Method::Auto => super::dopri::run(sys, y0, settings, start, true),
        Method::Radau5 => super::radau::run(sys, y0, settings, start, super::radau::Stages::Three),
        Method::Radau9 => super::radau::run(sys, y0, settings, start, super::radau::Stages::Five),
        Method::Rk4 => super::rk4::run(sys, y0, settings, start),
        Method::Dop853 => super::dop853::run(sys, y0, settings, start),
        Method::Bdf => super::bdf::run(sys, y0, settings, start),
    }
}
