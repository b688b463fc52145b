//! Linearised bearing coefficients: the 4×4 stiffness `K = −∂W/∂q` and damping
//! `C = −∂W/∂q̇` in `q = (x, y, tilt_x, tilt_y)` at the bearing mid-plane, from central
//! differences of the film loads at three step sizes with Richardson extrapolation, every
//! perturbed state of every bearing evaluated in one [`LoadEvaluator::evaluate`] call.
//!
//! Coordinates (bearing frame of MODEL.md section 1): `x, y` the journal centre at the
//! mid-plane `z = B/2`, m; `tilt_x, tilt_y` right-handed rotations of the journal axis
//! about the `x` and `y` axes, rad, so that the centre at axial distance `ζ = z − B/2`
//! from the mid-plane is `(x + ζ tilt_y, y − ζ tilt_x)`. Loads: the film force on the
//! journal `(W_x, W_y)`, N, and its moment about the mid-plane centre `(M_x, M_y)`, N·m.

// Index loops mirror the matrix subscripts.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use super::StabilityError;
use crate::backend::{effective_model, LoadEvaluator, LoadRequest};
use crate::bearing::finite::{FiniteGrid, FiniteJob, FiniteSolver, SolveReport};
use crate::bearing::{pack_state, BearingParams, BearingState, FilmModel, Loads};

/// Names of the coordinates, in matrix order.
pub const ORDER: [&str; 4] = ["x", "y", "tilt_x", "tilt_y"];

/// How the derivatives are taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffOptions {
    /// Largest position step over the radial clearance times the state's smoothness
    /// scale `min(1 − ε_max, max(e_axis/δ, 1e-4))` (`e_axis` the journal axis' distance
    /// from the bore axis inside the bearing). Default 1e-3.
    pub relative_step: f64,
    /// Three step sizes `h, h/2, h/4` with two Richardson levels and an error estimate
    /// (true, default), or `h` alone (Newton iterations; no error estimate).
    pub richardson: bool,
    /// Coordinates differenced: 8 (positions `x, y, tilt_x, tilt_y` and their rates,
    /// default) or 2 (`x, y` only: the x-y stiffness block, the rest zero; a bearing's
    /// static equilibrium needs no more, issue 20's cost).
    pub coordinates: usize,
}

impl Default for DiffOptions {
    fn default() -> Self {
        DiffOptions {
            relative_step: 1e-3,
            richardson: true,
            coordinates: 8,
        }
    }
}

impl DiffOptions {
    /// One central difference per coordinate: the Jacobian of a Newton iteration.
    pub fn newton() -> Self {
        DiffOptions {
            relative_step: 1e-4,
            richardson: false,
            coordinates: 8,
        }
    }

    /// [`DiffOptions::newton`] for an aligned journal's position alone (`x, y`): the
    /// Jacobian of a bearing's static equilibrium, 5 film evaluations per iteration
    /// instead of 17.
    pub fn newton_positions() -> Self {
        DiffOptions {
            coordinates: 2,
            ..DiffOptions::newton()
        }
    }
}

/// One bearing and the state to linearise about.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoefficientJob {
    /// The bearing.
    pub params: BearingParams,
    /// The journal state (positions, velocities, relative spin).
    pub state: BearingState,
}

/// Steps used for the differences (the largest of the levels). On a held ladder grid
/// (finite film, accuracy mode) the rate steps are [`HELD_RATE_FACTOR`] times those
/// equivalent to the position step (the damping's differences must average over the
/// discrete cavitation boundary's kinks).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Steps {
    /// Mid-plane displacement step, m.
    pub position_m: f64,
    /// Tilt step, rad (moves the end faces by `position_m`).
    pub tilt_rad: f64,
    /// Mid-plane velocity step, m/s.
    pub velocity_m_s: f64,
    /// Tilt-rate step, rad/s.
    pub tilt_rate_rad_s: f64,
}

/// The linearised film of one bearing at one state. SI units.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BearingCoefficients {
    /// `K[i][j] = −∂L_i/∂q_j`, `L = (W_x, W_y, M_x, M_y)`; N/m, N/rad, N·m/m, N·m/rad.
    pub stiffness: [[f64; 4]; 4],
    /// `C[i][j] = −∂L_i/∂q̇_j`; N·s/m, N·s/rad, N·m·s/m, N·m·s/rad.
    pub damping: [[f64; 4]; 4],
    /// Error estimate of each stiffness coefficient (same units; zero without
    /// Richardson): the difference-step error plus, for the finite film, the grid's
    /// discretisation error from the same differences on the half (and, in accuracy
    /// mode, quarter) grid (see `add_grid_error`).
    pub stiffness_error: [[f64; 4]; 4],
    /// Error estimate of each damping coefficient (as `stiffness_error`).
    pub damping_error: [[f64; 4]; 4],
    /// Finite film: the grid `[n_theta, n_z]` every differenced state was solved on
    /// (chosen at the state itself in accuracy mode); `None` for the short film.
    pub grid: Option<[u32; 2]>,
    /// Loads at the state itself.
    pub loads: Loads,
    /// `(W_x, W_y, M_x, M_y)` about the mid-plane, N and N·m.
    pub mid_plane_loads: [f64; 4],
    /// Steps of the differences.
    pub steps: Steps,
}

