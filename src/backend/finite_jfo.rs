//! Host side of `shaders/finite_jfo.wgsl`: the finite film's mass-conserving (JFO)
//! cavitation on the GPU backend's device (issue 27), explicit grids, one workgroup per
//! state, f64.
//!
//! The host sets each state's discrete problem up with the CPU solver's own code
//! ([`JfoProblem`]: coefficients, the steady or time-step storage with a film history, the
//! held supply nodes), so the kernel solves the same equations; it starts cold states from
//! the Swift–Stieber solution of the same grid computed on the device by the finite-film
//! kernels (PSOR or multigrid, as the CPU starts from its multigrid solution), iterates on
//! the device, and sums the loads of the returned field here, as the CPU does. Accuracy
//! mode: the host climbs each state's ladder of grids as the CPU does
//! ([`JfoLadder`]: grids, starts, Richardson estimates), the kernel iterates every grid.

use std::time::Duration;

use rayon::prelude::*;
use wgpu::util::DeviceExt;

use super::finite_gpu::{compile_pipeline, dispatch_read};
use super::BackendError;
use crate::bearing::finite::{
    Cavitation, FiniteGrid, FiniteJob, JfoHistory, JfoLadder, JfoProblem, KernelStop, SolveReport,
    JFO_NODE_STRIDE,
};
use crate::bearing::FilmIntegrals;

/// The JFO kernel's WGSL source.
pub const FINITE_JFO_WGSL: &str = include_str!("../../shaders/finite_jfo.wgsl");

/// One state's finished iteration: its field, the sweeps it took, its reported iteration
/// error and whether that met the tolerance.
type Solved = (Vec<f64>, u32, f64, bool);

/// f64 per job and per result (`JOB_STRIDE`, `OUT_STRIDE` in the shader).
const JOB_STRIDE: usize = 4;
const OUT_STRIDE: usize = 12;
/// Loop iterations one invocation may run per dispatch: llvmpipe (lavapipe) ends a
/// shader's loops after 65 535 iterations in all (shaders/finite_jfo.wgsl `per_dispatch`);
/// with a margin for the loops other than the row march.
const LOOP_BUDGET: usize = 40_000;
/// Dispatches per submission (between read-backs of the done flags).
const REPEAT: u32 = 16;
/// Lanes of the kernel's workgroup (`WG`).
const WG: usize = 64;
/// States per dispatch at most (bounds one dispatch's run time under the device timeout on
/// a software device).
const MAX_STATES: usize = 4096;
/// Bytes of one dispatch's coefficient buffer at most: WebGPU's default storage-binding
/// limit (128 MiB).
const COEF_BUDGET: usize = 128 << 20;

/// The uniform block (`Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    n_theta: u32,
    n_z: u32,
    max_sweeps: u32,
    per_dispatch: u32,
    _pad: [u32; 3],
}

/// The compiled JFO pipeline on one device.
pub(crate) struct JfoPipeline {
    pipeline: wgpu::ComputePipeline,
}

/// The Swift–Stieber solve of the cold states' start: `(jobs, grid, fields, reports)` as
/// [`super::FilmBackend::integrate_finite`].
pub(crate) type StartSolver<'a> = dyn FnMut(
        &[FiniteJob],
        &FiniteGrid,
        &mut [Vec<f64>],
        &mut Vec<SolveReport>,
    ) -> Result<(), BackendError>
    + 'a;

impl JfoPipeline {
    /// Compiles the kernel; a validation error is returned, not raised.
    pub(crate) fn new(device: &wgpu::Device) -> Result<Self, BackendError> {
        let pipeline = compile_pipeline(
            device,
            "finite_jfo.wgsl",
            FINITE_JFO_WGSL,
            "finite film JFO kernel",
            "the finite-film JFO kernel",
        )?;
        Ok(JfoPipeline { pipeline })
    }

