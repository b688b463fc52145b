//! The discretised Reynolds equation and its CPU solvers: projected full multigrid
//! ([`super::multigrid`], the default) and red-black projected SOR (kept as the reference
//! and for the work comparison of BENCHMARKS.md), and the accuracy control that picks the
//! grid from the nested multigrid solutions (Richardson).
//!
//! Nondimensional form (`ζ = z/B`, `H = h/δ`, `p = μ ρ B²/δ² · P` with `ρ` the rate scale
//! of [`crate::bearing::pack_state`], `λ = (B/r0)²`):
//!
//! ```text
//! λ ∂θ(H³ ∂θP) + ∂ζ(H³ ∂ζP) = 6 (a(ζ) sin θ − b(ζ) cos θ),   P(θ, 0) = P(θ, 1) = 0,
//! P ≥ 0,  −L P + rhs ≥ 0,  P (−L P + rhs) = 0          (Swift–Stieber, an LCP)
//! ```
//!
//! with `(a, b)` the packed rate vector interpolated along `ζ` and `H = 1 − εx(ζ) cos θ −
//! εy(ζ) sin θ`. Five-point finite volumes on a node grid periodic in θ (`n_theta`
//! intervals) and with `n_z` intervals in ζ, `H³` evaluated exactly at the cell faces;
//! second order. The loads are the rectangle (= trapezoid, periodic/zero-boundary) sums
//! `FilmIntegrals = −⅓ (∬P cos θ, ∬P sin θ, ∬P ζ cos θ, ∬P ζ sin θ)`, the same
//! normalisation as the short-bearing rule, so [`crate::bearing::finish_loads`] applies.

use std::f64::consts::PI;

use super::multigrid::{
    cubic_edge, cubic_mid, load_change, load_tail_estimate, prolong_solution,
    prolong_solution_cubic, tail_estimate, Coarsen, Hierarchy, Stop,
};
pub use super::multigrid::{CoarsestSolve, MgCycle};
use super::{Cavitation, FiniteSettings, Inlet};
use crate::bearing::{
    finish_loads, pack_state, BearingParams, BearingState, FilmIntegrals, FilmLayout, Loads,
    Packed, PackedState, StateFault,
};

/// Grid dimensions and tolerance, copied from [`FiniteSettings`] (what the kernels need).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiniteGrid {
    /// Intervals around the circumference (even).
    pub n_theta: usize,
    /// Intervals along the length.
    pub n_z: usize,
    /// Relative iteration tolerance.
    pub tolerance: f64,
    /// Pressure held at ambient along the maximum-film line (never with grooves or arcs).
    pub max_film_inlet: bool,
    /// `Some(target)`: the grid is chosen per state from the nested multigrid solutions
    /// until the Richardson estimate of the load vector's relative error is below
    /// `target` (`n_theta`/`n_z` are then 0: the grid varies), or, with `n_theta`/`n_z`
    /// nonzero, the ladder is climbed to that grid and held there
    /// ([`FiniteSettings::held_grid`]); `None`: the fixed grid.
    pub accuracy: Option<f64>,
    /// Grooves and gaps between arcs: the film's held bands (docs/grooves.md); empty for
    /// the plain 360° bearing.
    pub layout: FilmLayout,
    /// Cavitation model (issue 27): Swift–Stieber, or JFO ([`super::jfo`]), whose field
    /// holds the pressure and then the film fraction (twice the length).
    pub cavitation: Cavitation,
    /// Accuracy mode (Swift–Stieber): after the ladder stops, its last grid is iterated
    /// on until the field's estimated iteration error is below `tolerance`, as on an
    /// explicit grid. For the film friction and flow: boundary gradients, which the
    /// ladder's stop on the loads (accuracy/10) leaves with an iteration error up to about
    /// the accuracy (issue 20). The evaluator sets it where film outputs are requested
    /// (rotor stages do not request them); default false.
    pub polish: bool,
}

impl From<&FiniteSettings> for FiniteGrid {
    fn from(s: &FiniteSettings) -> Self {
        let fixed = s.fixed_grid();
        // Accuracy mode with a held ladder grid: its dimensions (see `FiniteGrid::accuracy`).
        let dims = fixed.or(s.held_grid.map(|[t, z]| (t, z)));
        FiniteGrid {
            n_theta: dims.map_or(0, |g| g.0 as usize),
            n_z: dims.map_or(0, |g| g.1 as usize),
            tolerance: s.tolerance,
            max_film_inlet: s.inlet == Inlet::MaxFilm,
            accuracy: if fixed.is_some() {
                None
            } else {
                Some(s.accuracy)
            },
            layout: FilmLayout::default(),
            cavitation: s.cavitation,
            polish: false,
        }
    }
}

impl FiniteGrid {
    /// The grid of a bearing: its finite settings and its grooves and arcs (which
    /// replace the `max_film` inlet line when present).
    pub fn for_bearing(params: &BearingParams) -> FiniteGrid {
        let layout = params.film_layout();
        let mut g = FiniteGrid::from(&params.finite);
        if !layout.is_empty() {
            g.max_film_inlet = false;
            g.layout = layout;
        }
        g
    }
}

impl FiniteGrid {
    /// Length of a field vector: `n_theta × (n_z + 1)` nodes, row-major in ζ (rows 0 and
    /// `n_z` are the end faces, always 0).
    /// With JFO cavitation the field is the pressure followed by the film fraction, twice
    /// that length.
    pub fn field_len(&self) -> usize {
        let n = self.n_theta * (self.n_z + 1);
        match self.cavitation {
            Cavitation::Reynolds => n,
            Cavitation::Jfo => 2 * n,
        }
    }

    /// Over-relaxation factor: optimal SOR for the constant-film operator, whose slowest
    /// Jacobi mode is uniform in θ and `sin πζ` in ζ: `ρ_J = (cθ + cz cos πΔζ)/(cθ + cz)`,
    /// `ω = 2/(1 + √(1 − ρ_J²))` with `cθ = λ/Δθ²`, `cz = 1/Δζ²`.
    pub fn relaxation(&self, aspect: f64) -> f64 {
        let dt = 2.0 * PI / self.n_theta as f64;
        let dz = 1.0 / self.n_z as f64;
        let ct = aspect * aspect / (dt * dt);
        let cz = 1.0 / (dz * dz);
        let rho = (ct + cz * (PI * dz).cos()) / (ct + cz);
        2.0 / (1.0 + (1.0 - rho * rho).max(0.0).sqrt())
    }

    /// Load integrals of a field of this grid (node 0 at θ = 0, the rectangle rule: those
    /// of a fixed-grid solve's result).
    pub fn integrals(&self, p: &[f64]) -> FilmIntegrals {
        integrals_of(p, self)
    }

    /// Sweep limit: far beyond what a converging solve needs (iterations grow like the
    /// square root of the grid's stiffness times `ln(1/tol)`).
    pub fn max_sweeps(&self) -> u32 {
        (200 * (self.n_theta + self.n_z) as u32).max(20_000)
    }
}

/// One state for the finite solver: the packed kinematics and the bearing's `B/r0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiniteJob {
    /// Packed state (as for the short rule).
    pub state: PackedState,
    /// Length over journal radius `B/r0` (the film's aspect; `λ = (B/r0)²`).
    pub aspect: f64,
    /// Nondimensional pressure per pascal, `δ² / (μ ρ B²)` with `ρ` the rate scale, 1/Pa:
    /// a groove's held `P` is its supply pressure times this (0: no supply pressure).
    pub supply: f64,
    /// Spin over the rate scale, `ω0/ρ` (dimensionless): the Couette part of the rate
    /// vectors, which the JFO model transports the film fraction with (issue 27). `None`
    /// when the job was built without the state's spin ([`FiniteJob::new`]); the
    /// Swift–Stieber solvers do not need it, a JFO solve of such a job returns NaN loads.
    pub spin: Option<f64>,
}

impl FiniteJob {
    /// The job of a packed state of bearing `params`.
    pub fn new(params: &BearingParams, packed: &Packed) -> FiniteJob {
        let supply = if packed.rate_scale > 0.0 && !params.grooves.is_empty() {
            params.clearance * params.clearance
                / (params.viscosity * packed.rate_scale * params.length * params.length)
        } else {
            0.0
        };
        FiniteJob {
            state: packed.state,
            aspect: params.length / params.radius,
            supply,
            spin: None,
        }
    }

    /// The job of a packed state of bearing `params` whose spin is `omega` (rad/s):
    /// [`FiniteJob::new`] with [`FiniteJob::spin`] set (what the JFO model needs).
    pub fn of_state(params: &BearingParams, packed: &Packed, omega: f64) -> FiniteJob {
        let spin = (packed.rate_scale > 0.0).then(|| omega / packed.rate_scale);
        FiniteJob {
            spin,
            ..FiniteJob::new(params, packed)
        }
    }
}

/// How a solve went.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolveReport {
    /// Work in sweeps of the final grid: relaxation node updates on all grids over the
    /// final grid's interior node count, rounded up (PSOR: its red-black sweeps).
    pub sweeps: u32,
    /// Estimated iteration error of the field over its maximum at the end.
    pub iteration_error: f64,
    /// Whether the estimate went below the tolerance before the sweep limit.
    pub converged: bool,
    /// Grid intervals around the circumference of the returned solution.
    pub n_theta: u32,
    /// Grid intervals along the length of the returned solution.
    pub n_z: u32,
    /// Accuracy mode: Richardson estimate of the returned load vector's relative
    /// discretisation error (see [`FiniteSolver::solve`]; the plain film's also counts
    /// the last grid's estimated iteration error, [`simpson_reported`]); 0 on a fixed
    /// grid.
    pub error_estimate: f64,
    /// Accuracy mode: whether the ladder's stop rule reached the requested accuracy (false
    /// when the largest grid, 1024 intervals around, was not enough, or when its last
    /// grid's V-cycles did not reach their stop; session 41). The plain film
    /// stops on [`simpson_stop_bound`] (one grid further where [`ladder_extends`]); its
    /// reported `error_estimate` can exceed the
    /// accuracy on erratic ladders, where the true error does too (up to 1.64× on the
    /// benchmark's 1024 states at the default, true error 5.4e-4; session 40).
    pub accuracy_met: bool,
}

/// One grid of the accuracy ladder ([`FiniteSolver::ladder`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LadderStep {
    /// Intervals around the circumference.
    pub n_theta: usize,
    /// Intervals along the length.
    pub n_z: usize,
    /// Load integrals of this grid's solution (node 0 at the ladder's angle), summed as the
    /// accuracy mode reports them: Simpson's rule in ζ for the plain 360° film
    /// ([`ladder_integrals_on`]), the rectangle rule with grooves or arcs.
    pub integrals: FilmIntegrals,
    /// The same field's load integrals by the rectangle rule (what the ladder reported
    /// before issue 20 pass 4; [`FiniteSolver::reference`] extrapolates these).
    pub rectangle: FilmIntegrals,
    /// Relaxation node updates on all grids since the ladder started (work).
    pub updates: u64,
    /// V-cycles on this grid, estimated iteration error, converged.
    pub result: (u32, f64, bool),
}