/// `state` moved by `dq` (mid-plane displacement and tilt) and `dv` (their rates).
pub fn perturb(state: &BearingState, length_m: f64, dq: [f64; 4], dv: [f64; 4]) -> BearingState {
    let h = 0.5 * length_m;
    BearingState {
        xi: state.xi + dq[0] - h * dq[3],
        yi: state.yi + dq[1] + h * dq[2],
        xj: state.xj + dq[0] + h * dq[3],
        yj: state.yj + dq[1] - h * dq[2],
        vxi: state.vxi + dv[0] - h * dv[3],
        vyi: state.vyi + dv[1] + h * dv[2],
        vxj: state.vxj + dv[0] + h * dv[3],
        vyj: state.vyj + dv[1] - h * dv[2],
        omega: state.omega,
    }
}

/// The aligned state whose mid-plane centre is `(x, y)` at rest, spinning at `omega`.
pub fn aligned_state(x: f64, y: f64, omega: f64) -> BearingState {
    BearingState {
        xi: x,
        yi: y,
        xj: x,
        yj: y,
        omega,
        ..BearingState::default()
    }
}

/// `(W_x, W_y, M_x, M_y)` with the moments taken about the mid-plane centre instead of
/// the frame origin (`M_mid = M − (0, 0, B/2) × W`).
pub fn mid_plane_loads(l: &Loads, length_m: f64) -> [f64; 4] {
    let h = 0.5 * length_m;
    [l.wx, l.wy, l.mx + h * l.wy, l.my - h * l.wx]
}

/// Distance of the journal axis (the segment between the end centres) from the bore
/// axis, m.
fn axis_distance(s: &BearingState) -> f64 {
    let (dx, dy) = (s.xj - s.xi, s.yj - s.yi);
    let d2 = dx * dx + dy * dy;
    let t = if d2 > 0.0 {
        (-(s.xi * dx + s.yi * dy) / d2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (s.xi + t * dx).hypot(s.yi + t * dy)
}

/// Smallest smoothness scale: below `1e-4 δ` from the bore axis the steps stop shrinking
/// (the centred film is linear in the state to first order; its second-order part is
/// `|t| t`-like, so the central difference there is first order in the step and the
/// estimate reports it).
const MIN_SCALE: f64 = 1e-4;

fn steps_of(job: &CoefficientJob, relative_step: f64) -> Steps {
    let d = job.params.clearance;
    let s = &job.state;
    let (ei, ej) = s.eccentricity_ratios(d);
    let gap = 1.0 - ei.max(ej);
    let scale = gap.min((axis_distance(s) / d).max(MIN_SCALE));
    let h = relative_step * d * scale;
    let half = 0.5 * job.params.length;
    // A velocity v changes the rate vector by 2v, a displacement e by ω e: equal effects.
    let rate = s.omega.abs().max(1.0);
    Steps {
        position_m: h,
        tilt_rad: h / half,
        velocity_m_s: 0.5 * h * rate,
        tilt_rate_rad_s: 0.5 * h * rate / half,
    }
}

/// Step-size levels of one coefficient set: of the positions and tilts (`pos`) and of
/// their rates (`rate`), the latter on held ladder grids over rate steps
/// [`HELD_RATE_FACTOR`] times larger (`held`). On held grids each position and tilt also
/// gets one secant pair at [`HELD_RATE_FACTOR`] times its step (after its levels): the
/// grid error is estimated from the secants (see `add_grid_error`).
#[derive(Clone, Copy, Debug)]
struct Levels {
    pos: &'static [f64],
    rate: &'static [f64],
    held: bool,
}

impl Levels {
    /// The levels of coordinate `c` (0-3 positions and tilts, 4-7 their rates).
    fn of(&self, c: usize) -> &'static [f64] {
        if c < 4 {
            self.pos
        } else {
            self.rate
        }
    }

    /// Film evaluations of coordinate `c`: its levels' pairs, plus the secant pair of a
    /// position or tilt on a held grid.
    fn of_coordinate(&self, c: usize) -> usize {
        2 * self.of(c).len() + if self.held && c < 4 { 2 } else { 0 }
    }

    /// Film evaluations of one coefficient set over `nc` coordinates.
    fn evaluations(&self, nc: usize) -> usize {
        1 + (0..nc).map(|c| self.of_coordinate(c)).sum::<usize>()
    }
}

/// Secants of the loads over the largest steps of a held grid, per coordinate (same
/// signs and units as the coefficients): positions and tilts over ±[`HELD_RATE_FACTOR`]
/// times their step, rates over ±`s` (their largest level). Their grid convergence is
/// regular where the small-step derivative's is not (see `add_grid_error`).
#[derive(Clone, Copy, Debug, Default)]
struct Secants {
    stiffness: [[f64; 4]; 4],
    damping: [[f64; 4]; 4],
}

/// Step-size levels: `h, h/2, h/4` (Richardson) or `h`.
fn levels(richardson: bool) -> &'static [f64] {
    if richardson {
        &[1.0, 0.5, 0.25]
    } else {
        &[1.0]
    }
}

