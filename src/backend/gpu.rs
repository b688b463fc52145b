//! The GPU kernel: `shaders/film.wgsl` through wgpu, in f64 where the adapter offers
//! `SHADER_F64` and in f32 (on the already nondimensional packed states) otherwise.
//!
//! Device, pipeline, bind group and buffers are created once and grown as needed; a
//! call is split into chunks that respect the binding and dispatch limits. Every chunk
//! runs inside error scopes and waits with a timeout: a lost device, an out-of-memory
//! or a timeout turns into [`BackendError::Device`] (which [`super::LoadEvaluator`]
//! answers with a CPU recomputation), never into loads read from a buffer the kernel did
//! not finish. After such a failure the backend refuses further work.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use wgpu::util::DeviceExt;

use super::gpu_kernel::{
    kernel_source_lanes, GpuOptions, GpuTiming, HARDWARE_DEFAULT_LANES, HARDWARE_DEFAULT_SLOTS,
    KERNEL_WORKGROUP_SIZE, MAX_SLOTS,
};
use super::{relative_difference, BackendError, BackendInfo, CpuBackend, FilmBackend, Precision};
use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::{Accuracy, FilmIntegrals, FilmRule, PackedState, RuleSettings};

/// Invocations per workgroup (`@workgroup_size` in the shader).
const WORKGROUP_SIZE: u32 = KERNEL_WORKGROUP_SIZE;

/// Most states per dispatch by default: 2^20 keeps the f64 input at 64 MiB, under the
/// 128 MiB storage-binding size that every Vulkan driver offers.
const DEFAULT_MAX_CHUNK: usize = 1 << 20;

/// Relative agreement with the CPU kernel the start-up self-check demands, by precision
/// (the promises, which the backend suite measures on random states).
const SELF_CHECK_TOL_F64: f64 = 1e-9;
const SELF_CHECK_TOL_F32: f64 = 1e-5;

/// Failure state shared with wgpu's callbacks.
type Fault = Arc<Mutex<Option<String>>>;

struct Buffers {
    capacity: usize,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f64,
}

/// The WGSL kernel on one wgpu device.
pub struct GpuBackend {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    table: wgpu::Buffer,
    buffers: Option<Buffers>,
    timestamps: Option<Timestamps>,
    settings: RuleSettings,
    precision: Precision,
    device_name: String,
    max_chunk: usize,
    timeout: Duration,
    profile: bool,
    fault: Fault,
    scratch_f32: Vec<f32>,
    last: GpuTiming,
    notice: Option<String>,
    software: bool,
    /// Invocations per state of the short-film kernel.
    lanes: u32,
    /// Most workgroups along one dispatch dimension (the device's limit).
    max_groups_x: u32,
    /// Dispatch slots a shared dispatcher should keep in flight ([`GpuOptions::slots`]).
    slots: usize,
    /// Poll in a loop instead of blocking on the fence ([`GpuOptions::spin_wait`]).
    spin_wait: bool,
    /// A shared dispatcher's merge policy ([`GpuOptions::merge`]).
    merge: Option<(usize, Duration)>,
    /// The finite-film kernel, compiled on first use (f64 devices only).
    finite: Option<super::finite_gpu::FinitePipeline>,
}

/// The uniform block of the shader (`Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    nodes: u32,
    max_panels: u32,
    pad: u32,
}

/// Picks the adapter: `WGPU_ADAPTER_NAME` (case-insensitive substring) when set, else the
/// best device type (discrete, integrated, virtual, CPU); among the backends that
/// `WGPU_BACKEND` allows.
fn select_adapter() -> Result<wgpu::Adapter, BackendError> {
    if wgpu::Instance::enabled_backend_features().is_empty() {
        // wgpu would panic: this build has no backend for this platform (Vulkan only).
        return Err(BackendError::NoAdapter(
            "this build has no wgpu backend for this platform (it includes Vulkan only)".into(),
        ));
    }
    let desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    let backends = desc.backends;
    let instance = wgpu::Instance::new(desc);
    let adapters: Vec<wgpu::Adapter> = pollster::block_on(instance.enumerate_adapters(backends))
        .into_iter()
        .filter(|a| {
            a.get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        })
        .collect();
    if adapters.is_empty() {
        return Err(BackendError::NoAdapter(format!(
            "no adapter with compute shaders among backends {backends:?} \
             (on Linux without a GPU install Mesa's lavapipe: mesa-vulkan-drivers)"
        )));
    }
    if let Ok(wanted) = std::env::var("WGPU_ADAPTER_NAME") {
        let w = wanted.to_lowercase();
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        return adapters
            .into_iter()
            .find(|a| a.get_info().name.to_lowercase().contains(&w))
            .ok_or_else(|| {
                BackendError::NoAdapter(format!(
                    "WGPU_ADAPTER_NAME=`{wanted}` matches none of {names:?}"
                ))
            });
    }
    let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    adapters
        .into_iter()
        .min_by_key(rank)
        .ok_or_else(|| BackendError::NoAdapter("no adapter".into()))
}