/// How accuracy mode iterates the ladder's grids (plain 360° film, Simpson sums; issue 20
/// session 36). The defaults are the solver's; the fields exist so that probes
/// (examples/zeta_probe.rs) can measure the rule against the one before.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LadderRule {
    /// An intermediate grid `k` stops when the estimated iteration error of its load
    /// vector is below `loose × |v_k − v_{k−1}| / 4` (relative to `|v_k|`; `|v_k −
    /// v_{k−1}|/4` is about the next grid's difference, through which alone `v_k` enters
    /// the estimate), or below `floor × accuracy` if that is larger; a grid whose estimate
    /// then meets the accuracy is iterated on to `floor × accuracy` before it ends the
    /// ladder. 0: every grid to `floor × accuracy` (with `floor` = 0.1, the crate's
    /// `ALGEBRAIC_FRACTION`, and the bilinear start: the rule before session 36, same bits). Dimensionless,
    /// default [`LADDER_LOOSE`].
    pub loose: f64,
    /// Whether a ladder grid starts from its coarser grid's solution interpolated by
    /// cubics in ζ (one-sided next to the end faces) instead of the bilinear
    /// interpolation of full multigrid: the linear interpolant's Simpson load sum is the
    /// coarse grid's trapezoid sum, off by the `Δζ²` quadrature error that Simpson's rule
    /// removed, which the first V-cycles then have to remove again. Default
    /// [`LADDER_CUBIC_START`].
    pub cubic_start: bool,
    /// The per-grid stop's floor as a fraction of the accuracy: the estimated iteration
    /// error of the load vector of the grid that ends the ladder is below it.
    /// Dimensionless, default [`LADDER_FLOOR`].
    pub floor: f64,
    /// Smoothing sweeps after the coarse-grid correction in the V-cycles of the ladder's
    /// grids after the first (on every level of the cycle; before it: the cycle's 2).
    /// Default [`LADDER_POST_SWEEPS`]; 1 is the cycle of explicit grids and the ladder's
    /// before session 42.
    pub post: u32,
    /// Whether the grid that ends the ladder does at least two V-cycles, so that the
    /// iteration term its estimate reports is the load vector's measured contraction, not
    /// the 0.5 assumed after one cycle. Default [`LADDER_MEASURED_LAST`]; false is the rule
    /// before session 42.
    pub measured_last: bool,
}

impl Default for LadderRule {
    fn default() -> Self {
        LadderRule {
            loose: LADDER_LOOSE,
            cubic_start: LADDER_CUBIC_START,
            floor: LADDER_FLOOR,
            post: LADDER_POST_SWEEPS,
            measured_last: LADDER_MEASURED_LAST,
        }
    }
}

/// Default of [`LadderRule::loose`]: an intermediate grid's iteration error at most 0.3 of
/// the next grid's expected difference moves that grid's estimate by at most ~0.1 of
/// itself. Measured (`zeta_probe rules 5e-4`, 32 benchmark and 12 test states): every
/// intermediate grid then stops after 2 V-cycles, the least the stop test can measure (1
/// instead of 0.3 gives the same cycles), estimate / true error 0.45-1.33 as before.
pub const LADDER_LOOSE: f64 = 0.3;
/// Default of [`LadderRule::cubic_start`] (measured: 2 V-cycles on 128 × 16 where the
/// bilinear start took 3; cubics in θ as well took more cycles, not used).
pub const LADDER_CUBIC_START: bool = true;
/// Default of [`LadderRule::floor`]: the grid that ends the ladder to accuracy/5 (was /10
/// for every grid): its returned loads are within 0.06 (benchmark) / 0.10 (test states) of
/// the accuracy of the same grid iterated to 1e-10 (tests/finite_accuracy.rs allows 0.25),
/// a V-cycle less on 256 × 32 for most states that end there (mean node updates at the
/// default 60,328 at /10, 57,158 at /7, 54,221 at /5 and beyond; `zeta_probe rules`).
pub const LADDER_FLOOR: f64 = 0.2;
/// Default of [`LadderRule::post`]: the ladder's V-cycles are V(2,0) (issue 20, session
/// 42). The ladder reads only load integrals, in which the rough high-frequency error that
/// a post-smoothing sweep removes nearly cancels, and its next grid starts from an
/// interpolation that a pre-smoothing sweep smooths anyway; a cycle is then 2 sweeps of
/// the grid instead of 3 at about the same contraction of the loads. Measured
/// (examples/zeta_probe.rs `prof 5e-4`, the 32 benchmark states, exact): 55,311 node
/// updates per default state with V(2,1), 45,109 with V(2,0) (0.83× the old 64 × 16 PSOR
/// state's 54,150), 31,925 with V(1,0) (but estimates up to 14.6× their true error on the
/// dense ε 0.8-0.95 scan), 54,968 with V(1,1), 54,345 with V(3,0); estimates within 1/3-3
/// on every tested set (BENCHMARKS.md "Issue 20, session 42").
pub const LADDER_POST_SWEEPS: u32 = 0;
/// Default of [`LadderRule::measured_last`] (issue 20, session 42; measured, not taken).
/// Where the grid that ends the ladder stops after one cycle, its iteration term assumes
/// a contraction of 0.5: at ε 0.907-0.94 squeezed (the dense scan's states 519, 615, 663,
/// 674) the returned loads' true iteration error was 2.5-4.7× that term, up to 0.42 of
/// the accuracy (V(2,0); 0.39 with V(2,1)), and state 615 (ε 0.9275, both ends, its
/// extra 1024 × 128 grid) was 0.29× its true error against 4096 × 512 (0.33× with
/// V(2,1)). With `true`: no cost on the 32 benchmark states (45,109 node updates), +5.2 %
/// on the 732 dense states, the loads' iteration error at most 0.17 of the accuracy,
/// state 615 1.14×, but state 663 (ε 0.9375, one end) then 0.23× its true error 1.72e-4:
/// its discretisation part (3.1e-5) is 5× low, which its one-cycle iteration error had
/// masked (BENCHMARKS.md "Issue 20, session 42").
pub const LADDER_MEASURED_LAST: bool = false;

/// Scratch space of the CPU solver (face coefficients, right-hand side), reused.
#[derive(Default)]
pub struct FiniteSolver {
    mg: Hierarchy,
    ae: Vec<f64>,
    an: Vec<f64>,
    inv_d: Vec<f64>,
    rhs: Vec<f64>,
    /// Held value of each node where `inv_d` is 0.
    hold: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
    /// Scratch of the JFO solver (issue 27).
    jfo: super::jfo::JfoSolver,
    /// Accuracy mode with the loads summed by the rectangle rule and the
    /// measured-contraction estimate ([`ladder_estimate`]), as before issue 20 pass 4:
    /// what the finite-film coefficients and equilibria use to choose their held grid
    /// (src/stability/coefficients.rs), whose coefficient error model is calibrated on that
    /// ladder's convergence (with Simpson sums its half/quarter-grid tail was measured 10 %
    /// short at accuracy 1e-2). Held grids ([`FiniteSettings::held_grid`]) always sum this
    /// way. Default false: Simpson's rule in ζ ([`ladder_integrals_on`]).
    pub rectangle_ladder: bool,
    /// How accuracy mode iterates the Simpson-summed ladder's grids (default: the
    /// solver's rule; probes set others).
    pub ladder_rule: LadderRule,
    /// The grids of the last accuracy-mode solve of the plain or banded film, in order
    /// (for probes: cycles and work per grid). On the Simpson-summed ladder their
    /// `rectangle` sums are not computed (NaN).
    pub trace: Vec<LadderStep>,
    /// The V-cycle of explicit grids ([`FiniteSolver::solve`] with `g.accuracy` `None`,
    /// [`FiniteSolver::fmg_cycles`]): default the red-black point smoother, V(2,1);
    /// probes set others (issue 20, session 37). The accuracy ladder always uses the
    /// default.
    pub cycle: MgCycle,
    /// How the multigrid solves its coarsest grid inside a V-cycle (explicit grids and the
    /// accuracy ladder; default: the solver's; probes set others, issue 20 session 38).
    pub coarsest: CoarsestSolve,
    /// Smoothing sweeps on the levels below the grid being solved (`None`, the default:
    /// the cycle's; probes, issue 20 session 38; see the multigrid's `below_top`).
    pub below_top: Option<(u32, u32)>,
    /// Explicit grids: the coarse-grid correction truncated on the coarse side too (the
    /// multigrid's `coarse_truncation`; issue 20 session 41). Without it the V-cycle
    /// stalls in a limit cycle of the free boundary on grids finer than 1024 × 128 at high
    /// eccentricity (ε 0.9, 4096 × 512: every state tried; the solve then reports
    /// `converged: false`); with it those grids contract by ~0.5 per cycle. Default false:
    /// the WGSL kernel mirrors the correction without it (the accuracy ladder never uses
    /// it). [`FiniteSolver::ladder_beyond`] always uses it.
    pub coarse_truncation: bool,
    /// The load vectors of the accuracy ladder's last grid (of the last solve): at its
    /// start and after each of its V-cycles (for probes of the iteration-error estimate,
    /// examples/bench_worst.rs; issue 20 session 41).
    pub cycle_loads: Vec<FilmIntegrals>,
}

/// Nondimensional film thickness `h/δ` at axial fraction `zeta` and angle `(cos θ, sin θ)`
/// for end eccentricities `ecc` (shared by the PSOR and multigrid solvers).
#[inline]
pub(super) fn film(ecc: &[f64; 4], zeta: f64, c: f64, s: f64) -> f64 {
    let ex = ecc[0] + (ecc[2] - ecc[0]) * zeta;
    let ey = ecc[1] + (ecc[3] - ecc[1]) * zeta;
    1.0 - ex * c - ey * s
}

impl FiniteSolver {
    /// A solver with empty scratch space.
    pub fn new() -> Self {
        Self::default()
    }

