//! The finite-length film path of the backends: the CPU implementation (threads over
//! states) that every backend inherits, and the model choice of `"auto"`.

use rayon::prelude::*;

use crate::bearing::finite::{
    apply_finite_flow, apply_jfo_flow, Cavitation, FiniteGrid, FiniteJob, FiniteSolver, JfoHistory,
    JfoSolver, SolveReport,
};
use crate::bearing::{BearingParams, BearingState, FilmIntegrals, Loads};

/// Solves `jobs` on the calling thread's rayon pool, one task per state (a state is
/// 0.1-10 ms of work, so no chunking is needed). `fields[k]` is job k's warm start
/// (any other length: cold start) and receives its solution.
pub(crate) fn cpu_integrate_finite(
    jobs: &[FiniteJob],
    grid: &FiniteGrid,
    fields: &mut [Vec<f64>],
    out: &mut Vec<FilmIntegrals>,
    reports: &mut Vec<SolveReport>,
    parallel: bool,
) {
    out.clear();
    out.resize(jobs.len(), [0.0; 4]);
    reports.clear();
    reports.resize(jobs.len(), SolveReport::default());
    let run = |solver: &mut FiniteSolver,
               ((o, r), (job, field)): (
        (&mut FilmIntegrals, &mut SolveReport),
        (&FiniteJob, &mut Vec<f64>),
    )| {
        let (ints, rep) = solver.solve(job, grid, field);
        *o = ints;
        *r = rep;
    };
    if parallel && jobs.len() > 1 {
        out.par_iter_mut()
            .zip(reports.par_iter_mut())
            .zip(jobs.par_iter().zip(fields.par_iter_mut()))
            .for_each_init(FiniteSolver::new, run);
    } else {
        let mut solver = FiniteSolver::new();
        out.iter_mut()
            .zip(reports.iter_mut())
            .zip(jobs.iter().zip(fields.iter_mut()))
            .for_each(|x| run(&mut solver, x));
    }
}

/// Solves JFO `jobs` on the fixed `grid` with one film history per job (`None`: steady;
/// `histories` empty: all steady) on rayon's global pool, one task per state: the CPU
/// implementation of [`super::FilmBackend::integrate_finite_jfo`].
pub(crate) fn cpu_integrate_jfo(
    jobs: &[FiniteJob],
    grid: &FiniteGrid,
    fields: &mut [Vec<f64>],
    histories: &[Option<JfoHistory>],
    out: &mut Vec<FilmIntegrals>,
    reports: &mut Vec<SolveReport>,
) {
    out.clear();
    out.resize(jobs.len(), [0.0; 4]);
    reports.clear();
    reports.resize(jobs.len(), SolveReport::default());
    out.par_iter_mut()
        .zip(reports.par_iter_mut())
        .zip(jobs.par_iter().zip(fields.par_iter_mut()).enumerate())
        .for_each_init(
            || (FiniteSolver::new(), JfoSolver::new()),
            |(reynolds, jfo), ((o, r), (k, (job, field)))| {
                let h = histories.get(k).and_then(|h| h.as_ref());
                let (ints, rep) = jfo.solve(reynolds, job, grid, field, h);
                *o = ints;
                *r = rep;
            },
        );
}

/// The model a state is evaluated with (moved to [`crate::bearing::finite`] so that the
/// bearing layer can resolve `auto` too).
pub use crate::bearing::finite::effective_model;

/// The film fraction of JFO bearings carried through a time-stepped run (issue 27;
/// docs/jfo.md "Film history in rotor runs"): per bearing index, the film fraction
/// committed at the last accepted step and its time. A JFO state evaluated at a time after
/// it takes one backward-Euler step of the liquid content from it (`JfoHistory`), so the
/// cavitated zone's history enters the loads; what the integrator sees is a discrete state
/// per bearing, constant during a step and updated when the step is accepted (the last
/// evaluation of the bearing, i.e. the state at the step's end for FSAL and collocation
/// methods). Without times (eval, coefficients, equilibria) JFO states are steady.
#[derive(Default)]
pub(crate) struct FilmHistory {
    /// Time of each request of the current call (empty: no time, steady films).
    times: Vec<f64>,
    /// Whether this call's solves are candidates for the next commit (the stages of a
    /// step; not output samples).
    candidates_on: bool,
    /// Per bearing index: time and film fraction committed at the last accepted step.
    committed: std::collections::HashMap<u32, Committed>,
    /// Per bearing index: time and film fraction of its latest stage evaluation.
    candidates: std::collections::HashMap<u32, Committed>,
    /// Per state of the group last solved: the history it was solved with (φ°, Δτ, the
    /// previous eccentricities).
    used: Vec<Option<Used>>,
}