/// The `table` buffer's contents (layout documented in the shader).
fn table_values(rule: &FilmRule) -> Vec<f64> {
    let s = rule.settings();
    let g = rule.gauss();
    let mut t = vec![
        s.kappa_ahead,
        s.kappa_behind,
        s.kink_floor,
        s.complex_ellipse,
    ];
    t.extend_from_slice(&g.nodes);
    t.extend_from_slice(&g.weights);
    // Durand-Kerner start angles, as `quartic_roots` computes them on the CPU.
    for m in 1..=4usize {
        for k in 0..m {
            let ang = 0.4 + 2.0 * std::f64::consts::PI * k as f64 / m as f64;
            t.push(ang.cos());
            t.push(ang.sin());
        }
    }
    t
}

/// Fixed states the start-up self-check evaluates: aligned, tilted, squeezed, near the
/// wall, a rate-vector kink. Eccentricities up to 0.95.
fn self_check_states() -> Vec<PackedState> {
    let mut v = Vec::new();
    for k in 0..24 {
        let t = k as f64 / 23.0;
        let a = 0.3 + 5.0 * t;
        let e0 = 0.95 * t;
        let e1 = 0.95 * (1.0 - t);
        v.push(PackedState {
            ecc: [
                e0 * a.cos(),
                e0 * a.sin(),
                e1 * (a + 1.0).cos(),
                e1 * (a + 1.0).sin(),
            ],
            rate: [
                (2.0 * a).cos(),
                (3.0 * a).sin(),
                -0.5 + t,
                if k % 3 == 0 { 0.2 } else { -0.7 },
            ],
        });
    }
    // Aligned with pure spin.
    v.push(PackedState {
        ecc: [0.6, 0.1, 0.6, 0.1],
        rate: [-0.1, 0.6, -0.1, 0.6],
    });
    v
}

impl GpuBackend {
    /// Opens the adapter (see docs/cli.md "Backends"), builds the pipeline for the rule
    /// at `accuracy` and checks it against the CPU kernel on a few fixed states. An f64
    /// kernel that fails to build or to agree is replaced by the f32 one (with a notice)
    /// unless f64 was demanded.
    pub fn new(accuracy: Accuracy, options: GpuOptions) -> Result<Self, BackendError> {
        Self::with_settings(accuracy.settings(), options)
    }

    /// As [`GpuBackend::new`] with explicit rule settings.
    pub fn with_settings(
        settings: RuleSettings,
        options: GpuOptions,
    ) -> Result<Self, BackendError> {
        let adapter = select_adapter()?;
        let has_f64 = adapter.features().contains(wgpu::Features::SHADER_F64);
        let name = adapter.get_info().name;
        let first = match options.precision {
            Some(Precision::F64) if !has_f64 => {
                return Err(BackendError::NoAdapter(format!(
                    "adapter `{name}` lacks SHADER_F64 and f64 was demanded"
                )))
            }
            Some(p) => p,
            None if has_f64 => Precision::F64,
            None => Precision::F32,
        };
        match Self::build(&adapter, settings, &options, first) {
            Ok(b) => Ok(b),
            Err(e) if first == Precision::F64 && options.precision.is_none() => {
                let mut b = Self::build(&adapter, settings, &options, Precision::F32)?;
                b.notice = Some(format!(
                    "notice: the f64 kernel on `{name}` failed ({e}); using f32 on the GPU"
                ));
                Ok(b)
            }
            Err(e) => Err(e),
        }
    }