    fn setup(&mut self, job: &FiniteJob, g: &FiniteGrid) {
        let (nt, nz) = (g.n_theta, g.n_z);
        let n = g.field_len();
        let dt = 2.0 * PI / nt as f64;
        let dz = 1.0 / nz as f64;
        let ct = job.aspect * job.aspect / (dt * dt);
        let cz = 1.0 / (dz * dz);
        let e = &job.state.ecc;
        let r = &job.state.rate;
        self.cos.clear();
        self.sin.clear();
        // Node angles θ_i = iΔθ and face angles θ_{i+½}, interleaved: index 2i and 2i+1.
        for k in 0..2 * nt {
            let th = 0.5 * dt * k as f64;
            self.cos.push(th.cos());
            self.sin.push(th.sin());
        }
        for v in [
            &mut self.ae,
            &mut self.an,
            &mut self.inv_d,
            &mut self.rhs,
            &mut self.hold,
        ] {
            v.clear();
            v.resize(n, 0.0);
        }
        let held = g.layout.held_nodes(nt, nz, 0.0);
        for j in 0..=nz {
            let zeta = j as f64 * dz;
            let zh = (j as f64 + 0.5) * dz;
            let a = r[0] + (r[2] - r[0]) * zeta;
            let b = r[1] + (r[3] - r[1]) * zeta;
            for i in 0..nt {
                let k = j * nt + i;
                let hf = film(e, zeta, self.cos[2 * i + 1], self.sin[2 * i + 1]);
                self.ae[k] = ct * hf * hf * hf * held.east[k];
                if j < nz {
                    let hn = film(e, zh, self.cos[2 * i], self.sin[2 * i]);
                    self.an[k] = cz * hn * hn * hn * held.north[k];
                }
                self.rhs[k] = 6.0 * (a * self.sin[2 * i] - b * self.cos[2 * i]);
            }
        }
        for j in 1..nz {
            for i in 0..nt {
                let k = j * nt + i;
                let im = if i == 0 { nt - 1 } else { i - 1 };
                let d = self.ae[k] + self.ae[j * nt + im] + self.an[k] + self.an[k - nt];
                if held.held_pa[k] >= 0.0 {
                    // A groove or a gap between arcs: held at its pressure.
                    self.inv_d[k] = 0.0;
                    self.hold[k] = held.held_pa[k] * job.supply;
                } else {
                    self.inv_d[k] = 1.0 / d;
                }
            }
            if g.max_film_inlet {
                // The column nearest the maximum film, angle arg(−ε(ζ)): held at zero
                // (a zero inverse diagonal makes the update return 0, see `solve`).
                let zeta = j as f64 * dz;
                let ex = e[0] + (e[2] - e[0]) * zeta;
                let ey = e[1] + (e[3] - e[1]) * zeta;
                if ex != 0.0 || ey != 0.0 {
                    let th = (-ey).atan2(-ex).rem_euclid(2.0 * PI);
                    let i = (th / dt).round() as usize % nt;
                    self.inv_d[j * nt + i] = 0.0;
                }
            }
        }
    }

    /// Keeps (`true`) or drops the breakdown of the multigrid's node updates by grid and
    /// role ([`FiniteSolver::work_tally`]; for probes, issue 20 session 38). Off by default.
    pub fn keep_work_tally(&mut self, on: bool) {
        self.mg.tally = on.then(Vec::new);
    }

    /// The node updates since [`FiniteSolver::keep_work_tally`] (or the last
    /// [`FiniteSolver::take_work_tally`]) by grid solved, grid relaxed and role (empty when
    /// not kept); the tally restarts.
    pub fn take_work_tally(&mut self) -> Vec<super::WorkShare> {
        match self.mg.tally.as_mut() {
            Some(t) => std::mem::take(t),
            None => Vec::new(),
        }
    }

    /// Keeps (`true`) or drops the multigrid's per-cycle log on the field stop
    /// ([`super::CycleLog`]: explicit grids and [`FiniteSolver::ladder_beyond`]; for
    /// probes, issue 20 session 41). Off by default.
    pub fn keep_cycle_log(&mut self, on: bool) {
        self.mg.cycle_log = on.then(Vec::new);
    }

    /// The cycles logged since [`FiniteSolver::keep_cycle_log`] (or the last call); the
    /// log restarts.
    pub fn take_cycle_log(&mut self) -> Vec<super::CycleLog> {
        match self.mg.cycle_log.as_mut() {
            Some(t) => std::mem::take(t),
            None => Vec::new(),
        }
    }

    /// Solves one state by projected full multigrid ([`super::multigrid`]).
    ///
    /// Fixed grid (`g.accuracy` is `None`): from a cold start, full multigrid from the
    /// coarsest grid (one V-cycle per intermediate grid, each grid started from the
    /// cubic interpolation of the next coarser one's solution) and V-cycles on `g`'s grid
    /// until the estimated iteration error is below `g.tolerance`; with `field` of the grid's
    /// length (finite, nonnegative: a warm start) V-cycles from it.
    ///
    /// Accuracy mode (`g.accuracy = Some(target)`): the grids of [`accuracy_ladder`]
    /// (both directions doubled per step), each iterated from the previous one's
    /// interpolated solution until the estimated iteration error of its load vector is
    /// below `max(ALGEBRAIC_FRACTION × target, g.tolerance)` (the plain film: the stop of
    /// [`LadderRule`], by the grid's role), until the Richardson estimate of the load
    /// vector's relative error ([`ladder_estimate`]) is at most `target`; the loads of
    /// the last grid are returned, with the estimate in the report. `field` is not used
    /// as a start (its grid varies); it receives the last grid's solution.
    pub fn solve(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        field: &mut Vec<f64>,
    ) -> (FilmIntegrals, SolveReport) {
        if g.cavitation == Cavitation::Jfo {
            // Mass-conserving cavitation (issue 27), steady: its own solver.
            let mut jfo = std::mem::take(&mut self.jfo);
            let out = jfo.solve(self, job, g, field, None);
            self.jfo = jfo;
            return out;
        }
        match g.accuracy {
            Some(target) if g.n_theta > 0 => self.solve_held(job, g, target, field),
            Some(target) => self.solve_accuracy(job, g, target, field),
            None => self.solve_fixed(job, g, field),
        }
    }

    /// Accuracy mode on a held grid (`g.n_theta × g.n_z`, a grid of the ladder): the
    /// ladder of [`FiniteSolver::solve`] up to that grid (each grid iterated as in
    /// accuracy mode, node 0 on the state's mid-plane maximum film), then the held grid
    /// iterated on until the estimated iteration error of its load vector is below
    /// `g.tolerance`, so that the loads of nearby states differ by their discretised
    /// film's difference, not by the iteration's stopping point (what a finite difference
    /// or a Newton iteration over states needs). The report carries the ladder's
    /// Richardson estimate of the held grid's loads (infinite below three grids) and the
    /// grid actually solved (the ladder's first grid when the held one is coarser; the
    /// first ladder grid at least as fine when it is not on the ladder). `field` is not
    /// used as a start; it receives the solution.
    fn solve_held(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        target: f64,
        field: &mut Vec<f64>,
    ) -> (FilmIntegrals, SolveReport) {
        let ladder = accuracy_ladder(job.aspect);
        let stop = Stop::Loads((ALGEBRAIC_FRACTION * target).max(g.tolerance));
        // Held grids (coefficients and equilibria) sum by the rectangle rule, as before
        // issue 20 pass 4 (see `FiniteSolver::rectangle_ladder`).
        let keep = std::mem::replace(&mut self.rectangle_ladder, true);
        let start = self.ladder_start(job, g, stop);
        self.rectangle_ladder = keep;
        let mut values = vec![start.integrals];
        let mut top_nt = self.mg.levels.last().map_or(0, |l| l.nt);
        for &dims in &ladder[1..] {
            if top_nt >= g.n_theta {
                break;
            }
            values.push(self.ladder_next(job, g, dims, stop).integrals);
            top_nt = dims.0;
        }
        let top = self.mg.levels.len() - 1;
        // The held grid polished to the tolerance (a few V-cycles from accuracy/10).
        let res = self
            .mg
            .iterate(top, job.aspect, Stop::Loads(g.tolerance), MAX_CYCLES);
        let last = self.mg.levels[top].loads(self.mg.theta0, self.mg.simpson_z);
        *values.last_mut().expect("at least one grid") = last;
        let estimate = if g.layout.is_empty() {
            ladder_estimate(&values)
        } else {
            banded_estimate(&values)
        }
        .unwrap_or(f64::INFINITY);
        field.clear();
        field.extend_from_slice(&self.mg.levels[top].p);
        let mut report = self.report(top, res);
        report.error_estimate = estimate;
        report.accuracy_met = estimate <= target;
        (last, report)
    }

    /// Full multigrid from the bottom level to `top`: one V-cycle on each intermediate
    /// level, cycles to `tol` on `top`, bilinear starts (the accuracy ladder's first grid).
    fn fmg(&mut self, aspect: f64, top: usize, stop: Stop) -> (u32, f64, bool) {
        self.fmg_with(aspect, top, stop, stop, MAX_CYCLES, false)
    }

    /// Full multigrid from the bottom level to `top`: one V-cycle on each intermediate
    /// level, at most `top_cycles` on `top` (0: `top` only interpolated) with the stop
    /// `top_stop` (`stop` below it); each level
    /// starts from the next coarser one's solution interpolated cubically
    /// ([`prolong_solution_cubic`], explicit grids) or bilinearly ([`prolong_solution`],
    /// the accuracy ladder's first grid, whose estimates are calibrated on it).
    fn fmg_with(
        &mut self,
        aspect: f64,
        top: usize,
        stop: Stop,
        top_stop: Stop,
        top_cycles: u32,
        cubic: bool,
    ) -> (u32, f64, bool) {
        // Explicit grids: the first grid only feeds the next one's interpolated start,
        // whose error is the first grid's discretisation error (~10 % on 16 × 4): solved
        // to `FMG_FIRST_TOLERANCE` if that is looser than the grid's tolerance (the
        // accuracy ladder's first grid is one of its estimate's grids: its own stop).
        let first = match stop {
            Stop::Field(t) if cubic && top > 0 => Stop::Field(t.max(FMG_FIRST_TOLERANCE)),
            s => s,
        };
        let mut res = self.mg.iterate(0, aspect, first, MAX_CYCLES);
        for l in 1..=top {
            let (lo, hi) = self.mg.levels.split_at_mut(l);
            let c = hi[0].coarsen.expect("a finer level has a coarsening");
            if cubic {
                prolong_solution_cubic(&mut hi[0], &lo[l - 1], c);
            } else {
                prolong_solution(&mut hi[0], &lo[l - 1], c);
            }
            if l == top {
                res = self.mg.iterate(l, aspect, top_stop, top_cycles);
            } else {
                // Its one cycle's stop test decides nothing (issue 20, session 39).
                self.mg.cycle_once(l, aspect, stop);
            }
        }
        res
    }

