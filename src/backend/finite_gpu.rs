//! Host side of `shaders/finite.wgsl`: the finite-length film on the GPU backend's device,
//! one workgroup per state, f64 only (the kernel is an iterative solver whose tolerance
//! reaches 1e-8 and below; f32 would stop at ~1e-6). Explicit grids within the workgroup
//! memory run this PSOR kernel; larger grids and accuracy mode run the projected
//! multigrid kernel of [`super::finite_mg`].

use std::f64::consts::PI;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use wgpu::util::DeviceExt;

use super::BackendError;
use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::FilmIntegrals;

use super::gpu_kernel::{FINITE_MAX_NODES, FINITE_WGSL};

/// Workgroups per dispatch row (WebGPU's guaranteed per-dimension limit).
const ROW: u32 = 65_535;
/// States per dispatch: bounds the field buffer (4096 × 1664 × 8 B ≈ 55 MB at most).
const CHUNK: usize = 4096;
/// f64 per job and per result (`JOB_STRIDE`, `OUT_STRIDE` in the shader).
const JOB_STRIDE: usize = 12;
const OUT_STRIDE: usize = 8;
/// Column value meaning "no inlet on this row" (`NO_INLET`).
const NO_INLET: u32 = u32::MAX;

/// The uniform block (`Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    n_theta: u32,
    n_z: u32,
    max_sweeps: u32,
    tolerance: f64,
}

/// The compiled finite-film pipeline on one device.
pub(crate) struct FinitePipeline {
    pipeline: wgpu::ComputePipeline,
    /// The multigrid kernel (larger grids, accuracy mode), built on first use.
    multigrid: Mutex<Option<Arc<super::finite_mg::MultigridPipeline>>>,
    /// The JFO kernel (`cavitation: jfo`, explicit grids), built on first use.
    jfo: Mutex<Option<Arc<super::finite_jfo::JfoPipeline>>>,
}

impl FinitePipeline {
    /// Compiles the kernel; a validation error is returned, not raised.
    pub(crate) fn new(device: &wgpu::Device) -> Result<Self, BackendError> {
        let pipeline = compile_pipeline(
            device,
            "finite.wgsl",
            FINITE_WGSL,
            "finite film kernel",
            "the finite-film kernel",
        )?;
        Ok(FinitePipeline {
            pipeline,
            multigrid: Mutex::new(None),
            jfo: Mutex::new(None),
        })
    }