/// Step-size levels on a held ladder grid (finite film, accuracy mode) with Richardson:
/// `h, h/2`, one Richardson level, for the positions and tilts. Its step error, O(h⁴) ~
/// 1e-12 relative at the default step, is far below the grid's discretisation error
/// (≥ 1e-4), and the estimate `|D(h/2) − D(h)|/3` (the error of `D(h/2)`, O(h²) ~ 1e-7)
/// bounds it; a third level would cost 16 more film solves per grid and amplify the
/// solver's noise at `h/4` (issue 20's cost).
const HELD_LEVELS: &[f64] = &[1.0, 0.5];

/// Step-size levels of the rates (velocities, tilt rates) on a held ladder grid: `s, s/2,
/// s/4` with two Richardson levels, `s` [`HELD_RATE_FACTOR`] times the rate step of the
/// positions.
const HELD_RATE_LEVELS: &[f64] = &[1.0, 0.5, 0.25];

/// Largest rate step on a held ladder grid over the rate step equivalent to the position
/// step (`Steps::velocity_m_s` of [`steps_of`]): 400, i.e. a squeeze velocity `v` with `2v`
/// up to 0.4 of the smoothness scale times `ω δ` (at most 0.4 of `ω e`). Why (issue 20,
/// `examples/coef_cause.rs`): the discrete film's cavitated set is a set of nodes, so the
/// loads are piecewise linear in a squeeze velocity, with a kink wherever a boundary node
/// switches. At the position-like step (~1e-3) the difference sees the slope of the
/// piece at hand, which changes erratically with the grid (C's successive-grid ratios
/// 0.02-3.5 up to 1024 × 128, changes of 0.1-1 %; the iteration tolerance is not the
/// cause: 1e-8 and 1e-11 agree to 1e-5). The linearised film on the converged active
/// set (Lund's method) is that same slope, so it would not help. A step that moves the
/// boundary across several cells averages the kinks: from a relative step of 0.2 on,
/// C converges at about second order (ratios 0.16-0.41, mostly 0.2-0.3, at ε 0.3-0.7),
/// and its truncation error (the continuum film is smooth in the velocity: D(s) = C +
/// a s² + b s⁴ + ...) is removed by the two Richardson levels, to ~1e-5 relative. Smaller (0.1) steps are
/// erratic again at ε ≥ 0.7, larger ones leave more truncation for the same levels.
const HELD_RATE_FACTOR: f64 = 400.0;

/// The finite-film grid `[n_theta, n_z]` a job's loads are differenced on: the explicit
/// grid, or in accuracy mode the grid the solver chooses at the job's own state (held for
/// every perturbed state: a grid change between differenced states would be a jump of
/// the order of the accuracy over a step of ~1e-3 δ). `None` for the short film.
pub fn difference_grid(params: &BearingParams, state: &BearingState) -> Option<[u32; 2]> {
    grid_and_estimate(params, state, false).map(|g| g.0)
}