    /// Probe of the equal-error comparison (examples/mg_equal_error.rs): the fixed grid
    /// `g` from cold by full multigrid as [`FiniteSolver::solve`] does it, then exactly
    /// `cycles` V-cycles on the grid (no stop test); `observe(node updates so far, field)`,
    /// when given, once the grid is interpolated from the next coarser one's solution and
    /// after each of its V-cycles (without it the cycles run as in `solve`: the cost of
    /// that work, e.g. under callgrind).
    pub fn fmg_cycles(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        cycles: u32,
        mut observe: FieldObserver<'_>,
    ) -> (FilmIntegrals, SolveReport) {
        self.mg.theta0 = 0.0;
        self.mg.updates = 0;
        self.mg.line_freeze = true;
        self.mg.simpson_z = false;
        self.mg.cycle = self.cycle;
        self.mg.coarsest = self.coarsest;
        self.mg.below_top = self.below_top;
        self.mg.coarse_truncation = self.coarse_truncation;
        self.mg.build(job, g.n_theta, g.n_z, g);
        let top = self.mg.levels.len() - 1;
        // The coarser grids as in `solve_fixed` (the coarsest solved to the tolerance);
        // on the top grid no stop: only an all-zero change ends its cycles early.
        let fmg_stop = Stop::Field(g.tolerance);
        let none = Stop::Field(-1.0);
        let res = match observe.as_mut() {
            Some(observe) => {
                let mut res = self.fmg_with(job.aspect, top, fmg_stop, none, 0, true);
                observe(self.mg.updates, &self.mg.levels[top].p);
                for _ in 0..cycles {
                    res = self.mg.iterate(top, job.aspect, none, 1);
                    observe(self.mg.updates, &self.mg.levels[top].p);
                }
                res
            }
            // The cost probe: the top grid's cycles in the call that interpolates it, as
            // `solve` runs them (one `iterate` on the top grid: its coarse grids frozen
            // once; issue 20, session 39: a second call redid those freezes, work `solve`
            // does not do). The single-level grid keeps its second call (its first solves).
            None if top > 0 => self.fmg_with(job.aspect, top, fmg_stop, none, cycles, true),
            None => {
                self.fmg_with(job.aspect, top, fmg_stop, none, 0, true);
                self.mg.iterate(top, job.aspect, none, cycles)
            }
        };
        self.mg.cycle = MgCycle::default();
        (self.top_integrals(top), self.report(top, res))
    }

    /// [`integrals_of`] the top level's iterate, from the level's table of column angles
    /// (the same bits, see [`super::multigrid::Level::loads`]; issue 20, session 39: `integrals_of` evaluates
    /// a sine and cosine per column and state).
    fn top_integrals(&self, top: usize) -> FilmIntegrals {
        self.mg.levels[top].loads(self.mg.theta0, false)
    }

    fn report(&self, top: usize, res: (u32, f64, bool)) -> SolveReport {
        let lvl = &self.mg.levels[top];
        let interior = (lvl.nt * (lvl.nz - 1)).max(1) as u64;
        SolveReport {
            sweeps: self.mg.updates.div_ceil(interior) as u32,
            iteration_error: res.1,
            converged: res.2,
            n_theta: lvl.nt as u32,
            n_z: lvl.nz as u32,
            error_estimate: 0.0,
            accuracy_met: false,
        }
    }

    fn solve_fixed(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        field: &mut Vec<f64>,
    ) -> (FilmIntegrals, SolveReport) {
        let warm = field.len() == g.field_len() && field.iter().all(|v| v.is_finite() && *v >= 0.0);
        self.mg.theta0 = 0.0;
        self.mg.updates = 0;
        self.mg.line_freeze = true;
        self.mg.simpson_z = false;
        self.mg.cycle = self.cycle;
        self.mg.coarsest = self.coarsest;
        self.mg.below_top = self.below_top;
        self.mg.coarse_truncation = self.coarse_truncation;
        self.mg.build(job, g.n_theta, g.n_z, g);
        let top = self.mg.levels.len() - 1;
        let res = if warm {
            self.mg.levels[top].load_field(field);
            self.mg
                .iterate(top, job.aspect, Stop::Field(g.tolerance), MAX_CYCLES)
        } else {
            let stop = Stop::Field(g.tolerance);
            self.fmg_with(job.aspect, top, stop, stop, MAX_CYCLES, true)
        };
        field.clear();
        field.extend_from_slice(&self.mg.levels[top].p);
        // The accuracy ladder keeps the point smoother (see `FiniteSolver::cycle`).
        self.mg.cycle = MgCycle::default();
        (self.top_integrals(top), self.report(top, res))
    }

    /// Starts the accuracy ladder: node 0 on the mid-plane's maximum film (max-film
    /// inlet), the first grid solved by full multigrid to `tol`; returns its step.
    fn ladder_start(&mut self, job: &FiniteJob, g: &FiniteGrid, stop: Stop) -> LadderStep {
        let ladder = accuracy_ladder(job.aspect);
        // With the inlet held on the maximum-film line, node 0 sits on the mid-plane's
        // maximum film: on every grid of the ladder the line is then on the grid (exactly
        // for a journal tilted in the plane of its eccentricity), instead of snapped to
        // the nearest column, an irregular first-order error that breaks the Richardson
        // estimate (measured: estimate/true 0.2-8 with snapping, 0.8-1.6 without).
        self.mg.theta0 = super::ladder_theta0(job, g.max_film_inlet);
        self.mg.updates = 0;
        self.mg.coarsest = self.coarsest;
        self.mg.below_top = self.below_top;
        // The kernel's correction (see `FiniteSolver::coarse_truncation`); the finer
        // references of `ladder_beyond` set it on after this.
        self.mg.coarse_truncation = false;
        self.mg.line_freeze = false;
        // The default V(2,1) (`solve_accuracy` sets the ladder's own from its second grid).
        self.mg.cycle = MgCycle::default();
        // The plain 360° film sums its loads by Simpson's rule in ζ (see
        // `ladder_integrals_on`); grooves and arcs keep the rectangle rule, whose
        // banded estimate is calibrated on it (tests/grooves.rs).
        self.mg.simpson_z = g.layout.is_empty() && !self.rectangle_ladder;
        self.mg.build(job, ladder[0].0, ladder[0].1, g);
        let top = self.mg.levels.len() - 1;
        let res = self.fmg(job.aspect, top, stop);
        self.ladder_step(top, res)
    }

    /// Adds the ladder's next grid `nt × nz` on top, starts it from the interpolated
    /// solution below and iterates it to `tol`.
    fn ladder_next(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        (nt, nz): (usize, usize),
        stop: Stop,
    ) -> LadderStep {
        self.mg.push_finer(job, nt, nz, g, Coarsen::Both);
        let top = self.mg.levels.len() - 1;
        let (lo, hi) = self.mg.levels.split_at_mut(top);
        prolong_solution(&mut hi[0], &lo[top - 1], Coarsen::Both);
        let res = self.mg.iterate(top, job.aspect, stop, MAX_CYCLES);
        self.ladder_step(top, res)
    }

    fn ladder_step(&self, top: usize, res: (u32, f64, bool)) -> LadderStep {
        let lvl = &self.mg.levels[top];
        // The level's column table (`Level::loads`): the same bits as `integrals_at`.
        let rectangle = lvl.loads(self.mg.theta0, false);
        LadderStep {
            n_theta: lvl.nt,
            n_z: lvl.nz,
            integrals: if self.mg.simpson_z {
                lvl.loads(self.mg.theta0, true)
            } else {
                rectangle
            },
            rectangle,
            updates: self.mg.updates,
            result: res,
        }
    }

    /// The first `levels` grids of the accuracy ladder of `job` (see [`accuracy_ladder`]),
    /// each iterated until the estimated iteration error is below `tol` (of the load
    /// vector over its norm when `on_loads`, as the accuracy mode does, else of the field
    /// over its maximum), with their load integrals and the work done so far (a probe of
    /// the ladder's convergence for examples and tests; the solve itself stops at the
    /// requested accuracy).
    pub fn ladder(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        tol: f64,
        on_loads: bool,
        levels: usize,
    ) -> Vec<LadderStep> {
        let stop = if on_loads {
            Stop::Loads(tol)
        } else {
            Stop::Field(tol)
        };
        let ladder = accuracy_ladder(job.aspect);
        let mut out = vec![self.ladder_start(job, g, stop)];
        for &dims in ladder.iter().skip(1).take(levels.saturating_sub(1)) {
            out.push(self.ladder_next(job, g, dims, stop));
        }
        out
    }

    /// [`FiniteSolver::ladder`] carried `extra` grids past the accuracy ladder's finest
    /// (each doubled in both directions: at B/D = 0.5, 2048 × 256 and 4096 × 512), every
    /// grid iterated to `tol` on the field: the finer references of probes and tests
    /// (issue 20 session 40: at ε ≥ 0.9 the ladder's own 1024 × 128 extrapolate is not
    /// converged to a tenth of the default's error). Memory grows ×4 per extra grid
    /// (2048 × 256: ~40 MB).
    pub fn ladder_beyond(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        tol: f64,
        extra: usize,
    ) -> Vec<LadderStep> {
        let stop = Stop::Field(tol);
        let mut dims = accuracy_ladder(job.aspect);
        for _ in 0..extra {
            let (nt, nz) = dims[dims.len() - 1];
            dims.push((2 * nt, 2 * nz));
        }
        let mut out = vec![self.ladder_start(job, g, stop)];
        // The coarse side truncated too (issue 20 session 41): without it 2048 × 256
        // stalled on 40 of 96 states at ε 0.88-0.95 and 4096 × 512 on every state tried.
        // On the grids that converge either way the fields agree to `tol`.
        self.mg.coarse_truncation = true;
        for &d in &dims[1..] {
            out.push(self.ladder_next(job, g, d, stop));
        }
        self.mg.coarse_truncation = false;
        out
    }

    /// [`FiniteSolver::ladder`] with each grid's field (row-major, `n_theta × (n_z + 1)`)
    /// and the angle of node 0 (rad): for probes of load sums and error estimates
    /// (examples/zeta_probe.rs).
    pub fn ladder_fields(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        tol: f64,
        on_loads: bool,
        levels: usize,
    ) -> (f64, Vec<(LadderStep, Vec<f64>)>) {
        let stop = if on_loads {
            Stop::Loads(tol)
        } else {
            Stop::Field(tol)
        };
        let ladder = accuracy_ladder(job.aspect);
        let first = self.ladder_start(job, g, stop);
        let top = |s: &Self| s.mg.levels[s.mg.levels.len() - 1].p.clone();
        let mut out = vec![(first, top(self))];
        for &dims in ladder.iter().skip(1).take(levels.saturating_sub(1)) {
            let step = self.ladder_next(job, g, dims, stop);
            out.push((step, top(self)));
        }
        (self.mg.theta0, out)
    }