    /// Solves the JFO `jobs` on the explicit `grid` with the JFO kernel
    /// ([`super::finite_jfo`]), cold states from this pipeline's Swift–Stieber solution;
    /// `histories` empty (steady) or one per job (a time step).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run_jfo(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<crate::bearing::finite::JfoHistory>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        let jfo = {
            let mut slot = self
                .jfo
                .lock()
                .map_err(|_| BackendError::Device("finite-film pipeline lock".into()))?;
            if slot.is_none() {
                *slot = Some(Arc::new(super::finite_jfo::JfoPipeline::new(device)?));
            }
            slot.clone().expect("built above")
        };
        let mut start =
            |j: &[FiniteJob], g: &FiniteGrid, f: &mut [Vec<f64>], r: &mut Vec<SolveReport>| {
                let mut ints = Vec::new();
                self.run(device, queue, timeout, j, g, f, true, &mut ints, r)
            };
        jfo.run(
            device, queue, timeout, jobs, grid, fields, histories, &mut start, out, reports,
        )
    }

    /// Solves `jobs` on `grid`; `fields[k]` of the grid's length is job k's warm start,
    /// and receives its solution if `fields_wanted` (otherwise it is left empty and the
    /// fields are not read back from the device: the same loads and reports).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        fields_wanted: bool,
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        if grid.cavitation == crate::bearing::finite::Cavitation::Jfo {
            return self.run_jfo(
                device,
                queue,
                timeout,
                jobs,
                grid,
                fields,
                &[],
                out,
                reports,
            );
        }
        if grid.accuracy.is_some() && (grid.polish || grid.n_theta > 0) {
            // The multigrid kernel runs the ladder with its per-grid stop on the loads; a
            // held ladder grid (coefficients, equilibria: `FiniteSettings::held_grid`) and
            // the last grid polished to the tolerance (film outputs requested:
            // `FiniteGrid::polish`) are not in it.
            return Err(BackendError::Device(
                "the WGSL multigrid kernel runs the accuracy ladder only; held ladder grids \
                 (coefficients, equilibria) and accuracy mode with film friction or flow \
                 requested run on the CPU"
                    .into(),
            ));
        }
        let interior = grid.n_theta * (grid.n_z.max(1) - 1);
        if grid.accuracy.is_some() || interior > FINITE_MAX_NODES {
            // Accuracy mode and grids beyond the workgroup memory: projected multigrid.
            let mg = {
                let mut slot = self
                    .multigrid
                    .lock()
                    .map_err(|_| BackendError::Device("finite-film pipeline lock".into()))?;
                if slot.is_none() {
                    *slot = Some(Arc::new(super::finite_mg::MultigridPipeline::new(device)?));
                }
                slot.clone().expect("built above")
            };
            return mg.run(
                device,
                queue,
                timeout,
                jobs,
                grid,
                fields,
                fields_wanted,
                out,
                reports,
            );
        }
        out.clear();
        reports.clear();
        let trig: Vec<f64> = (0..2 * grid.n_theta)
            .flat_map(|k| {
                let th = 0.5 * (2.0 * PI / grid.n_theta as f64) * k as f64;
                [th.cos(), th.sin()]
            })
            .collect();
        let trig_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("finite trig"),
            contents: bytemuck::cast_slice(&trig),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let full = grid.field_len();
        let dt = 2.0 * PI / grid.n_theta as f64;
        // Grooves and arcs: face factors and held pressures per node (binding 6).
        let held = grid.layout.held_nodes(grid.n_theta, grid.n_z, 0.0);
        let geo: Vec<f64> = (0..full)
            .flat_map(|k| [held.east[k], held.north[k], held.held_pa[k]])
            .collect();
        let geo_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("finite grooves"),
            contents: bytemuck::cast_slice(&geo),
            usage: wgpu::BufferUsages::STORAGE,
        });
        for (c, chunk) in jobs.chunks(CHUNK).enumerate() {
            let fchunk = &mut fields[c * CHUNK..c * CHUNK + chunk.len()];
            let n = chunk.len();
            let mut job_data = Vec::with_capacity(n * JOB_STRIDE);
            let mut field_data = vec![0.0_f64; n * full];
            let mut inlets = vec![NO_INLET; n * (grid.n_z + 1)];
            for (k, (job, f)) in chunk.iter().zip(fchunk.iter()).enumerate() {
                let warm = f.len() == full && f.iter().all(|v| v.is_finite() && *v >= 0.0);
                if warm {
                    field_data[k * full..(k + 1) * full].copy_from_slice(f);
                }
                job_data.extend_from_slice(&job.state.ecc);
                job_data.extend_from_slice(&job.state.rate);
                job_data.push(job.aspect * job.aspect / (dt * dt));
                job_data.push(grid.relaxation(job.aspect));
                job_data.push(if warm { 1.0 } else { 0.0 });
                job_data.push(job.supply);
                if grid.max_film_inlet {
                    let e = &job.state.ecc;
                    for j in 0..=grid.n_z {
                        let zeta = j as f64 / grid.n_z as f64;
                        let ex = e[0] + (e[2] - e[0]) * zeta;
                        let ey = e[1] + (e[3] - e[1]) * zeta;
                        if ex != 0.0 || ey != 0.0 {
                            let th = (-ey).atan2(-ex).rem_euclid(2.0 * PI);
                            inlets[k * (grid.n_z + 1) + j] =
                                ((th / dt).round() as usize % grid.n_theta) as u32;
                        }
                    }
                }
            }
            let params = Params {
                count: n as u32,
                n_theta: grid.n_theta as u32,
                n_z: grid.n_z as u32,
                max_sweeps: grid.max_sweeps(),
                tolerance: grid.tolerance,
            };
            let make = |device: &wgpu::Device| {
                let storage = |label, data: &[u8], extra: wgpu::BufferUsages| {
                    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(label),
                        contents: data,
                        usage: wgpu::BufferUsages::STORAGE | extra,
                    })
                };
                vec![
                    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("finite params"),
                        contents: bytemuck::bytes_of(&params),
                        usage: wgpu::BufferUsages::UNIFORM,
                    }),
                    trig_buf.clone(),
                    storage(
                        "finite jobs",
                        bytemuck::cast_slice(&job_data),
                        wgpu::BufferUsages::empty(),
                    ),
                    storage(
                        "finite fields",
                        bytemuck::cast_slice(&field_data),
                        wgpu::BufferUsages::COPY_SRC,
                    ),
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("finite results"),
                        size: (n * OUT_STRIDE * 8) as u64,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    }),
                    storage(
                        "finite inlets",
                        bytemuck::cast_slice(&inlets),
                        wgpu::BufferUsages::empty(),
                    ),
                    geo_buf.clone(),
                ]
            };
            // Fields (binding 3, if wanted), then results (binding 4).
            let read: &[usize] = if fields_wanted { &[3, 4] } else { &[4] };
            let vals = dispatch_read(
                device,
                queue,
                timeout,
                &self.pipeline,
                make,
                n as u32,
                1,
                read,
                "finite-film",
            )?;
            let read_fields = if fields_wanted { n * full } else { 0 };
            for (k, f) in fchunk.iter_mut().enumerate() {
                f.clear();
                if fields_wanted {
                    f.extend_from_slice(&vals[k * full..(k + 1) * full]);
                }
            }
            let res = &vals[read_fields..];
            for k in 0..n {
                let r = &res[k * OUT_STRIDE..(k + 1) * OUT_STRIDE];
                out.push([r[0], r[1], r[2], r[3]]);
                reports.push(SolveReport {
                    sweeps: r[4] as u32,
                    iteration_error: r[5],
                    converged: r[6] > 0.5,
                    n_theta: grid.n_theta as u32,
                    n_z: grid.n_z as u32,
                    ..SolveReport::default()
                });
            }
        }
        Ok(())
    }
}