/// [`difference_grid`] with the relative discretisation error estimate of the loads
/// there (accuracy mode; 0 on an explicit grid, and on a held grid unless `estimate`).
fn grid_and_estimate(
    params: &BearingParams,
    state: &BearingState,
    estimate: bool,
) -> Option<([u32; 2], f64)> {
    if effective_model(params, state) != FilmModel::Finite {
        return None;
    }
    if let Some((t, z)) = params.finite.fixed_grid() {
        return Some(([t, z], 0.0));
    }
    if let (Some(held), false) = (params.finite.held_grid, estimate) {
        // Held already (a Newton iteration): no solve needed to choose it.
        return Some((held, 0.0));
    }
    // The solve alone (no film friction and flow: only the grid and estimate are used).
    let packed = pack_state(params, state).ok()?;
    let r = if packed.rate_scale > 0.0 {
        let job = FiniteJob::of_state(params, &packed, state.omega);
        let mut solver = FiniteSolver::new();
        // The held grids' ladder: rectangle sums, the estimate `add_grid_error` is
        // calibrated on (see `FiniteSolver::rectangle_ladder`, issue 20 pass 4).
        solver.rectangle_ladder = true;
        solver
            .solve(&job, &FiniteGrid::for_bearing(params), &mut Vec::new())
            .1
    } else {
        SolveReport::default()
    };
    // A state without film pressure (no spin, no squeeze) has no grid choice: the
    // explicit default.
    Some(if r.n_theta > 0 {
        ([r.n_theta, r.n_z], r.error_estimate)
    } else {
        ([64, 16], 0.0)
    })
}

/// Noise floor of a bearing's film loads, relative: the finite film's iteration
/// tolerance (its iterate's error shows in the loads at that level; warm starts make it
/// vary between evaluations), 0 for the short film (rounding only). Newton iterations
/// stop at a multiple of it instead of chasing noise.
pub fn load_noise(params: &BearingParams) -> f64 {
    if params.model == FilmModel::Short {
        0.0
    } else {
        params.finite.tolerance
    }
}

/// `params` with the finite film held on `grid` (unchanged for `None` or an explicit
/// grid): in accuracy mode the ladder's grid with node 0 on each state's own maximum
/// film ([`crate::bearing::finite::FiniteSettings::held_grid`]), so that the loads are
/// smooth in the state. Issue 20 found the explicit grid pinned here before: its inlet
/// column snaps to the nearest grid angle, which jumps between nearby states (K_yy off
/// by 51 %, Newton stalled at a residual of the accuracy's order). JFO cavitation too
/// (its ladder holds the grid the same way since issue 27's last pass; pinned as an
/// explicit grid before, the snapping put its K 1.8-7 % off Swift–Stieber's on the
/// max-film feed, up to 6× the reported errors).
pub fn pin_grid(params: &BearingParams, grid: Option<[u32; 2]>) -> BearingParams {
    let mut p = *params;
    if let Some(g) = grid {
        p.finite = p.finite.held(g);
    }
    p
}

