//! The finite-length film path of the backends: the CPU implementation (threads over
//! states) that every backend inherits, and the model choice of `"auto"`.

use rayon::prelude::*;

use crate::bearing::finite::{FiniteGrid, FiniteJob, FiniteSolver, SolveReport};
use crate::bearing::FilmIntegrals;

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

/// The model a state is evaluated with (moved to [`crate::bearing::finite`] so that the
/// bearing layer can resolve `auto` too).
pub use crate::bearing::finite::effective_model;