    /// Solves the JFO `jobs` on the fixed `grid`. `fields[k]` of the grid's length
    /// (pressure then film fraction, valid) is job k's warm start, else it starts from the
    /// Swift–Stieber solution by `start`; it receives the solution. `histories`: empty
    /// (steady) or one per job (a time step from its film fraction, as
    /// [`crate::bearing::finite::JfoSolver::solve`]). A job without a finite spin gets NaN
    /// loads (as the CPU solver returns).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<JfoHistory>],
        start: &mut StartSolver,
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        if grid.accuracy.is_some() {
            return self.run_ladder(device, queue, timeout, jobs, grid, fields, out, reports);
        }
        let (nt, nz) = (grid.n_theta, grid.n_z);
        let n = nt * (nz + 1);
        out.clear();
        out.resize(jobs.len(), [f64::NAN; 4]);
        reports.clear();
        reports.resize(jobs.len(), SolveReport::default());
        // Warm starts as the CPU accepts them; the others from Swift–Stieber on the device.
        let warm: Vec<bool> = fields
            .iter()
            .map(|f| {
                f.len() == 2 * n
                    && f[..n].iter().all(|v| v.is_finite() && *v >= 0.0)
                    && f[n..].iter().all(|v| (0.0..=1.0).contains(v))
            })
            .collect();
        let cold: Vec<usize> = (0..jobs.len()).filter(|&k| !warm[k]).collect();
        let mut start_sweeps = vec![0u32; jobs.len()];
        let mut starts: Vec<Vec<f64>> = vec![Vec::new(); jobs.len()];
        if !cold.is_empty() {
            let rg = FiniteGrid {
                cavitation: Cavitation::Reynolds,
                ..*grid
            };
            let cold_jobs: Vec<FiniteJob> = cold.iter().map(|&k| jobs[k]).collect();
            let mut cold_fields = vec![Vec::new(); cold.len()];
            let mut cold_reports = Vec::new();
            start(&cold_jobs, &rg, &mut cold_fields, &mut cold_reports)?;
            for (c, &k) in cold.iter().enumerate() {
                starts[k] = std::mem::take(&mut cold_fields[c]);
                start_sweeps[k] = cold_reports.get(c).map_or(0, |r| r.sweeps);
            }
        }
        let mut problems: Vec<Option<JfoProblem>> = jobs
            .par_iter()
            .enumerate()
            .map(|(k, job)| {
                let (p, phi) = if warm[k] {
                    (fields[k][..n].to_vec(), fields[k][n..].to_vec())
                } else {
                    let mut p = starts[k].clone();
                    if p.len() != n || !p.iter().all(|v| v.is_finite()) {
                        p = vec![0.0; n];
                    }
                    (p, vec![1.0; n])
                };
                let history = histories.get(k).and_then(|h| h.as_ref());
                JfoProblem::new(job, grid, p, phi, history)
            })
            .collect();
        let todo: Vec<usize> = (0..jobs.len()).filter(|&k| problems[k].is_some()).collect();
        let solved = {
            let mut set: Vec<&mut JfoProblem> = problems.iter_mut().flatten().collect();
            self.iterate(
                device,
                queue,
                timeout,
                &mut set,
                (nt, nz),
                grid.max_sweeps(),
                grid.tolerance,
            )?
        };
        for (&k, (field, sweeps, err, converged)) in todo.iter().zip(solved) {
            let pr = problems[k].as_mut().expect("filtered above");
            out[k] = pr.integrals_of(&field);
            fields[k] = field;
            reports[k] = SolveReport {
                sweeps: start_sweeps[k].saturating_add(sweeps),
                iteration_error: err,
                converged,
                n_theta: nt as u32,
                n_z: nz as u32,
                ..SolveReport::default()
            };
        }
        Ok(())
    }

    /// Accuracy mode: each state's ladder of grids ([`JfoLadder`]: the CPU ladder's grids,
    /// starts, held-grid rule and Richardson estimates) driven here, every grid iterated
    /// by the kernel; the states on the same next grid are one batch. `fields` receive the
    /// last grid's solution (warm starts are not used, as on the CPU).
    #[allow(clippy::too_many_arguments)]
    fn run_ladder(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        out.clear();
        out.resize(jobs.len(), [f64::NAN; 4]);
        reports.clear();
        reports.resize(jobs.len(), SolveReport::default());
        let mut ladders: Vec<Option<JfoLadder>> =
            jobs.iter().map(|job| JfoLadder::new(job, grid)).collect();
        // The next grid of the first unfinished ladder; every ladder on it goes along.
        while let Some(next) = ladders
            .iter()
            .flatten()
            .find(|l| !l.done())
            .map(|l| l.next_grid())
        {
            let batch: Vec<usize> = (0..jobs.len())
                .filter(|&k| {
                    ladders[k]
                        .as_ref()
                        .is_some_and(|l| !l.done() && l.next_grid() == next)
                })
                .collect();
            let mut problems: Vec<JfoProblem> = batch
                .par_iter()
                .map(|&k| {
                    ladders[k]
                        .as_ref()
                        .expect("filtered above")
                        .problem(&jobs[k], grid)
                })
                .collect();
            let level = FiniteGrid {
                n_theta: next.0,
                n_z: next.1,
                ..*grid
            };
            let mut set: Vec<&mut JfoProblem> = problems.iter_mut().collect();
            let solved = self.iterate(
                device,
                queue,
                timeout,
                &mut set,
                next,
                level.max_sweeps(),
                grid.tolerance,
            )?;
            for ((&k, pr), (field, sweeps, err, converged)) in
                batch.iter().zip(problems.iter_mut()).zip(solved)
            {
                let l = ladders[k].as_mut().expect("filtered above");
                l.accept(grid, pr, &field, sweeps, (err, converged));
            }
        }
        for (k, l) in ladders.iter().enumerate() {
            if let Some(l) = l {
                (out[k], reports[k]) = l.finish(&mut fields[k]);
            }
        }
        Ok(())
    }

    /// Iterates `problems` (all on the `(n_theta, n_z)` grid) on the device to
    /// `tolerance`, at most `max_sweeps` sweeps; returns per problem the solved field
    /// (pressure, then film fraction), the sweeps, the iteration error and whether it
    /// converged. The kernel pauses each state at the end of every block of sweeps and the
    /// CPU's stop rule decides here ([`JfoProblem::at_pause`]: the block extrapolation
    /// with its rounding floor, issue 27 session 35), so the reported error is the CPU's
    /// estimate of the kernel's iterate.
    #[allow(clippy::too_many_arguments)]
    fn iterate(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        problems: &mut [&mut JfoProblem],
        (nt, nz): (usize, usize),
        max_sweeps: u32,
        tolerance: f64,
    ) -> Result<Vec<Solved>, BackendError> {
        let n = nt * (nz + 1);
        let mut solved = Vec::with_capacity(problems.len());
        // Sweeps per dispatch: one invocation marches `rows` rows of `nt` nodes per sweep.
        let rows = 2 * (nz.saturating_sub(1)).div_ceil(2 * WG);
        let per_dispatch = (LOOP_BUDGET / (rows * nt + 64)).max(1);
        let per_state = n * JFO_NODE_STRIDE * 8;
        let chunk = (COEF_BUDGET / per_state.max(1)).clamp(1, MAX_STATES);
        for part in problems.chunks_mut(chunk) {
            let count = part.len();
            let mut rules: Vec<KernelStop> =
                part.iter().map(|pr| pr.stop_rule(tolerance)).collect();
            // Per state: the finished iteration's (error, converged).
            let mut verdicts: Vec<Option<(f64, bool)>> = vec![None; count];
            let mut coef = Vec::with_capacity(count * n * JFO_NODE_STRIDE);
            let mut job_data = Vec::with_capacity(count * JOB_STRIDE);
            let mut field_data = Vec::with_capacity(count * 2 * n);
            for (pr, rule) in part.iter().zip(&rules) {
                pr.node_coefficients(&mut coef);
                pr.start(&mut field_data);
                let sign = if pr.spin() >= 0.0 { 1.0 } else { -1.0 };
                job_data.extend_from_slice(&[pr.omega, sign, rule.stop.block as f64, 0.0]);
            }
            let params = Params {
                count: count as u32,
                n_theta: nt as u32,
                n_z: nz as u32,
                max_sweeps,
                per_dispatch: per_dispatch as u32,
                _pad: [0; 3],
            };
            // The iteration's state: sweeps, last change, still, state, history (−1:
            // none), last halved change (none yet: 1e300), its sweep.
            let mut state: Vec<f64> = (0..count)
                .flat_map(|_| {
                    let mut r = [0.0; OUT_STRIDE];
                    r[4..10].fill(-1.0);
                    r[10] = 1e300;
                    r
                })
                .collect();
            let vals = loop {
                let make = |device: &wgpu::Device| {
                    let init = |label, data: &[u8], usage| {
                        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some(label),
                            contents: data,
                            usage,
                        })
                    };
                    let st = wgpu::BufferUsages::STORAGE;
                    vec![
                        init(
                            "finite jfo params",
                            bytemuck::bytes_of(&params),
                            wgpu::BufferUsages::UNIFORM,
                        ),
                        init("finite jfo coefficients", bytemuck::cast_slice(&coef), st),
                        init("finite jfo jobs", bytemuck::cast_slice(&job_data), st),
                        init(
                            "finite jfo fields",
                            bytemuck::cast_slice(&field_data),
                            st | wgpu::BufferUsages::COPY_SRC,
                        ),
                        init(
                            "finite jfo results",
                            bytemuck::cast_slice(&state),
                            st | wgpu::BufferUsages::COPY_SRC,
                        ),
                    ]
                };
                let vals = dispatch_read(
                    device,
                    queue,
                    timeout,
                    &self.pipeline,
                    make,
                    count as u32,
                    REPEAT,
                    &[3, 4],
                    "finite-film JFO",
                )?;
                // Resume from where the device stopped; the host decides on the paused
                // states (the CPU's stop rule on their fields).
                field_data.copy_from_slice(&vals[..count * 2 * n]);
                state.copy_from_slice(&vals[count * 2 * n..]);
                let decided: Vec<(usize, Option<(f64, bool)>)> = part
                    .par_iter_mut()
                    .zip(rules.par_iter_mut())
                    .zip(field_data.par_chunks(2 * n))
                    .zip(state.par_chunks(OUT_STRIDE))
                    .enumerate()
                    .filter(|(c, _)| verdicts[*c].is_none())
                    .map(|(c, (((pr, rule), field), r))| {
                        let v = if r[3] > 1.5 {
                            pr.at_pause(
                                rule,
                                field,
                                r[0] as u32,
                                &r[4..10],
                                r[11] as u32,
                                r[2] > 0.5,
                            )
                        } else if r[3] > 0.5 {
                            Some(pr.at_limit(rule))
                        } else {
                            None
                        };
                        (c, v)
                    })
                    .collect();
                for (c, v) in decided {
                    let r = &mut state[c * OUT_STRIDE..(c + 1) * OUT_STRIDE];
                    match v {
                        Some(v) => {
                            verdicts[c] = Some(v);
                            r[3] = 1.0;
                        }
                        // Paused and not done: run on (a state at the limit is decided).
                        None => {
                            r[2] = 0.0;
                            r[3] = 0.0;
                        }
                    }
                }
                if verdicts.iter().all(|v| v.is_some()) {
                    break vals;
                }
            };
            for c in 0..count {
                let (err, converged) = verdicts[c].expect("all decided");
                solved.push((
                    vals[c * 2 * n..(c + 1) * 2 * n].to_vec(),
                    state[c * OUT_STRIDE] as u32,
                    err,
                    converged,
                ));
            }
        }
        Ok(solved)
    }
}