    /// The converged reference of a state for benchmarks and probes: the ladder's two
    /// finest grids (up to 1024 intervals around), iterated to 1e-10, their loads summed
    /// by the rectangle rule (as before issue 20 pass 4: the reference does not depend on
    /// the load sum it checks), Richardson-
    /// extrapolated `(4 v_h − v_2h)/3` (good to ~1e-5 on the states of
    /// tests/finite_accuracy.rs, whose ladder converges at second order). The inlet line is
    /// on the grid at every level (unlike a fixed grid's snapped column, an irregular
    /// first-order error in tilted states).
    pub fn reference(&mut self, job: &FiniteJob, g: &FiniteGrid) -> FilmIntegrals {
        let steps = self.ladder(job, g, 1e-10, false, usize::MAX);
        let n = steps.len();
        if n < 2 {
            return steps[n - 1].rectangle;
        }
        let (f, c) = (&steps[n - 1].rectangle, &steps[n - 2].rectangle);
        std::array::from_fn(|k| (4.0 * f[k] - c[k]) / 3.0)
    }

    fn solve_accuracy(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        target: f64,
        field: &mut Vec<f64>,
    ) -> (FilmIntegrals, SolveReport) {
        let ladder = accuracy_ladder(job.aspect);
        let floor = (ALGEBRAIC_FRACTION * target).max(g.tolerance);
        let stop = Stop::Loads(floor);
        let mut steps = vec![self.ladder_start(job, g, stop)];
        let mut values = vec![steps[0].integrals];
        let mut estimate = f64::INFINITY;
        let mut met = false;
        // The session-36 rule (`LadderRule`) on the Simpson-summed ladder only: grooves,
        // arcs and the rectangle ladder of coefficients keep every grid to the floor.
        let rule = if self.mg.simpson_z {
            self.ladder_rule
        } else {
            LadderRule {
                loose: 0.0,
                cubic_start: false,
                floor: ALGEBRAIC_FRACTION,
                post: MgCycle::default().post,
                measured_last: false,
            }
        };
        // The ladder's V-cycles from its second grid on (the first grid's full multigrid
        // keeps the default cycle; the polish below too).
        self.mg.cycle.post = rule.post;
        let floor = (rule.floor * target).max(g.tolerance);
        for &dims in &ladder[1..] {
            let below = values[values.len() - 1];
            self.ladder_grow(job, g, dims, rule.cubic_start);
            let mut cyc = LadderCycles::default();
            let mut res = self.ladder_cycles(job.aspect, &mut cyc, floor, rule.loose, &below, 1);
            let mut step = self.ladder_step_of(&cyc, res);
            values.push(step.integrals);
            // (the bound the ladder stops on, the estimate it reports): one and the same
            // but on the Simpson-summed ladder of the plain film, which stops on
            // `simpson_stop_bound` and reports `simpson_reported` (with the grid's
            // estimated iteration error `it`; it may exceed the accuracy: stopping on it
            // too cost +21.5 % node updates at the default, session 40).
            let est_of = |values: &[FilmIntegrals], simpson: bool, it: f64| {
                if !g.layout.is_empty() {
                    banded_estimate(values).map(|e| (e, e))
                } else if simpson {
                    simpson_stop_bound(values).zip(simpson_reported(values, it))
                } else {
                    ladder_estimate(values).map(|e| (e, e))
                }
            };
            // Whether the grid may end the ladder (the bound: without `it`; on the
            // Simpson-summed ladder not where its last pair is out of the asymptotic
            // range and a finer grid is left, see `ladder_extends`).
            let more = dims != ladder[ladder.len() - 1];
            let simpson = self.mg.simpson_z && g.layout.is_empty();
            let ends = |values: &[FilmIntegrals], bound: f64| {
                bound <= target && !(simpson && more && ladder_extends(values))
            };
            let mut est = est_of(&values, self.mg.simpson_z, 0.0);
            let last_min = if rule.measured_last { 2 } else { 1 };
            if est.is_some_and(|e| ends(&values, e.0)) && (res.1 > floor || cyc.cycles < last_min) {
                // Stopped loosely as an intermediate grid, but it may end the ladder:
                // on to the floor, and to a second cycle with `measured_last` (the cycles
                // continue, none is repeated).
                res = self.ladder_cycles(job.aspect, &mut cyc, floor, 0.0, &below, last_min);
                step = self.ladder_step_of(&cyc, res);
                *values.last_mut().expect("pushed") = step.integrals;
            }
            // The reported iteration term: the load vector's own contraction (issue 20
            // session 41, s41-honest2), not the stop's `res.1`.
            est = est_of(&values, self.mg.simpson_z, cyc.reported_iteration());
            steps.push(step);
            if let Some((bound, e)) = est {
                estimate = e;
                // A grid whose V-cycles did not reach their stop (`res.2`) does not end
                // the ladder: its loads' iteration error is not known to be small.
                if ends(&values, bound) && res.2 {
                    met = true;
                    break;
                }
            }
        }
        self.mg.cycle = MgCycle::default();
        let top = self.mg.levels.len() - 1;
        let last = steps.last().expect("at least one grid");
        let (integrals, result) = if g.polish {
            // Film outputs wanted: the field to the tolerance (see `FiniteGrid::polish`).
            let res = self
                .mg
                .iterate(top, job.aspect, Stop::Field(g.tolerance), MAX_CYCLES);
            let polished = self.mg.levels[top].loads(self.mg.theta0, self.mg.simpson_z);
            if self.mg.simpson_z && g.layout.is_empty() {
                // The reported estimate of the polished loads: their pairs, and the
                // polished grid's iteration error instead of the ladder stop's, which
                // the polish removed (issue 20 session 41: counted, it made the estimate
                // 4× a true error of 2e-5 at ε 0.9325, squeezed).
                let mut v = values.clone();
                *v.last_mut().expect("at least one grid") = polished;
                if let Some(e) = simpson_reported(&v, res.1) {
                    estimate = e;
                }
            }
            (polished, res)
        } else {
            (last.integrals, last.result)
        };
        field.clear();
        field.extend_from_slice(&self.mg.levels[top].p);
        let mut report = self.report(top, result);
        report.error_estimate = estimate;
        report.accuracy_met = met;
        self.trace.clear();
        self.trace.extend_from_slice(&steps);
        (integrals, report)
    }

    /// Adds the ladder's next grid `nt × nz` on top and starts it from the solution
    /// below: bilinear (full multigrid's interpolation), then with `cubic` the rows
    /// between the coarse rows again by cubics in ζ (see [`LadderRule::cubic_start`]).
    fn ladder_grow(&mut self, job: &FiniteJob, g: &FiniteGrid, dims: (usize, usize), cubic: bool) {
        self.mg.push_finer(job, dims.0, dims.1, g, Coarsen::Both);
        let top = self.mg.levels.len() - 1;
        let (lo, hi) = self.mg.levels.split_at_mut(top);
        prolong_solution(&mut hi[0], &lo[top - 1], Coarsen::Both);
        if cubic {
            let (nt, nz) = dims;
            let lvl = &mut self.mg.levels[top];
            let mut p = std::mem::take(&mut lvl.p);
            cubic_rows_in_zeta(&mut p, lvl.operator().3, nt, nz);
            lvl.p = p;
        }
    }

    /// The load vector of the ladder's top grid as its level sums it
    /// ([`super::multigrid::Level::loads`]: Simpson in ζ when `simpson`, else the
    /// rectangle rule; the same bits).
    fn top_loads(&mut self, simpson: bool) -> FilmIntegrals {
        // The level's own column table (see `Level::set_trig`): one per grid and state.
        self.mg.levels[self.mg.levels.len() - 1].loads(self.mg.theta0, simpson)
    }

    /// The ladder step of the top grid after [`FiniteSolver::ladder_cycles`]: its loads
    /// are the last cycle's (the rectangle sums on the Simpson-summed ladder are not
    /// computed: NaN).
    fn ladder_step_of(&self, cyc: &LadderCycles, res: (u32, f64, bool)) -> LadderStep {
        let lvl = &self.mg.levels[self.mg.levels.len() - 1];
        LadderStep {
            n_theta: lvl.nt,
            n_z: lvl.nz,
            integrals: cyc.prev,
            rectangle: if self.mg.simpson_z {
                [f64::NAN; 4]
            } else {
                cyc.prev
            },
            updates: self.mg.updates,
            result: res,
        }
    }