/// The history a state was solved with: film fraction, `Δτ`, the previous eccentricities.
type Used = (Vec<f64>, f64, [f64; 4]);

/// A bearing's film at one time: time, film fraction, packed eccentricities (its gap, so
/// that the next step conserves the liquid content exactly, `JfoHistory::prev_ecc`).
type Committed = (f64, Vec<f64>, [f64; 4]);

impl FilmHistory {
    /// Times of the next call's requests (one per request), and whether its solves are
    /// stage evaluations (commit candidates).
    pub(crate) fn set_times(&mut self, times: &[f64], candidates: bool) {
        self.times.clear();
        self.times.extend_from_slice(times);
        self.candidates_on = candidates;
    }

    /// Forgets the current call's times (after the call).
    pub(crate) fn end_call(&mut self) {
        self.times.clear();
    }

    /// Commits the latest stage film fraction of `bearing` (an accepted step).
    pub(crate) fn commit(&mut self, bearing: u32) {
        // Without JFO bearings nothing is ever a candidate: no key hashed (the rotor
        // commits every bearing of every accepted step, ~1 M of grid9's instructions
        // hashing into an empty map; issue 28's thirteenth pass).
        if self.candidates.is_empty() {
            return;
        }
        if let Some(c) = self.candidates.remove(&bearing) {
            self.committed.insert(bearing, c);
        }
    }

    /// Forgets every history (a new run).
    pub(crate) fn clear(&mut self) {
        self.committed.clear();
        self.candidates.clear();
    }

    /// Solves a group of JFO states of one fixed grid with their histories by `backend`
    /// ([`super::FilmBackend::integrate_finite_jfo`]; on its failure by the CPU, the
    /// failure returned for the caller's notice), when the call has times; `None` (nothing
    /// done) otherwise. `states[k] = (bearing index, request index, rate scale)`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve_group(
        &mut self,
        states: &[(u32, usize, f64)],
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
        backend: &mut dyn super::FilmBackend,
    ) -> Option<Result<(), super::BackendError>> {
        self.used.clear();
        if grid.cavitation != Cavitation::Jfo || self.times.is_empty() || grid.accuracy.is_some() {
            return None;
        }
        let n = grid.n_theta * (grid.n_z + 1);
        let times = &self.times;
        let committed = &self.committed;
        self.used.extend(states.iter().map(|&(b, req, scale)| {
            let t = *times.get(req)?;
            let (th, phi, ecc) = committed.get(&b)?;
            (phi.len() == n && t > *th).then(|| (phi.clone(), scale * (t - th), *ecc))
        }));
        let histories: Vec<Option<JfoHistory>> = self
            .used
            .iter()
            .map(|used| {
                used.as_ref().map(|(phi, dtau, ecc)| JfoHistory {
                    phi,
                    dtau: *dtau,
                    prev_ecc: Some(*ecc),
                })
            })
            .collect();
        let mut status = backend.integrate_finite_jfo(jobs, grid, fields, &histories, out, reports);
        if status.is_err() {
            for f in fields.iter_mut() {
                f.clear();
            }
            cpu_integrate_jfo(jobs, grid, fields, &histories, out, reports);
        } else {
            status = Ok(());
        }
        if self.candidates_on {
            for (k, &(b, req, _)) in states.iter().enumerate() {
                if let (Some(&t), true) = (times.get(req), fields[k].len() == 2 * n) {
                    let ecc = jobs[k].state.ecc;
                    self.candidates.insert(b, (t, fields[k][n..].to_vec(), ecc));
                }
            }
        }
        Some(status)
    }

    /// Film friction and flow of state `k` of the group last solved by
    /// [`FilmHistory::solve_group`] (its time storage included); the steady
    /// post-processing when it was solved without history.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn apply_flow(
        &self,
        k: usize,
        loads: &mut Loads,
        params: &BearingParams,
        state: &BearingState,
        rate_scale: f64,
        job: &FiniteJob,
        grid: &FiniteGrid,
        report: &SolveReport,
        field: &[f64],
    ) {
        match self.used.get(k) {
            Some(Some((phi, dtau, ecc))) => {
                let h = JfoHistory {
                    phi,
                    dtau: *dtau,
                    prev_ecc: Some(*ecc),
                };
                apply_jfo_flow(
                    loads,
                    params,
                    state,
                    rate_scale,
                    job,
                    grid,
                    report,
                    field,
                    Some(&h),
                );
            }
            _ => apply_finite_flow(loads, params, state, rate_scale, job, grid, report, field),
        }
    }
}