/// Linearised coefficients of every job, all perturbed states in one evaluator call.
/// Bearing `k` of the call is `jobs[k]`; a job whose state (or a perturbed one) has no
/// film loads gets that bearing's error, the others are unaffected.
pub fn coefficients_batch(
    evaluator: &mut LoadEvaluator,
    jobs: &[CoefficientJob],
    options: &DiffOptions,
) -> Vec<Result<BearingCoefficients, StabilityError>> {
    let nc = options.coordinates.clamp(1, 8);
    // Finite film: one grid per job (see `difference_grid`), and with Richardson the
    // same differences on the half grid for the discretisation error (bearing index
    // `jobs.len() + k`).
    let chosen: Vec<Option<([u32; 2], f64)>> = jobs
        .par_iter()
        .map(|j| grid_and_estimate(&j.params, &j.state, options.richardson))
        .collect();
    let grids: Vec<Option<[u32; 2]>> = chosen.iter().map(|c| c.map(|g| g.0)).collect();
    let mut params: Vec<BearingParams> = jobs
        .iter()
        .zip(&grids)
        .map(|(j, g)| pin_grid(&j.params, *g))
        .collect();
    // Step levels and film evaluations per grid of each job.
    let lvs: Vec<Levels> = params
        .iter()
        .map(|p| {
            if options.richardson && p.finite.held_grid.is_some() {
                Levels {
                    pos: HELD_LEVELS,
                    rate: HELD_RATE_LEVELS,
                    held: true,
                }
            } else {
                let lv = levels(options.richardson);
                Levels {
                    pos: lv,
                    rate: lv,
                    held: false,
                }
            }
        })
        .collect();
    let per: Vec<usize> = lvs.iter().map(|lv| lv.evaluations(nc)).collect();
    let coarse: Vec<Option<BearingParams>> = params
        .iter()
        .zip(&grids)
        .map(|(p, g)| {
            if !options.richardson || g.is_none() {
                return None;
            }
            p.finite
                .half_grid()
                .map(|c| BearingParams { finite: c, ..*p })
        })
        .collect();
    // The quarter grid (the half grid's half) of held ladder grids: the observed
    // contraction of the coefficients' grid convergence (bearing index
    // `2 jobs.len() + k`; 1/16 of the fine grid's work).
    let quarter: Vec<Option<BearingParams>> = coarse
        .iter()
        .map(|c| {
            let c = c.as_ref()?;
            c.finite.held_grid?;
            c.finite
                .half_grid()
                .map(|q| BearingParams { finite: q, ..*c })
        })
        .collect();
    if let Some(&first) = params.first() {
        // Jobs without a half or quarter grid get a placeholder (no request uses it).
        params.extend(coarse.iter().map(|c| c.unwrap_or(first)));
        params.extend(quarter.iter().map(|c| c.unwrap_or(first)));
    }
    let mut requests = Vec::with_capacity(per.iter().sum::<usize>() * 3);
    let mut steps = Vec::with_capacity(jobs.len());
    // Start of each job's fine and coarse chunks in the requests.
    let mut starts: Vec<(usize, Option<usize>, Option<usize>)> = Vec::with_capacity(jobs.len());
    for (k, job) in jobs.iter().enumerate() {
        let lv = lvs[k];
        let mut st = steps_of(job, options.relative_step);
        if lv.held {
            // The rates' larger steps (see `HELD_RATE_FACTOR`).
            st.velocity_m_s *= HELD_RATE_FACTOR;
            st.tilt_rate_rad_s *= HELD_RATE_FACTOR;
        }
        steps.push(st);
        let fine_start = requests.len();
        push_differences(&mut requests, k as u32, job, &st, lv, nc);
        // With the quarter grid (held grids) the half and quarter grids give only the
        // secants of the grid error (`push_secants`: 2 film solves per coordinate instead
        // of 6-8 and the state); without it the half grid's coefficients themselves.
        let secants_only = quarter[k].is_some();
        let coarse_start = coarse[k].map(|_| {
            let at = requests.len();
            let b = (jobs.len() + k) as u32;
            if secants_only {
                push_secants(&mut requests, b, job, &st, nc);
            } else {
                push_differences(&mut requests, b, job, &st, lv, nc);
            }
            at
        });
        let quarter_start = quarter[k].map(|_| {
            let at = requests.len();
            push_secants(&mut requests, (2 * jobs.len() + k) as u32, job, &st, nc);
            at
        });
        starts.push((fine_start, coarse_start, quarter_start));
    }
    let mut results = Vec::new();
    evaluator.evaluate(&params, &requests, &mut results);
    jobs.iter()
        .enumerate()
        .map(|(k, job)| {
            let (fs, cs, qs) = starts[k];
            let (lv, per_job) = (lvs[k], per[k]);
            let (mut out, fine_sec) = differentiate(
                k,
                job,
                &results[fs..fs + per_job],
                &steps[k],
                lv,
                options.richardson,
                nc,
            )?;
            out.grid = grids[k];
            if let Some(cs) = cs {
                let est = chosen[k].map_or(0.0, |g| g.1);
                match qs {
                    // Held grids with their quarter grid: the secants' grid convergence.
                    Some(qs) => {
                        let half_sec = secants_of(k, job, &results[cs..cs + 2 * nc], &steps[k])?;
                        let quarter_sec = secants_of(k, job, &results[qs..qs + 2 * nc], &steps[k])?;
                        add_grid_error(
                            &mut out.stiffness_error,
                            &out.stiffness,
                            &fine_sec.stiffness,
                            &half_sec.stiffness,
                            Some(&quarter_sec.stiffness),
                            est,
                        );
                        add_grid_error(
                            &mut out.damping_error,
                            &out.damping,
                            &fine_sec.damping,
                            &half_sec.damping,
                            Some(&quarter_sec.damping),
                            est,
                        );
                    }
                    None => {
                        let (c, _) = differentiate(
                            k,
                            job,
                            &results[cs..cs + per_job],
                            &steps[k],
                            lv,
                            options.richardson,
                            nc,
                        )?;
                        add_grid_error(
                            &mut out.stiffness_error,
                            &out.stiffness,
                            &out.stiffness,
                            &c.stiffness,
                            None,
                            est,
                        );
                        add_grid_error(
                            &mut out.damping_error,
                            &out.damping,
                            &out.damping,
                            &c.damping,
                            None,
                            est,
                        );
                    }
                }
            }
            Ok(out)
        })
        .collect()
}