    fn build(
        adapter: &wgpu::Adapter,
        settings: RuleSettings,
        options: &GpuOptions,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        let info = adapter.get_info();
        let mut features = wgpu::Features::empty();
        if precision == Precision::F64 {
            features |= wgpu::Features::SHADER_F64;
        }
        let timestamps_ok =
            options.profile && adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        if timestamps_ok {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("bearing-sweep film kernel"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| BackendError::Device(format!("cannot open `{}`: {e}", info.name)))?;
        let fault: Fault = Arc::new(Mutex::new(None));
        {
            let f = fault.clone();
            device.set_device_lost_callback(move |reason, msg| {
                if let Ok(mut g) = f.lock() {
                    g.get_or_insert(format!("device lost ({reason:?}): {msg}"));
                }
            });
            let f = fault.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                if let Ok(mut g) = f.lock() {
                    g.get_or_insert(format!("uncaptured device error: {e}"));
                }
            }));
        }
        let rule = FilmRule::new(settings);
        let software = info.device_type == wgpu::DeviceType::Cpu;
        let lanes = options
            .lanes
            .unwrap_or(if software { 1 } else { HARDWARE_DEFAULT_LANES });
        let source = kernel_source_lanes(precision, lanes)?;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("film.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("film kernel"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(BackendError::Device(format!(
                "the {precision:?} kernel does not build on `{}`: {e}",
                info.name
            )));
        }
        let table_f64 = table_values(&rule);
        let table_bytes: Vec<u8> = match precision {
            Precision::F64 => bytemuck::cast_slice(&table_f64).to_vec(),
            Precision::F32 => {
                let t: Vec<f32> = table_f64.iter().map(|&x| x as f32).collect();
                bytemuck::cast_slice(&t).to_vec()
            }
        };
        let table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rule table"),
            contents: &table_bytes,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let params = params_buffer(&device);
        let in_stride = in_stride(precision) as u64;
        let by_binding = (limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            / in_stride) as usize;
        // Workgroups run along x and y (the shader folds them into one index).
        let max_groups_x = limits.max_compute_workgroups_per_dimension.max(1);
        let by_dispatch =
            max_groups_x as usize * max_groups_x as usize * (WORKGROUP_SIZE / lanes) as usize;
        let max_chunk = options
            .max_chunk
            .unwrap_or(DEFAULT_MAX_CHUNK)
            .min(by_binding)
            .min(by_dispatch)
            .max(1);
        let timestamps = timestamps_ok.then(|| Timestamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            period_ns: queue.get_timestamp_period() as f64,
        });
        let mut backend = GpuBackend {
            device,
            queue,
            pipeline,
            params,
            table,
            buffers: None,
            timestamps,
            settings,
            precision,
            device_name: format!(
                "{} ({:?} {:?}, driver {} {})",
                info.name, info.backend, info.device_type, info.driver, info.driver_info
            ),
            max_chunk,
            timeout: options.timeout,
            profile: options.profile,
            fault,
            scratch_f32: Vec::new(),
            last: GpuTiming::default(),
            notice: None,
            software,
            lanes,
            max_groups_x,
            slots: options
                .slots
                .unwrap_or(if software { 1 } else { HARDWARE_DEFAULT_SLOTS })
                .clamp(1, MAX_SLOTS),
            spin_wait: options.spin_wait.unwrap_or(false),
            merge: options.merge,
            finite: None,
        };
        backend.self_check()?;
        Ok(backend)
    }

    /// Runs the fixed self-check states and compares them with the CPU kernel.
    fn self_check(&mut self) -> Result<(), BackendError> {
        let states = self_check_states();
        let mut cpu = CpuBackend::with_settings(self.settings, Some(1));
        let mut want = Vec::new();
        cpu.integrate(&states, &mut want)?;
        let mut got = Vec::new();
        self.integrate(&states, &mut got)?;
        let tol = match self.precision {
            Precision::F64 => SELF_CHECK_TOL_F64,
            Precision::F32 => SELF_CHECK_TOL_F32,
        };
        if got.len() != want.len() {
            return Err(BackendError::Device(format!(
                "self-check: {} results for {} states",
                got.len(),
                want.len()
            )));
        }
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            let d = relative_difference(g, w);
            // NaN fails too.
            if d.is_nan() || d > tol {
                return Err(BackendError::Device(format!(
                    "self-check state {k}: GPU {g:?} vs CPU {w:?}, relative difference \
                     {d:.2e} > {tol:.0e}"
                )));
            }
        }
        Ok(())
    }

    /// Precision the kernel computes in.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// Whether the adapter is a software rasteriser on the CPU (lavapipe's llvmpipe).
    pub fn is_software(&self) -> bool {
        self.software
    }

    /// Invocations per state of the short-film kernel ([`GpuOptions::lanes`]).
    pub fn lanes(&self) -> u32 {
        self.lanes
    }

    /// Another backend on the same device, pipeline and rule table, with buffers of its
    /// own (for a second dispatch in flight beside this one): identical integrals, no
    /// profiling, the same fault state (a failure of either stops both).
    pub fn sibling_backend(&self) -> GpuBackend {
        GpuBackend {
            device: self.device.clone(),
            queue: self.queue.clone(),
            pipeline: self.pipeline.clone(),
            params: params_buffer(&self.device),
            table: self.table.clone(),
            buffers: None,
            timestamps: None,
            settings: self.settings,
            precision: self.precision,
            device_name: self.device_name.clone(),
            max_chunk: self.max_chunk,
            timeout: self.timeout,
            profile: false,
            fault: self.fault.clone(),
            scratch_f32: Vec::new(),
            last: GpuTiming::default(),
            notice: None,
            software: self.software,
            lanes: self.lanes,
            max_groups_x: self.max_groups_x,
            slots: self.slots,
            spin_wait: self.spin_wait,
            merge: self.merge,
            finite: None,
        }
    }

    /// Dispatch slots a shared dispatcher keeps in flight ([`GpuOptions::slots`]).
    pub fn slots(&self) -> usize {
        self.slots
    }

    /// Most states per dispatch.
    pub fn max_chunk(&self) -> usize {
        self.max_chunk
    }

    /// Timing of the last call.
    pub fn last_timing(&self) -> GpuTiming {
        self.last
    }

    /// A notice raised while building (an f64 kernel replaced by f32), if any.
    pub fn take_notice(&mut self) -> Option<String> {
        self.notice.take()
    }

    /// Destroys the device as a driver fault would (for testing the fallback path).
    #[doc(hidden)]
    pub fn simulate_device_loss(&mut self) {
        self.device.destroy();
    }

    /// Sets the per-chunk wait (for testing the timeout path).
    #[doc(hidden)]
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    fn check_fault(&self) -> Result<(), BackendError> {
        match self.fault.lock() {
            Ok(g) => match g.as_ref() {
                Some(msg) => Err(BackendError::Device(msg.clone())),
                None => Ok(()),
            },
            Err(_) => Err(BackendError::Device("fault state poisoned".into())),
        }
    }

    /// Records `msg` as the backend's fault (it then refuses further work) and returns it.
    fn fail(&self, msg: String) -> BackendError {
        if let Ok(mut g) = self.fault.lock() {
            g.get_or_insert(msg.clone());
        }
        BackendError::Device(msg)
    }

    fn ensure_capacity(&mut self, n: usize) -> Result<(), BackendError> {
        if self.buffers.as_ref().is_some_and(|b| b.capacity >= n) {
            return Ok(());
        }
        let capacity = n.next_power_of_two().max(256).min(self.max_chunk.max(n));
        let ins = in_stride(self.precision) as u64 * capacity as u64;
        let outs = out_stride(self.precision) as u64 * capacity as u64;
        let scope_oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let scope_val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let input = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("states"),
            size: ins,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let output = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("integrals"),
            size: outs,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: outs,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = self.pipeline.get_bind_group_layout(0);
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("film kernel bindings"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.table.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        let val = pollster::block_on(scope_val.pop());
        let oom = pollster::block_on(scope_oom.pop());
        if let Some(e) = oom.or(val) {
            self.buffers = None;
            return Err(self.fail(format!(
                "cannot allocate buffers for {capacity} states ({} MiB): {e}",
                (ins + 2 * outs) >> 20
            )));
        }
        self.buffers = Some(Buffers {
            capacity,
            input,
            output,
            readback,
            bind_group,
        });
        Ok(())
    }

    /// Blocks until `buffer`'s first `size` bytes are mapped, the device fails, or the
    /// timeout passes.
    fn map_wait(
        &self,
        buffer: &wgpu::Buffer,
        size: u64,
        submission: wgpu::SubmissionIndex,
    ) -> Result<(), BackendError> {
        let done: Arc<Mutex<Option<Result<(), wgpu::BufferAsyncError>>>> =
            Arc::new(Mutex::new(None));
        let d = done.clone();
        buffer.map_async(wgpu::MapMode::Read, 0..size, move |r| {
            if let Ok(mut g) = d.lock() {
                *g = Some(r);
            }
        });
        let poll = if self.spin_wait {
            self.spin_until(&done, self.timeout)
        } else {
            self.device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(submission),
                    timeout: Some(self.timeout),
                })
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        if let Err(e) = poll {
            return Err(self.fail(format!(
                "waiting for the kernel (timeout {:?}): {e}",
                self.timeout
            )));
        }
        self.check_fault()?;
        // The map callback runs during the poll that saw the submission complete; poll
        // once more without blocking in case it was queued behind it.
        let mut state = done.lock().ok().and_then(|g| g.clone());
        if state.is_none() {
            let _ = self.device.poll(wgpu::PollType::Poll);
            state = done.lock().ok().and_then(|g| g.clone());
        }
        match state {
            Some(Ok(())) => Ok(()),
            Some(Err(e)) => Err(self.fail(format!("reading the results back: {e}"))),
            None => Err(self.fail("results never became readable".into())),
        }
    }

    /// Polls the device without blocking until `done` holds a result (the map callback ran)
    /// or `timeout` passes.
    fn spin_until(
        &self,
        done: &Mutex<Option<Result<(), wgpu::BufferAsyncError>>>,
        timeout: Duration,
    ) -> Result<(), String> {
        let start = Instant::now();
        loop {
            self.device
                .poll(wgpu::PollType::Poll)
                .map_err(|e| e.to_string())?;
            if done.lock().map(|g| g.is_some()).unwrap_or(true) {
                return Ok(());
            }
            if start.elapsed() > timeout {
                return Err("timed out".into());
            }
            std::hint::spin_loop();
        }
    }

    /// One chunk: upload, dispatch, read back, append to `out`.
    fn run_chunk(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        let n = states.len();
        self.ensure_capacity(n)?;
        let bufs = self.buffers.as_ref().expect("buffers allocated above");
        let scope_oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let scope_val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let scope_int = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        match self.precision {
            Precision::F64 => {
                self.queue
                    .write_buffer(&bufs.input, 0, bytemuck::cast_slice(states));
            }
            Precision::F32 => {
                self.scratch_f32.clear();
                self.scratch_f32.extend(
                    states
                        .iter()
                        .flat_map(|s| s.ecc.iter().chain(&s.rate).map(|&x| x as f32)),
                );
                self.queue
                    .write_buffer(&bufs.input, 0, bytemuck::cast_slice(&self.scratch_f32));
            }
        }
        let params = Params {
            count: n as u32,
            nodes: self.settings.nodes,
            max_panels: self.settings.max_panels,
            pad: 0,
        };
        self.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let out_bytes = (out_stride(self.precision) * n) as u64;
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("film kernel"),
                timestamp_writes: self.timestamps.as_ref().map(|t| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: &t.set,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }
                }),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bufs.bind_group, &[]);
            let groups = (n as u32).div_ceil(WORKGROUP_SIZE / self.lanes);
            let x = groups.clamp(1, self.max_groups_x);
            pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
        }
        if let Some(t) = &self.timestamps {
            enc.resolve_query_set(&t.set, 0..2, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &t.readback, 0, 16);
        }
        let kernel_start = Instant::now();
        if self.profile {
            // Kernel alone: submit the dispatch, wait, then copy in a second submission.
            let sub = self.queue.submit(Some(enc.finish()));
            if let Err(e) = self.device.poll(wgpu::PollType::Wait {
                submission_index: Some(sub),
                timeout: Some(self.timeout),
            }) {
                return Err(self.fail(format!(
                    "waiting for the kernel (timeout {:?}): {e}",
                    self.timeout
                )));
            }
            let wall = kernel_start.elapsed().as_secs_f64();
            *self.last.kernel_wall_s.get_or_insert(0.0) += wall;
            enc = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        }
        enc.copy_buffer_to_buffer(&bufs.output, 0, &bufs.readback, 0, out_bytes);
        let sub = self.queue.submit(Some(enc.finish()));
        let int = pollster::block_on(scope_int.pop());
        let val = pollster::block_on(scope_val.pop());
        let oom = pollster::block_on(scope_oom.pop());
        if let Some(e) = oom.or(val).or(int) {
            return Err(self.fail(format!("dispatching {n} states: {e}")));
        }
        self.map_wait(&bufs.readback, out_bytes, sub)?;
        {
            let view = bufs
                .readback
                .get_mapped_range(0..out_bytes)
                .map_err(|e| self.fail(format!("mapping the results: {e}")))?;
            // The device writes little-endian f64: on a little-endian host the mapped
            // bytes are the integrals already (one copy), when aligned as mapped ranges are.
            let direct = cfg!(target_endian = "little") && self.precision == Precision::F64;
            match bytemuck::try_cast_slice::<u8, [f64; 4]>(&view[..]) {
                Ok(v) if direct => out.extend_from_slice(v),
                _ => match self.precision {
                    Precision::F64 => out.extend(view.chunks_exact(32).map(|c| {
                        let f = |k: usize| {
                            f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().expect("8 bytes"))
                        };
                        [f(0), f(1), f(2), f(3)]
                    })),
                    Precision::F32 => out.extend(view.chunks_exact(16).map(|c| {
                        let f = |k: usize| {
                            f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"))
                                as f64
                        };
                        [f(0), f(1), f(2), f(3)]
                    })),
                },
            }
        }
        bufs.readback.unmap();
        if let Some(t) = &self.timestamps {
            let sub = self.queue.submit(None);
            self.map_wait(&t.readback, 16, sub)?;
            let ticks: [u64; 2] = {
                let view = t
                    .readback
                    .get_mapped_range(0..16)
                    .map_err(|e| self.fail(format!("mapping timestamps: {e}")))?;
                let a = u64::from_le_bytes(view[0..8].try_into().expect("8 bytes"));
                let b = u64::from_le_bytes(view[8..16].try_into().expect("8 bytes"));
                [a, b]
            };
            t.readback.unmap();
            let secs = ticks[1].saturating_sub(ticks[0]) as f64 * t.period_ns * 1e-9;
            *self.last.kernel_device_s.get_or_insert(0.0) += secs;
        }
        Ok(())
    }
}