    /// V-cycles on the ladder's top grid, continuing `cyc` (a fresh one: the grid's
    /// first cycle), until the estimated iteration error of its load vector (as
    /// [`super::multigrid::Hierarchy::iterate`] estimates it: the last change times the
    /// measured contraction's geometric tail) is below `max(floor, loose × |v − below| /
    /// 4 / |v|)` and at least `min_cycles` are done; returns (cycles on this grid,
    /// estimated error, converged).
    fn ladder_cycles(
        &mut self,
        aspect: f64,
        cyc: &mut LadderCycles,
        floor: f64,
        loose: f64,
        below: &FilmIntegrals,
        min_cycles: u32,
    ) -> (u32, f64, bool) {
        let top = self.mg.levels.len() - 1;
        let simpson = self.mg.simpson_z;
        let tol = |v: &FilmIntegrals| {
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if loose > 0.0 && norm > 0.0 {
                let d = (0..4)
                    .map(|k| (v[k] - below[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                // 4: the next grid's difference at second order.
                floor.max(loose * d / 4.0 / norm)
            } else {
                floor
            }
        };
        if cyc.cycles == 0 {
            self.cycle_loads.clear();
            // The loads of the grid's start (bilinear or cubic from the grid below): the
            // first cycle's change as a vector (the reported iteration error's
            // contraction from the second cycle on).
            let start = self.top_loads(simpson);
            self.cycle_loads.push(start);
            // The first cycle through `iterate` (which sets the grid up as the top one);
            // with one cycle its estimate is the change itself (contraction 0.5 assumed).
            let (_, err, _) = self.mg.iterate(top, aspect, Stop::Loads(f64::INFINITY), 1);
            cyc.cycles = 1;
            cyc.prev = self.top_loads(simpson);
            cyc.delta = std::array::from_fn(|q| cyc.prev[q] - start[q]);
            self.cycle_loads.push(cyc.prev);
            cyc.last_change = err;
            cyc.err = err;
        }
        if cyc.last_change == 0.0 || (cyc.err <= tol(&cyc.prev) && cyc.cycles >= min_cycles) {
            return (cyc.cycles, cyc.err, true);
        }
        while cyc.cycles < MAX_CYCLES {
            self.mg.vcycle(top, aspect);
            cyc.cycles += 1;
            let now = self.top_loads(simpson);
            let change = load_change(&now, &cyc.prev);
            cyc.last_delta = cyc.delta;
            cyc.delta = std::array::from_fn(|q| now[q] - cyc.prev[q]);
            cyc.prev = now;
            self.cycle_loads.push(now);
            // The estimate of `Hierarchy::iterate`.
            cyc.err = tail_estimate(change, cyc.last_change);
            cyc.last_change = change;
            if change == 0.0 || (cyc.err <= tol(&now) && cyc.cycles >= min_cycles) {
                return (cyc.cycles, cyc.err, true);
            }
        }
        (cyc.cycles, cyc.err, false)
    }

    /// Solves one state by red-black projected SOR on the fixed grid `g` (the solver
    /// before issue 20, kept as the reference). `field` is the initial guess when its
    /// length is the grid's (warm start), else it is reset to zero; it holds the
    /// solution on return.
    pub fn solve_psor(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        field: &mut Vec<f64>,
    ) -> (FilmIntegrals, SolveReport) {
        self.psor_run(job, g, field, g.max_sweeps(), |_, _| {})
    }

    /// Exactly `sweeps` red-black projected SOR sweeps on the fixed grid `g` from `field`
    /// (as [`FiniteSolver::solve_psor`]: a cold start unless it is a valid field of the
    /// grid), no stop test; `observe(node updates so far, field)` after each sweep
    /// ([`FiniteGrid::integrals`] gives its loads). The probe of
    /// the equal-error comparison (examples/mg_equal_error.rs: the work PSOR needs to get
    /// within a bound of the converged loads, judged against the truth).
    pub fn psor_sweeps(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        field: &mut Vec<f64>,
        sweeps: u32,
        mut observe: impl FnMut(u64, &[f64]),
    ) -> (FilmIntegrals, SolveReport) {
        let probe = FiniteGrid {
            // No stop: only an all-zero change (an exact fixed point) ends it early.
            tolerance: -1.0,
            ..*g
        };
        let interior = (g.n_theta * (g.n_z - 1)) as u64;
        self.psor_run(job, &probe, field, sweeps, |n, p| {
            observe(n as u64 * interior, p)
        })
    }

    /// The PSOR iteration of [`FiniteSolver::solve_psor`], at most `max_sweeps` sweeps,
    /// `observe` called after each.
    fn psor_run(
        &mut self,
        job: &FiniteJob,
        g: &FiniteGrid,
        field: &mut Vec<f64>,
        max_sweeps: u32,
        mut observe: impl FnMut(u32, &[f64]),
    ) -> (FilmIntegrals, SolveReport) {
        let (nt, nz) = (g.n_theta, g.n_z);
        if field.len() != g.field_len() || field.iter().any(|v| !v.is_finite() || *v < 0.0) {
            field.clear();
            field.resize(g.field_len(), 0.0);
        }
        self.setup(job, g);
        let omega = g.relaxation(job.aspect);
        let p = field.as_mut_slice();
        let mut report = SolveReport {
            n_theta: nt as u32,
            n_z: nz as u32,
            ..SolveReport::default()
        };
        // Update history for the measured contraction (five sweeps back).
        let mut hist = [f64::INFINITY; 6];
        while report.sweeps < max_sweeps {
            let mut max_dp = 0.0_f64;
            let mut max_p = 0.0_f64;
            for colour in 0..2 {
                for j in 1..nz {
                    let row = j * nt;
                    let start = (colour + j) % 2;
                    let mut i = start;
                    while i < nt {
                        let k = row + i;
                        let (ip, im) = (
                            if i + 1 == nt { row } else { k + 1 },
                            if i == 0 { row + nt - 1 } else { k - 1 },
                        );
                        let s = self.ae[k] * p[ip]
                            + self.ae[im] * p[im]
                            + self.an[k] * p[k + nt]
                            + self.an[k - nt] * p[k - nt];
                        let old = p[k];
                        let new = if self.inv_d[k] == 0.0 {
                            self.hold[k]
                        } else {
                            let gs = (s - self.rhs[k]) * self.inv_d[k];
                            (old + omega * (gs - old)).max(0.0)
                        };
                        p[k] = new;
                        max_dp = max_dp.max((new - old).abs());
                        max_p = max_p.max(new);
                        i += 2;
                    }
                }
            }
            report.sweeps += 1;
            observe(report.sweeps, p);
            hist.rotate_left(1);
            hist[5] = max_dp;
            // Contraction per sweep: at least SOR's ω − 1, or what the last five showed.
            let measured = if hist[0].is_finite() && hist[0] > 0.0 {
                (hist[5] / hist[0]).powf(0.2)
            } else {
                0.0
            };
            let rho = measured.max(omega - 1.0).min(0.9999);
            report.iteration_error = if max_p > 0.0 {
                max_dp * rho / (1.0 - rho) / max_p
            } else {
                0.0
            };
            if max_dp == 0.0 || (report.sweeps >= 6 && report.iteration_error <= g.tolerance) {
                report.converged = true;
                break;
            }
        }
        (integrals_of(p, g), report)
    }
}

/// Accuracy mode with grooves or arcs, the rectangle-summed ladder of coefficients and
/// equilibria, and the first grid of every ladder (the plain film's Simpson-summed ladder
/// follows [`LadderRule`] since session 36, on the CPU and, since session 37, in the WGSL
/// kernel): each grid of the ladder is iterated until the estimated iteration error of its
/// load vector is below this fraction of the requested accuracy (or
/// `finite.tolerance`, if larger). Iterating further buys nothing: the grid's own
/// discretisation error is at least the accuracy (all grids but the last) or about it
/// (the last). 0.1 (was 0.02 until issue 20 session 35): on the 12 test and 32 benchmark
/// states at the default accuracy the loads of 128 × 16 are then within 0.085 of the
/// accuracy of the same grid iterated to 1e-10 and its Richardson estimate within 0.023
/// of it (0.018 and 0.005 at 0.02), and a grid needs one V-cycle fewer where its loads'
/// changes straddle the stop: the ladder to 256 × 32 costs 92,816 node updates instead of
/// 125,952 (median state; `cargo run --release --example zeta_probe work`, which also
/// shows that 0.05 saves nothing: the cycles are whole).
pub(crate) const ALGEBRAIC_FRACTION: f64 = 0.1;

/// Optional callback of [`FiniteSolver::fmg_cycles`]: `(node updates so far, field)`.
type FieldObserver<'a> = Option<&'a mut dyn FnMut(u64, &[f64])>;

/// Stop of the first (coarsest) grid of full multigrid on explicit grids: estimated change
/// of the field below this fraction of its largest value (or the grid's tolerance, if
/// looser). Its solution is only the next grid's start, which carries the first grid's
/// discretisation error (~0.1 relative on 16 × 4) anyway (issue 20, session 38: to 1e-8
/// it took 14 of the 128 × 32 oracle solve's ~5.7 sweeps' worth of 16 × 4 sweeps).
const FMG_FIRST_TOLERANCE: f64 = 1e-3;

/// V-cycle limit of one grid (a cycle contracts the error ~10×; far beyond need).
const MAX_CYCLES: u32 = 200;

/// The V-cycle history of one ladder grid ([`FiniteSolver::ladder_cycles`]).
#[derive(Default)]
struct LadderCycles {
    /// V-cycles done on the grid.
    cycles: u32,
    /// Load vector after the last cycle.
    prev: FilmIntegrals,
    /// Relative load change of the last cycle.
    last_change: f64,
    /// Estimated iteration error after the last cycle (the stop's).
    err: f64,
    /// The last cycle's change of the load vector (absolute).
    delta: FilmIntegrals,
    /// The change of the cycle before it (0: none measured).
    last_delta: FilmIntegrals,
}

impl LadderCycles {
    /// The estimated iteration error of the loads after the last cycle that the
    /// estimate reports ([`simpson_reported`]'s `iteration`): the geometric tail of the
    /// contraction of the load vector itself (see
    /// [`super::multigrid::load_tail_estimate`]), not of its change's norm (the stop's).
    fn reported_iteration(&self) -> f64 {
        let norm = self.prev.iter().map(|x| x * x).sum::<f64>().sqrt();
        load_tail_estimate(&self.delta, &self.last_delta, norm)
    }
}

/// Re-interpolates the rows of a ladder grid's start that lie between the coarser grid's
/// rows (odd `j`; the even rows are the coarse solution, interpolated in θ) by cubics in
/// ζ through the four nearest even rows: `(−1, 9, 9, −1)/16`, next to an end face
/// `(5, 15, −5, 1)/16` (`nz ≥ 6`) or the quadratic `(3, 6, −1)/8` (`nz = 4`); clipped at
/// 0; nodes held (`inv_d` 0) keep their value. `nz` even.
fn cubic_rows_in_zeta(p: &mut [f64], inv_d: &[f64], nt: usize, nz: usize) {
    // Row slices (issue 20, session 37: the per-node row choice and index checks were
    // most of this pass); the same weights in the same order, the same bits.
    for j in (1..nz).step_by(2) {
        // The rows below `j` (even ones read), row `j` (written) and the rows above.
        let (lo, rest) = p.split_at_mut(j * nt);
        let (cur, hi) = rest.split_at_mut(nt);
        let below = |m: usize| &lo[(j - m) * nt..(j - m + 1) * nt];
        let above = |m: usize| &hi[(m - 1) * nt..m * nt];
        let inv = &inv_d[j * nt..(j + 1) * nt];
        if nz < 6 {
            // Rows 0, 2, 4 (nz = 4; p = 0 on the end rows).
            let (a, b, c) = if j == 1 {
                (below(1), above(1), above(3))
            } else {
                (above(1), below(1), below(3))
            };
            put_row(cur, inv, |i| (3.0 * a[i] + 6.0 * b[i] - c[i]) / 8.0);
        } else if j == 1 {
            let (a, b, c, d) = (below(1), above(1), above(3), above(5));
            put_row(cur, inv, |i| cubic_edge(a[i], b[i], c[i], d[i]));
        } else if j == nz - 1 {
            let (a, b, c, d) = (above(1), below(1), below(3), below(5));
            put_row(cur, inv, |i| cubic_edge(a[i], b[i], c[i], d[i]));
        } else {
            let (a, b, c, d) = (below(3), below(1), above(1), above(3));
            put_row(cur, inv, |i| cubic_mid(a[i], b[i], c[i], d[i]));
        }
    }
}

/// `out[i] = max(v(i), 0)` where `inv[i]` is not 0 (held nodes keep their value).
#[inline(always)]
fn put_row(out: &mut [f64], inv: &[f64], v: impl Fn(usize) -> f64) {
    for (i, (o, &ik)) in out.iter_mut().zip(inv).enumerate() {
        if ik != 0.0 {
            *o = v(i).max(0.0);
        }
    }
}

/// Grids of the accuracy ladder for aspect `B/r0`, coarsest first: both directions
/// doubled per step, up to 1024 intervals around. The shape `n_theta/n_z = r` is the
/// power of two nearest `π D/B = 2π/aspect`, which makes the grid's couplings
/// `λ/Δθ²` and `1/Δζ²` equal within a factor 2 (clamped to 1/16..64); the first grid
/// has at least 16 intervals around and 2 along.
pub fn accuracy_ladder(aspect: f64) -> Vec<(usize, usize)> {
    let shape = (2.0 * PI / aspect.max(1e-9))
        .log2()
        .round()
        .clamp(-4.0, 6.0) as i32;
    let (mut nt, mut nz) = if shape >= 0 {
        let r = 1usize << shape;
        let nz = (16 / r).max(2);
        (nz * r, nz)
    } else {
        (16, 16usize << (-shape))
    };
    let mut out = Vec::new();
    while nt <= 1024 && nz <= 512 {
        out.push((nt, nz));
        nt *= 2;
        nz *= 2;
    }
    out
}

/// Richardson estimate of the last of a sequence of integrals on grids each twice as
/// fine as the one before: with `d₁ = |v₋₁ − v₋₂|`, `d₂ = |v₀ − v₋₁|` and the observed
/// contraction `ρ = d₂/d₁` clamped to [1/4, 0.8] (1/4: second order; slower observed
/// convergence, before the asymptotic range, gives a larger estimate), the remaining
/// error is the geometric tail `d₂ ρ/(1 − ρ)` (`d₂/3` at second order), relative to
/// `|v₀|`. `None` below three grids.
pub fn ladder_estimate(values: &[FilmIntegrals]) -> Option<f64> {
    let n = values.len();
    if n < 3 {
        return None;
    }
    let dist = |a: &FilmIntegrals, b: &FilmIntegrals| {
        (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
    };
    let d1 = dist(&values[n - 2], &values[n - 3]);
    let d2 = dist(&values[n - 1], &values[n - 2]);
    let norm = values[n - 1].iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Some(0.0);
    }
    let rho = if d1 > 0.0 {
        (d2 / d1).clamp(0.25, 0.8)
    } else {
        0.25
    };
    Some(d2 * rho / (1.0 - rho) / norm)
}

/// The ladder estimate for a film with grooves or arcs (held bands): their edges fall
/// between nodes at a position that changes from grid to grid, so the error (order 1.5
/// to 2; about first order for a supplied full-length groove, whose held pressure meets
/// the ambient end faces) is irregular from one grid to the next, and the observed
/// contraction of [`ladder_estimate`] can be a lucky one (measured: 0.07 × the true error).
/// This estimate is a bound instead: `1.5 max(d₂, d₁/4)` relative to `|v₀|` (with `d₁,
/// d₂` as in [`ladder_estimate`]), measured 1.3-31 × the true error on the layouts of
/// tests/grooves.rs (grids 64-1024 around). `None` below three grids.
pub fn banded_estimate(values: &[FilmIntegrals]) -> Option<f64> {
    let n = values.len();
    if n < 3 {
        return None;
    }
    let dist = |a: &FilmIntegrals, b: &FilmIntegrals| {
        (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
    };
    let d1 = dist(&values[n - 2], &values[n - 3]);
    let d2 = dist(&values[n - 1], &values[n - 2]);
    let norm = values[n - 1].iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Some(0.0);
    }
    // 1.5: margin over the worst measured max(d₂, d₁/4)/true error, 0.87.
    Some(1.5 * d2.max(0.25 * d1) / norm)
}

/// The estimate of the accuracy ladder of the plain 360° film (loads summed by Simpson's
/// rule in ζ, [`ladder_integrals_on`]): `|v₀ − v₋₁| / 3` relative to `|v₀|`, the
/// Richardson estimate at second order. With the ζ quadrature's `Δζ²` error removed, what
/// is left is the field's own second-order discretisation error, mostly from ζ on the
/// ladder's grids (issue 20 pass 4, examples/zeta_probe.rs, B/D = 0.5, 128 × 16: refining
/// θ alone does not reduce it, 0.95-2×, refining ζ alone divides it by 1.2-12). The measured contraction of
/// [`ladder_estimate`] is not used: on these small errors it is often pre-asymptotic and
/// gave up to 40 × the true error, the fixed second order 0.37-1.7 × (tests/
/// finite_accuracy.rs checks 1/3-3 ×). `None` below three grids (the first pair, 16 × 2
/// and 32 × 4 at B/D = 0.5, is not in the asymptotic range).
pub fn simpson_estimate(values: &[FilmIntegrals]) -> Option<f64> {
    let n = values.len();
    if n < 3 {
        return None;
    }
    let d2 = (0..4)
        .map(|k| (values[n - 1][k] - values[n - 2][k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = values[n - 1].iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Some(0.0);
    }
    // 3 = 2² − 1: Richardson at second order.
    Some(d2 / 3.0 / norm)
}

/// The bound the Simpson-summed ladder of the plain film stops on (issue 20, session 39):
/// the larger of the last pair's second-order Richardson estimate and the one of the pair
/// two grids back carried to the last grid, `max(d₀/3, d₋₂/48)` relative to `|v₀|` (`dₖ`
/// the difference of a pair; 48 = 4²(2² − 1): the error falls ×1/4 per grid at second
/// order), the last pair alone on the third grid. On erratic ladders (high ε: the peak
/// and the film's rupture line under-resolved) the last difference alone can be a lucky
/// small one: stopped on [`simpson_estimate`], the default 5e-4 left aligned states at ε
/// 0.83-0.86 1.1-1.45e-3 off on 128 × 16 and a squeezed ε 0.91 2.4e-3 off, estimates
/// 0.13-0.44 × the truth (examples/bench_worst.rs; tests/finite_accuracy.rs
/// `default_within_1e3_on_a_dense_eccentricity_scan`). Measured on 3,800 states
/// (BENCHMARKS.md "Issue 20: the default's promise on dense scans, session 39"): none
/// above 1e-3 at 5e-4, the largest 7.2e-4, for +4-13 % node updates (replayed ladders);
/// adding the pair one grid back (`d₋₁/12`) cost +27-35 % and brought no further state
/// under 1e-3. `None` below three grids.
/// The estimate reported with it is the geometric mean `√(bound × simpson_estimate)`:
/// between the last pair's (too low on erratic ladders) and the bound (up to ~5× high),
/// and at most the bound, so a met accuracy reports an estimate below it.
pub fn simpson_stop_bound(values: &[FilmIntegrals]) -> Option<f64> {
    let n = values.len();
    if n < 3 {
        return None;
    }
    let norm = values[n - 1].iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Some(0.0);
    }
    let d = |i: usize| {
        (0..4)
            .map(|k| (values[i][k] - values[i - 1][k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    // 3 = 2² − 1 and 48 = 4²(2² − 1): the pair's Richardson estimate, carried two grids
    // on for the older pair.
    let mut b = d(n - 1) / 3.0;
    if n >= 4 {
        b = b.max(d(n - 3) / 48.0);
    }
    Some(b / norm)
}

/// The error estimate reported with [`simpson_stop_bound`] for the last of the
/// Simpson-summed ladder's values (issue 20, session 40), relative to `|v₀|`:
///
/// ```text
/// reported = √(max(d₀/3, d₋₁/12, d₋₂/48) × d₀/3) + iteration
/// ```
///
/// (`dₖ` the pairs' differences as in the bound, each carried to the last grid at second
/// order: 12 = 4 (2² − 1)), `iteration` the last grid's estimated iteration error of its
/// loads (relative). Both terms were missing before: at ε ≥ 0.9 the ladder's error
/// alternates from grid to grid (true errors e.g. 7.8e-4, 5.4e-4, 7.5e-5 on 128 × 16 …
/// 512 × 64), so a pair whose two grids happen to have like errors is small while the
/// one before it is not; and the last grid, iterated to `LADDER_FLOOR × accuracy` by an
/// estimate that is up to 10× low there (the multigrid's contraction varies from cycle to
/// cycle), returned loads whose iteration error was most of the true error (1.1-1.9e-4 of
/// 1.9-3.5e-4). Measured on 732 aligned and tilted states at ε 0.8-0.95 (every 0.0025):
/// session 39's `√(bound × d₀/3)` was 0.09-5.5 × the true error, 19 outside 1/3-3,
/// this one 0.41-3.7, 3 outside (over-estimates of errors ≤ 7e-5, where the last grid's
/// error is a lucky small one; examples/bench_worst.rs, BENCHMARKS.md "Issue 20: an
/// honest estimate at high eccentricity, session 40"); with the ladder going on one grid
/// where the last pair is not asymptotic ([`ladder_extends`], session 41) 0.40-3.67, 2
/// outside (over-estimates 3.5-3.7× of errors 5e-5-6e-5). The accuracy ladder passes as
/// `iteration` the tail of its last grid's load vector's own contraction
/// ([`super::multigrid::load_tail_estimate`], s41-honest2; the stop's norms' ratio made
/// the ε 0.7 squeezed test state 3.65× over at accuracy 1e-3, now 2.60×): 0.40-3.62 on
/// the 732, the same 2 outside, whose discretisation part alone is 2.3× / 3.0× their true
/// error. `None` below three grids.
pub fn simpson_reported(values: &[FilmIntegrals], iteration: f64) -> Option<f64> {
    let n = values.len();
    let bound = simpson_stop_bound(values)?;
    let e = simpson_estimate(values)?;
    let norm = values[n - 1].iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Some(0.0);
    }
    let mut b = bound;
    if n >= 4 {
        let d1 = (0..4)
            .map(|k| (values[n - 2][k] - values[n - 3][k]).powi(2))
            .sum::<f64>()
            .sqrt();
        // 12 = 4 (2² − 1): the pair one back carried one grid on at second order.
        b = b.max(d1 / 12.0 / norm);
    }
    Some((b * e).sqrt() + iteration.max(0.0))
}

/// Largest ratio `d₀/d₋₁` of the Simpson-summed ladder's last two pair differences for
/// which the last pair is taken as in its asymptotic range (second order: 1/4); see
/// [`ladder_extends`]. Measured (examples/bench_worst.rs, session 41): 1 extends 4 of the
/// 732 dense states at ε 0.8-0.95 and 2 of the 1,032 at ε 0.1-0.95, none of the 32
/// benchmark states (55,311 node updates per default state, unchanged); 0.5 extended 8
/// of the 732 and put 4 aligned states at ε 0.83 outside 1/3-3 on their extra grid; 0.35
/// cost 67,311 node updates (+21.7 %).
pub const LADDER_PAIR_RATIO: f64 = 1.0;

/// Whether the Simpson-summed ladder, its stop bound met on the last of `values`, goes on
/// one more grid (issue 20 session 41): where the last pair's difference is more than
/// [`LADDER_PAIR_RATIO`] × the one before (`d₀ > r d₋₁`; second order gives 1/4), the last
/// pair is not in its asymptotic range, the grid before the last is an unlucky one
/// between smaller errors, and `d₀/3` over-estimates the last grid's error (aligned
/// journals squeezed at ε 0.925-0.932: 3-8× of true errors 3e-5-7e-5). Not where the
/// grid before the last was itself such an extension (one extra grid at most).
pub fn ladder_extends(values: &[FilmIntegrals]) -> bool {
    let n = values.len();
    if n < 4 {
        return false;
    }
    let d = |i: usize| {
        (0..4)
            .map(|k| (values[i][k] - values[i - 1][k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let out = |m: usize| m >= 4 && d(m - 1) > LADDER_PAIR_RATIO * d(m - 2);
    out(n) && !out(n - 1)
}

/// Load integrals of an accuracy-ladder field (`nt × nz`, node 0 at `theta0`, `nz`
/// even): the rectangle rule in θ (periodic) and Simpson's rule in ζ (weights
/// `Δζ/3 · (1, 4, 2, …, 4, 1)`; the end rows are 0). The rectangle rule in ζ is the
/// trapezoid rule of an integrand that vanishes at both ends with a nonzero slope there,
/// off by `Δζ²/12 (f'(1) − f'(0))`: on the ladder's grids at B/D = 0.5 nearly all of the
/// load error (1.0e-3-2.0e-3 at 256 × 32, against 6.8e-5-6.2e-4 summed by Simpson from
/// the same fields; examples/zeta_probe.rs). Odd `nz` (never on the ladder): the
/// rectangle rule.
pub fn ladder_integrals_on(p: &[f64], nt: usize, nz: usize, theta0: f64) -> FilmIntegrals {
    if !nz.is_multiple_of(2) {
        return integrals_on(p, nt, nz, theta0);
    }
    row_weighted_integrals(p, nt, nz, theta0, simpson_row_weight)
}

/// `−⅓ Σ_j w(j) Σ_i P_ij (cos θ_i, sin θ_i, ζ_j cos θ_i, ζ_j sin θ_i) Δθ Δζ` over the
/// interior rows `j` of an `nt × nz` field (node 0 at `theta0`): the rectangle rule in θ
/// and the row weights `w` in ζ (1: the rectangle rule, exactly, since `1.0 × c == c`).
fn row_weighted_integrals(
    p: &[f64],
    nt: usize,
    nz: usize,
    theta0: f64,
    w: impl Fn(usize) -> f64,
) -> FilmIntegrals {
    row_weighted_with(p, nt, nz, &column_trig(nt, theta0), w)
}

/// `(cos θ_i, sin θ_i)`, `θ_i = theta0 + iΔθ`, of the `nt` columns.
fn column_trig(nt: usize, theta0: f64) -> Vec<(f64, f64)> {
    let dt = 2.0 * PI / nt as f64;
    (0..nt)
        .map(|i| {
            let th = theta0 + i as f64 * dt;
            (th.cos(), th.sin())
        })
        .collect()
}

/// Simpson's row weight over Δζ: 4/3 on odd rows, 2/3 on even ones.
pub(super) fn simpson_row_weight(j: usize) -> f64 {
    if j % 2 == 1 {
        4.0 / 3.0
    } else {
        2.0 / 3.0
    }
}

/// [`row_weighted_integrals`] with the columns' `(cos θ_i, sin θ_i)` given.
pub(super) fn row_weighted_with(
    p: &[f64],
    nt: usize,
    nz: usize,
    trig: &[(f64, f64)],
    w: impl Fn(usize) -> f64,
) -> FilmIntegrals {
    let dt = 2.0 * PI / nt as f64;
    let dz = 1.0 / nz as f64;
    let mut acc = [0.0; 4];
    let trig = &trig[..nt];
    // Each row's sums `(Σ P cos θ, Σ P sin θ)` in column order, as one chain per row and
    // component; four rows at a time (issue 20, session 37): one row's two chains were
    // bound by the latency of their additions (a load sum per V-cycle; the same sums,
    // the same bits).
    let mut rows = [(0.0, 0.0); ROWS_AT_ONCE];
    let mut j = 1;
    while j < nz {
        let m = ROWS_AT_ONCE.min(nz - j);
        if m == ROWS_AT_ONCE {
            let r: [&[f64]; ROWS_AT_ONCE] =
                std::array::from_fn(|q| &p[(j + q) * nt..(j + q + 1) * nt]);
            let mut cs = [0.0; ROWS_AT_ONCE];
            let mut ss = [0.0; ROWS_AT_ONCE];
            for (i, &(ci, si)) in trig.iter().enumerate() {
                for q in 0..ROWS_AT_ONCE {
                    let v = r[q][i];
                    cs[q] += v * ci;
                    ss[q] += v * si;
                }
            }
            for q in 0..ROWS_AT_ONCE {
                rows[q] = (cs[q], ss[q]);
            }
        } else {
            for (q, row) in rows.iter_mut().enumerate().take(m) {
                let (mut c, mut s) = (0.0, 0.0);
                for (&v, &(ci, si)) in p[(j + q) * nt..(j + q + 1) * nt].iter().zip(trig) {
                    c += v * ci;
                    s += v * si;
                }
                *row = (c, s);
            }
        }
        // The rows into the load vector in row order (as before).
        for (q, &(c, s)) in rows.iter().enumerate().take(m) {
            let jj = j + q;
            let zeta = jj as f64 * dz;
            let (c, s) = (w(jj) * c, w(jj) * s);
            acc[0] += c;
            acc[1] += s;
            acc[2] += c * zeta;
            acc[3] += s * zeta;
        }
        j += m;
    }
    acc.map(|v| -v * dt * dz / 3.0)
}

/// Rows summed side by side in [`row_weighted_with`] (independent addition chains).
const ROWS_AT_ONCE: usize = 4;

/// `−⅓ (∬P cos θ, ∬P sin θ, ∬P ζ cos θ, ∬P ζ sin θ) dθ dζ` by the rectangle rule.
pub(crate) fn integrals_of(p: &[f64], g: &FiniteGrid) -> FilmIntegrals {
    integrals_at(p, g, 0.0)
}

/// [`integrals_of`] for a grid whose node 0 is at angle `theta0`.
fn integrals_at(p: &[f64], g: &FiniteGrid, theta0: f64) -> FilmIntegrals {
    integrals_on(p, g.n_theta, g.n_z, theta0)
}

/// [`integrals_at`] on an `nt × nz` grid.
pub(super) fn integrals_on(p: &[f64], nt: usize, nz: usize, theta0: f64) -> FilmIntegrals {
    row_weighted_integrals(p, nt, nz, theta0, |_| 1.0)
}

/// Integrals of one job from a cold start on the calling thread.
pub fn finite_integrals(
    job: &FiniteJob,
    settings: &FiniteSettings,
) -> (FilmIntegrals, SolveReport) {
    let mut field = Vec::new();
    FiniteSolver::new().solve(job, &settings.into(), &mut field)
}

/// Loads of one state by the finite model (cold start, calling thread).
pub fn finite_loads(
    params: &BearingParams,
    state: &BearingState,
    settings: &FiniteSettings,
) -> Result<Loads, StateFault> {
    finite_solution(params, state, settings, false).map(|s| s.loads)
}

/// Loads with, optionally, the Richardson error estimate from the half grid.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FiniteSolution {
    /// Loads on the requested grid.
    pub loads: Loads,
    /// The solve on the requested grid.
    pub report: SolveReport,
    /// Richardson estimate of the discretisation error of the load vector
    /// `(W_x, W_y, M_x/B, M_y/B)`, relative to its norm: `|v_h − v_2h| / 3 / |v_h|`
    /// (second order); `None` when not asked or the grid cannot be halved.
    pub error_estimate: Option<f64>,
    /// The Richardson-extrapolated load vector `(4 v_h − v_2h)/3` (N), when estimated.
    pub extrapolated: Option<[f64; 4]>,
}

/// One state by the finite model, with the Richardson estimate when `estimate` is true.
pub fn finite_solution(
    params: &BearingParams,
    state: &BearingState,
    settings: &FiniteSettings,
    estimate: bool,
) -> Result<FiniteSolution, StateFault> {
    let packed = pack_state(params, state)?;
    let job = FiniteJob::of_state(params, &packed, state.omega);
    let grid = FiniteGrid {
        // The flows below are computed from the field: iterate it to the tolerance.
        polish: true,
        ..FiniteGrid::for_bearing(&BearingParams {
            finite: *settings,
            ..*params
        })
    };
    let mut solver = FiniteSolver::new();
    let mut field = Vec::new();
    let (ints, report) = if packed.rate_scale > 0.0 {
        solver.solve(&job, &grid, &mut field)
    } else {
        ([0.0; 4], SolveReport::default())
    };
    let mut loads = finish_loads(params, state, &ints, packed.rate_scale).finite_or_fault()?;
    // Film friction and flow from the field (issue 24; output only, see super::flow).
    super::flow::apply_finite_flow(
        &mut loads,
        params,
        state,
        packed.rate_scale,
        &job,
        // The solve's own grid: with grooves or arcs their held bands (issue 27 found
        // `settings.into()` here, which drops them).
        &grid,
        &report,
        &field,
    );
    let (mut error_estimate, mut extrapolated) = (None, None);
    if estimate && packed.rate_scale > 0.0 {
        if let Some(coarse) = settings.coarse() {
            let cg = FiniteGrid {
                layout: grid.layout,
                max_film_inlet: grid.max_film_inlet,
                ..FiniteGrid::from(&coarse)
            };
            let (ci, _) = solver.solve(&job, &cg, &mut Vec::new());
            let cl = finish_loads(params, state, &ci, packed.rate_scale);
            let (v, w) = (
                loads.load_vector(params.length),
                cl.load_vector(params.length),
            );
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let diff = v
                .iter()
                .zip(&w)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            error_estimate = Some(if norm > 0.0 { diff / 3.0 / norm } else { 0.0 });
            let mut x = [0.0; 4];
            for k in 0..4 {
                x[k] = (4.0 * v[k] - w[k]) / 3.0;
            }
            extrapolated = Some(x);
        }
    }
    Ok(FiniteSolution {
        loads,
        report,
        error_estimate,
        extrapolated,
    })
}

/// Richardson estimate for loads already computed on `settings`' grid (by any backend).
/// Accuracy mode: the estimate of the state's ladder (solved again on the CPU). Fixed
/// grid: solves the half grid on the CPU (an eighth of the work) and returns
/// `|v_h − v_2h| / 3 / |v_h|` for the load vector `(W_x, W_y, M_x/B, M_y/B)`; `None` when
/// the grid cannot be halved or the state carries no pressure.
pub fn richardson_estimate(
    params: &BearingParams,
    state: &BearingState,
    settings: &FiniteSettings,
    fine: &Loads,
) -> Option<f64> {
    if settings.fixed_grid().is_none() {
        // Accuracy mode: the solve is deterministic (full multigrid from cold), so the
        // estimate its ladder reached is that of `fine` (same state, same settings).
        let sol = finite_solution(params, state, settings, false).ok()?;
        return (sol.report.n_theta > 0).then_some(sol.report.error_estimate);
    }
    let coarse = settings.coarse()?;
    let c = finite_solution(params, state, &coarse, false).ok()?.loads;
    let (v, w) = (
        fine.load_vector(params.length),
        c.load_vector(params.length),
    );
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff = v
        .iter()
        .zip(&w)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    (norm > 0.0).then(|| diff / 3.0 / norm)
}