/// Compiles the compute pipeline of a finite-film kernel (`source`, entry point `main`,
/// layout from the shader), shared by the finite-film drivers; a validation error is
/// returned as "`what` does not build", not raised.
pub(crate) fn compile_pipeline(
    device: &wgpu::Device,
    file: &str,
    source: &str,
    label: &str,
    what: &str,
) -> Result<wgpu::ComputePipeline, BackendError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(file),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(BackendError::Device(format!("{what} does not build: {e}"))),
        None => Ok(pipeline),
    }
}

/// One dispatch of a one-workgroup-per-state kernel and its read-back, shared by the
/// finite-film drivers: `make` creates the buffers bound at 0, 1, ... (inside the error
/// scopes, so that running out of device memory is an error, not a panic); `groups`
/// workgroups run `pipeline`, `repeat` times in a row (one compute pass: each dispatch
/// sees the previous one's writes); the buffers at `read` (in that order, each with
/// `COPY_SRC`) are copied back and returned as one f64 vector. `what` names the work in
/// error messages.
#[allow(clippy::too_many_arguments)]
pub(crate) fn dispatch_read(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    timeout: Duration,
    pipeline: &wgpu::ComputePipeline,
    make: impl FnOnce(&wgpu::Device) -> Vec<wgpu::Buffer>,
    groups: u32,
    repeat: u32,
    read: &[usize],
    what: &str,
) -> Result<Vec<f64>, BackendError> {
    let scope_oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let scope_val = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bufs = make(device);
    let total: u64 = read.iter().map(|&b| bufs[b].size()).sum();
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("finite readback"),
        size: total.max(8),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = pipeline.get_bind_group_layout(0);
    let entries: Vec<wgpu::BindGroupEntry> = bufs
        .iter()
        .enumerate()
        .map(|(b, buf)| wgpu::BindGroupEntry {
            binding: b as u32,
            resource: buf.as_entire_binding(),
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("finite bindings"),
        layout: &layout,
        entries: &entries,
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(what),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        for _ in 0..repeat.max(1) {
            pass.dispatch_workgroups(groups.min(ROW), groups.div_ceil(ROW), 1);
        }
    }
    let mut at = 0;
    for &b in read {
        enc.copy_buffer_to_buffer(&bufs[b], 0, &readback, at, bufs[b].size());
        at += bufs[b].size();
    }
    let sub = queue.submit(Some(enc.finish()));
    let val = pollster::block_on(scope_val.pop());
    let oom = pollster::block_on(scope_oom.pop());
    if let Some(e) = oom.or(val) {
        return Err(BackendError::Device(format!(
            "dispatching {groups} {what} states: {e}"
        )));
    }
    map_read(device, sub, &readback, total.max(8), timeout, what)
}

/// The read-back's tail shared by the finite-film drivers: waits (at most `timeout`)
/// for submission `sub`, maps the first `bytes` of `readback` (`MAP_READ`, filled by a
/// copy in that submission), returns them as f64 and unmaps it, so that the buffer can be
/// reused. `what` names the work in error messages.
pub(crate) fn map_read(
    device: &wgpu::Device,
    sub: wgpu::SubmissionIndex,
    readback: &wgpu::Buffer,
    bytes: u64,
    timeout: Duration,
    what: &str,
) -> Result<Vec<f64>, BackendError> {
    if bytes == 0 {
        return Ok(Vec::new());
    }
    let done: Arc<Mutex<Option<Result<(), wgpu::BufferAsyncError>>>> = Arc::new(Mutex::new(None));
    let d = done.clone();
    readback.map_async(wgpu::MapMode::Read, ..bytes, move |r| {
        if let Ok(mut g) = d.lock() {
            *g = Some(r);
        }
    });
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(sub),
            timeout: Some(timeout),
        })
        .map_err(|e| {
            BackendError::Device(format!(
                "waiting for the {what} kernel (timeout {timeout:?}): {e}"
            ))
        })?;
    let mut state = done.lock().ok().and_then(|g| g.clone());
    if state.is_none() {
        let _ = device.poll(wgpu::PollType::Poll);
        state = done.lock().ok().and_then(|g| g.clone());
    }
    match state {
        Some(Ok(())) => {}
        Some(Err(e)) => {
            return Err(BackendError::Device(format!(
                "reading the {what} results back: {e}"
            )))
        }
        None => {
            return Err(BackendError::Device(format!(
                "{what} results never became readable"
            )))
        }
    }
    let vals = {
        let view = readback
            .get_mapped_range(..bytes)
            .map_err(|e| BackendError::Device(format!("mapping the {what} results: {e}")))?;
        bytemuck::cast_slice::<u8, f64>(&view).to_vec()
    };
    readback.unmap();
    Ok(vals)
}