/// The uniform buffer of one slot's `Params`.
fn params_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: std::mem::size_of::<Params>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Bytes per packed state in the shader's input array.
fn in_stride(p: Precision) -> usize {
    match p {
        Precision::F64 => 64,
        Precision::F32 => 32,
    }
}

/// Bytes per state in the shader's output array.
fn out_stride(p: Precision) -> usize {
    match p {
        Precision::F64 => 32,
        Precision::F32 => 16,
    }
}

impl FilmBackend for GpuBackend {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "gpu".into(),
            device: self.device_name.clone(),
            precision: self.precision,
        }
    }

    fn settings(&self) -> RuleSettings {
        self.settings
    }

    fn dispatch_slots(&self) -> usize {
        self.slots
    }

    fn sibling(&self) -> Option<Box<dyn FilmBackend>> {
        Some(Box::new(self.sibling_backend()))
    }

    fn merge_policy(&self) -> Option<(usize, Duration)> {
        self.merge
    }

    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        let start = Instant::now();
        out.clear();
        self.last = GpuTiming::default();
        self.check_fault()?;
        out.reserve(states.len());
        for chunk in states.chunks(self.max_chunk) {
            self.last.chunks += 1;
            if let Err(e) = self.run_chunk(chunk, out) {
                out.clear();
                return Err(e);
            }
        }
        self.last.total_s = start.elapsed().as_secs_f64();
        Ok(())
    }

    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.integrate_finite_with(jobs, grid, fields, true, out, reports)
    }

    fn integrate_finite_with(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        fields_wanted: bool,
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.check_fault()?;
        if self.precision != Precision::F64 {
            return Err(BackendError::Device(
                "the finite-film kernel needs SHADER_F64; this GPU kernel runs in f32".into(),
            ));
        }
        if self.finite.is_none() {
            self.finite = Some(super::finite_gpu::FinitePipeline::new(&self.device)?);
        }
        let pipeline = self.finite.as_ref().expect("built above");
        pipeline.run(
            &self.device,
            &self.queue,
            self.timeout,
            jobs,
            grid,
            fields,
            fields_wanted,
            out,
            reports,
        )
    }

    /// JFO films with their histories: the JFO kernel (explicit grids).
    fn integrate_finite_jfo(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<crate::bearing::finite::JfoHistory>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.check_fault()?;
        if self.precision != Precision::F64 {
            return Err(BackendError::Device(
                "the finite-film kernel needs SHADER_F64; this GPU kernel runs in f32".into(),
            ));
        }
        if self.finite.is_none() {
            self.finite = Some(super::finite_gpu::FinitePipeline::new(&self.device)?);
        }
        let pipeline = self.finite.as_ref().expect("built above");
        pipeline.run_jfo(
            &self.device,
            &self.queue,
            self.timeout,
            jobs,
            grid,
            fields,
            histories,
            out,
            reports,
        )
    }
}