/// Adds the discretisation error of the coefficients `value` (grid h) to `error`. `fine`,
/// `half` and `quarter` are what is compared across grids: on held ladder grids (with
/// the quarter grid) the secants over the largest steps (see [`Secants`]) on the grids
/// h, 2h and 4h; without the quarter grid `value` itself on h and 2h. Per 2 × 2
/// sub-block of like units (x-y and tilt rows and columns), with Frobenius norms
/// `n₂ = |S_h − S_2h|`, `n₁ = |S_2h − S_4h|`:
///
/// - with the quarter grid, the geometric tail of [`crate::bearing::finite::ladder_estimate`]:
///   `ρ = clamp(n₂/n₁, 1/4, 0.8)`, each entry
///   `|K|/|S| · ρ/(1 − ρ) · max(|ΔS_ij|, m · max(|S_ij|/|S|, 1/4))` with
///   `m = max(n₂, n₁/4)` (an entry whose grid error crosses zero gets at least the
///   block's relative error, and a small entry at least `m/4`, half the block's rms
///   share; a lucky small `n₂` after a large `n₁` is not believed), `|K|/|S|` carrying
///   the secants' relative grid error over to the coefficients.
///
///   Why the secants (issue 20, session 34): the discrete cavitated set is a set of
///   nodes, so the loads have a kink wherever a boundary node switches, and a
///   derivative at the small position step (~1e-3 of the smoothness scale) is the slope
///   of one piece: its grid error has an irregular part that jumps from grid to grid.
///   At ε ≤ 0.7 it is small and the coefficients themselves converge at second order,
///   but at ε 0.8-0.9 it dominates on 128 × 16 and 256 × 32: K's successive-grid ratios
///   were 0.06-0.67 (ε 0.85: 0.14, 0.60, 0.10 up to 1024 × 128) and the tail taken from
///   the coefficients reported 4-17× the true error (K 14.6×, C 4.6× at ε 0.85). The
///   secant over ±0.4 of the smoothness scale moves the boundary across several cells
///   and averages the kinks: at ε 0.85 its ratios are 0.29, 0.22, 0.26
///   (`examples/coef_cause.rs` at the relative step 0.4). Measured (examples/
///   coef_convergence.rs, paper bearing, the 1024 × 128 / 512 × 64 extrapolated
///   reference, x-y blocks at 512 × 64): reported/true K 1.1-2.5, C 1.1-2.4 at ε 0.3,
///   0.517, 0.7, 0.85, 0.9 (docs/finite-film.md "Coefficients"). The coefficients'
///   values are those of before (small steps; Richardson over the rate steps).
/// - without (explicit grids, or a half grid below the ladder's first), the bound of
///   before: `max(|ΔK_ij|, 3 est |K_ij|)` with `est` the loads' relative estimate
///   (measured: `|ΔK|` was up to 3× short on coarse grids, the loads' error ≤ 2×).
fn add_grid_error(
    error: &mut [[f64; 4]; 4],
    value: &[[f64; 4]; 4],
    fine: &[[f64; 4]; 4],
    half: &[[f64; 4]; 4],
    quarter: Option<&[[f64; 4]; 4]>,
    est: f64,
) {
    for bi in [0, 2] {
        for bj in [0, 2] {
            let cells = [(bi, bj), (bi, bj + 1), (bi + 1, bj), (bi + 1, bj + 1)];
            let norm = |f: &dyn Fn(usize, usize) -> f64| {
                cells
                    .iter()
                    .map(|&(i, j)| f(i, j).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let n2 = norm(&|i, j| fine[i][j] - half[i][j]);
            let size = norm(&|i, j| fine[i][j]);
            // The secants' grid error relative to their own size, on the coefficients'
            // (1 without secants: `fine` is `value`).
            let scale = if size > 0.0 {
                norm(&|i, j| value[i][j]) / size
            } else {
                1.0
            };
            for &(i, j) in &cells {
                let d2 = (fine[i][j] - half[i][j]).abs();
                error[i][j] += match quarter {
                    Some(q) => {
                        let n1 = norm(&|i, j| half[i][j] - q[i][j]);
                        let rho = if n1 > 0.0 {
                            (n2 / n1).clamp(0.25, 0.8)
                        } else {
                            0.25
                        };
                        // At least the block's relative error, and a small entry at least
                        // `m/4` (half its rms share: its own grid error may cross zero).
                        // `m/2` before the secants, whose small entries converge as
                        // regularly as the block; with it the block was 1.2-1.3× the
                        // no-floor estimate and 3.1-3.6× the true error at ε 0.8-0.85.
                        let share = if size > 0.0 {
                            n2.max(0.25 * n1) * (fine[i][j].abs() / size).max(0.25)
                        } else {
                            0.0
                        };
                        scale * rho / (1.0 - rho) * d2.max(share)
                    }
                    None => d2.max(3.0 * est * fine[i][j].abs()),
                };
            }
        }
    }
}

/// The state of `job` and its perturbations for the differences, on bearing `b`.
fn push_differences(
    requests: &mut Vec<LoadRequest>,
    b: u32,
    job: &CoefficientJob,
    st: &Steps,
    lv: Levels,
    nc: usize,
) {
    requests.push(LoadRequest {
        bearing: b,
        state: job.state,
    });
    let len = job.params.length;
    for c in 0..nc {
        let unit = match c {
            0 | 1 => st.position_m,
            2 | 3 => st.tilt_rad,
            4 | 5 => st.velocity_m_s,
            _ => st.tilt_rate_rad_s,
        };
        // The levels, then on a held grid a position's secant pair.
        let secant: &[f64] = if lv.held && c < 4 {
            &[HELD_RATE_FACTOR]
        } else {
            &[]
        };
        for &f in lv.of(c).iter().chain(secant) {
            for sign in [1.0, -1.0] {
                let mut dq = [0.0; 4];
                let mut dv = [0.0; 4];
                if c < 4 {
                    dq[c] = sign * f * unit;
                } else {
                    dv[c - 4] = sign * f * unit;
                }
                requests.push(LoadRequest {
                    bearing: b,
                    state: perturb(&job.state, len, dq, dv),
                });
            }
        }
    }
}

/// The secant pairs of `job` on bearing `b` alone (see [`Secants`]): per coordinate the
/// state moved by ± [`HELD_RATE_FACTOR`] times a position's or tilt's step, ± the rate
/// step `s` (`st` holds it already scaled); the same states as those of
/// [`push_differences`] on a held grid, so the secants are the same numbers.
fn push_secants(
    requests: &mut Vec<LoadRequest>,
    b: u32,
    job: &CoefficientJob,
    st: &Steps,
    nc: usize,
) {
    let len = job.params.length;
    for c in 0..nc {
        let (unit, f) = match c {
            0 | 1 => (st.position_m, HELD_RATE_FACTOR),
            2 | 3 => (st.tilt_rad, HELD_RATE_FACTOR),
            4 | 5 => (st.velocity_m_s, 1.0),
            _ => (st.tilt_rate_rad_s, 1.0),
        };
        for sign in [1.0, -1.0] {
            let mut dq = [0.0; 4];
            let mut dv = [0.0; 4];
            if c < 4 {
                dq[c] = sign * f * unit;
            } else {
                dv[c - 4] = sign * f * unit;
            }
            requests.push(LoadRequest {
                bearing: b,
                state: perturb(&job.state, len, dq, dv),
            });
        }
    }
}

/// The secants of job `k` from the loads of [`push_secants`] (`chunk`), computed as in
/// [`differentiate`].
fn secants_of(
    k: usize,
    job: &CoefficientJob,
    chunk: &[crate::backend::LoadResult],
    st: &Steps,
) -> Result<Secants, StabilityError> {
    let len = job.params.length;
    let mut out = Secants::default();
    for (c, pair) in chunk.chunks_exact(2).enumerate() {
        let mut mids = [[0.0; 4]; 2];
        for (m, r) in mids.iter_mut().zip(pair) {
            match r {
                Ok(l) => *m = mid_plane_loads(l, len),
                Err(fault) => {
                    return Err(StabilityError::Film {
                        bearing: k,
                        context: "at a perturbed state of the finite differences".into(),
                        fault: *fault,
                    })
                }
            }
        }
        for i in 0..4 {
            let (p, m) = (mids[0][i], mids[1][i]);
            if c < 4 {
                let unit = if c < 2 { st.position_m } else { st.tilt_rad };
                out.stiffness[i][c] = -(p - m) / (2.0 * HELD_RATE_FACTOR * unit);
            } else {
                let unit = if c < 6 {
                    st.velocity_m_s
                } else {
                    st.tilt_rate_rad_s
                };
                out.damping[i][c - 4] = -((p - m) / (2.0 * 1.0 * unit));
            }
        }
    }
    Ok(out)
}

/// Coefficients of job `k` from the loads of its state and perturbations (`chunk`, in
/// the order of [`push_differences`]).
fn differentiate(
    k: usize,
    job: &CoefficientJob,
    chunk: &[crate::backend::LoadResult],
    st: &Steps,
    lv: Levels,
    richardson: bool,
    nc: usize,
) -> Result<(BearingCoefficients, Secants), StabilityError> {
    let len = job.params.length;
    let mut mids = Vec::with_capacity(chunk.len());
    for (n, r) in chunk.iter().enumerate() {
        match r {
            Ok(l) => mids.push(mid_plane_loads(l, len)),
            Err(fault) => {
                return Err(StabilityError::Film {
                    bearing: k,
                    context: if n == 0 {
                        "at the state to linearise about".into()
                    } else {
                        "at a perturbed state of the finite differences".into()
                    },
                    fault: *fault,
                })
            }
        }
    }
    let base = match &chunk[0] {
        Ok(l) => *l,
        Err(_) => unreachable!("checked above"),
    };
    let st = *st;
    let mut out = BearingCoefficients {
        stiffness: [[0.0; 4]; 4],
        damping: [[0.0; 4]; 4],
        stiffness_error: [[0.0; 4]; 4],
        damping_error: [[0.0; 4]; 4],
        loads: base,
        mid_plane_loads: mids[0],
        steps: st,
        grid: None,
    };
    let mut secants = Secants::default();
    // Start of coordinate `c`'s differences in `mids`.
    let mut first = 1;
    for c in 0..nc {
        let unit = match c {
            0 | 1 => st.position_m,
            2 | 3 => st.tilt_rad,
            4 | 5 => st.velocity_m_s,
            _ => st.tilt_rate_rad_s,
        };
        let lvc = lv.of(c);
        for i in 0..4 {
            let mut d = [0.0; 3];
            let mut magnitude: f64 = 0.0;
            for (l, &f) in lvc.iter().enumerate() {
                let at = first + l * 2;
                let (p, m) = (mids[at][i], mids[at + 1][i]);
                magnitude = magnitude.max(p.abs()).max(m.abs());
                d[l] = (p - m) / (2.0 * f * unit);
            }
            let (value, error) = if richardson && lvc.len() == 2 {
                // One Richardson level (held ladder grids, `HELD_LEVELS`): the error of
                // D(h/2) bounds that of the extrapolate, plus rounding at h/2.
                let value = (4.0 * d[1] - d[0]) / 3.0;
                let rounding = 64.0 * f64::EPSILON * magnitude / (2.0 * 0.5 * unit);
                (value, (d[1] - d[0]).abs() / 3.0 + rounding)
            } else if richardson && lv.held {
                // The rates on a held grid (`HELD_RATE_LEVELS`, large steps): two
                // Richardson levels, whose last change `r2 − r1` (15 times the error of
                // r2) would overstate the extrapolate's error, O(s⁶), by a factor of
                // ~1/q with q = |r2 − r1| / |d1 − d0| the series' observed contraction
                // per level (measured, ε 0.517, 1024 × 128: q 0.03, |r2 − r1| q / 15 =
                // 4e-6 of C, the next level's change 3e-6); so the estimate is the last
                // change contracted once more, plus rounding at s/4.
                let r1 = (4.0 * d[1] - d[0]) / 3.0;
                let r2 = (4.0 * d[2] - d[1]) / 3.0;
                let value = r2 + (r2 - r1) / 15.0;
                let first_change = (d[1] - d[0]).abs();
                let q = if first_change > 0.0 {
                    ((r2 - r1).abs() / first_change).min(1.0)
                } else {
                    1.0
                };
                let rounding = 64.0 * f64::EPSILON * magnitude / (2.0 * 0.25 * unit);
                (value, (r2 - r1).abs() * q / 15.0 + rounding)
            } else if richardson {
                // D(h) = D + a h² + b h⁴ + ...: two Richardson levels. The error
                // estimate is the change of the last level (conservative: the
                // returned value is one level better), plus rounding of the
                // differences at the smallest step.
                let r1 = (4.0 * d[1] - d[0]) / 3.0;
                let r2 = (4.0 * d[2] - d[1]) / 3.0;
                let value = r2 + (r2 - r1) / 15.0;
                let rounding = 64.0 * f64::EPSILON * magnitude / (2.0 * 0.25 * unit);
                (value, (r2 - r1).abs() + rounding)
            } else {
                (d[0], 0.0)
            };
            if c < 4 {
                out.stiffness[i][c] = -value;
                out.stiffness_error[i][c] = error;
            } else {
                out.damping[i][c - 4] = -value;
                out.damping_error[i][c - 4] = error;
            }
            if lv.held {
                // The secant over the largest step: a position's own pair after its
                // levels, a rate's largest level.
                if c < 4 {
                    let at = first + 2 * lvc.len();
                    let (p, m) = (mids[at][i], mids[at + 1][i]);
                    secants.stiffness[i][c] = -(p - m) / (2.0 * HELD_RATE_FACTOR * unit);
                } else {
                    secants.damping[i][c - 4] = -d[0];
                }
            }
        }
        first += lv.of_coordinate(c);
    }
    Ok((out, secants))
}
