//! The finite-length film path of the backends: the CPU implementation (threads over
//! states) that every backend inherits, and the model choice of `"auto"`.

use rayon::prelude::*;

use crate::bearing::finite::{short_model_error, FiniteGrid, FiniteJob, FiniteSolver, SolveReport};
use crate::bearing::{BearingParams, BearingState, FilmIntegrals, FilmModel};

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

/// The model a state of bearing `params` is evaluated with: `short` and `finite` as
/// given; `auto` picks `finite` where the model-error map's load or attitude error
/// (attitude in radians, i.e. the tangential share of the load) at the bearing's `B/D`
/// and the state's larger end eccentricity exceeds `finite.auto_tolerance`.
pub fn effective_model(params: &BearingParams, state: &BearingState) -> FilmModel {
    match params.model {
        FilmModel::Auto => {
            let (ei, ej) = state.eccentricity_ratios(params.clearance);
            let err = short_model_error(params.length / (2.0 * params.radius), ei.max(ej));
            if err.load.abs().max(err.attitude_deg.to_radians().abs())
                > params.finite.auto_tolerance
            {
                FilmModel::Finite
            } else {
                FilmModel::Short
            }
        }
        m => m,
    }
}
