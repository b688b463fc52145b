//! Host side of `shaders/finite_mg.wgsl`: the finite-length film's projected multigrid on
//! the GPU backend's device (issue 20 item 2, issue 26 item 3), for explicit grids beyond
//! the PSOR kernel's workgroup memory and for accuracy mode (the ladder of nested grids
//! with its Richardson estimate and stop rule, run inside the kernel).
//!
//! One workgroup per state, every level of its hierarchy in a storage buffer. States are
//! grouped by their hierarchy (grid sizes and coarsenings depend on the aspect `B/r0`);
//! each group is dispatched in chunks bounded by a scratch budget per device
//! ([`scratch_budget`]); on hardware an accuracy-mode group too large for one chunk runs
//! in passes on growing ladders instead ([`tiered`]). The device buffers are kept between
//! chunks and calls ([`Kept`]), and the fields are read back only when the caller wants
//! them (`fields_wanted`: a warm start, film friction and flow).
//!
//! **Resumable.** llvmpipe (lavapipe) ends a shader's loops after 65 535 iterations in
//! all; one dispatch of the whole solve ran past that at 512 × 128 and beyond (1024 × 128:
//! stopped after 34.8 sweeps of work of the CPU's 105.7, loads 100 % off). So the kernel
//! runs steps of the solve (a level's set-up, a V-cycle's descent or ascent on one level,
//! one coarsest-grid sweep, ...) until it has counted a loop budget ([`loop_budget`]),
//! keeps its state (phase, level, cycle, stop-rule and ladder history) in the result
//! buffer and the fields in its scratch, and the host dispatches again until every state
//! is done: the same arithmetic in the same order as one long dispatch. A dispatch that
//! counted more loop iterations than [`LOOP_LIMIT`] (the serial walk of the truncated
//! correction beyond its reserve), or a state not done after the cap on dispatches, is an
//! error, never loads.
//!
//! **Range.** Grids up to [`DEVICE_MAX_NODES`] (nodes with the end rows): one step of the
//! largest level must fit a dispatch's loop budget (about 375 000 nodes; the range is
//! about 70 % of that, so that a dispatch holds more than one such step) and a state's
//! scratch (8 arrays per level, ~90 bytes per node of the largest level with the levels
//! below and the field) one storage binding of the device (checked per device: an error
//! beyond it). Checked against the CPU up to 1024 × 128 (132 096 nodes, the ladder's last
//! grid at B/D = 0.5) on lavapipe. Beyond the range an explicit grid is declined (the
//! evaluator recomputes it on the CPU with a notice), and in accuracy mode the ladder runs
//! on the device up to there; the states whose estimate is still above the accuracy are
//! solved from scratch by the CPU solver here (the same deterministic ladder, so the same
//! result as a CPU run).

use std::f64::consts::PI;
use std::time::Duration;

use wgpu::util::DeviceExt;

use super::finite_gpu::{compile_pipeline, map_read};
use super::BackendError;
use crate::bearing::finite::{
    accuracy_ladder, coarser, solution_theta0, Coarsen, FiniteGrid, FiniteJob, LadderRule,
    SolveReport, ALGEBRAIC_FRACTION,
};
use crate::bearing::FilmIntegrals;

/// The multigrid kernel's WGSL source.
pub const FINITE_MG_WGSL: &str = include_str!("../../shaders/finite_mg.wgsl");

/// Levels of a hierarchy the kernel's parameter block holds (`MAX_LEVELS`).
const MAX_LEVELS: usize = 24;
/// Ladder grids the kernel keeps load vectors of (`MAX_RUNGS`).
const MAX_RUNGS: usize = 12;
/// f64 per job and per result (`JOB_STRIDE`, `OUT_STRIDE`: the report, then the resumable
/// solve's state block from `OUT_STATE`, its status first).
const JOB_STRIDE: usize = 16;
const OUT_STRIDE: usize = 121;
const OUT_STATE: usize = 11;
/// The kernel's diagnostic tally of a slot (`OUT_TALLY`, `N_TALLY` f64): see [`TALLY_NAMES`].
const OUT_TALLY: usize = 87;
const N_TALLY: usize = 34;
/// What the tally counts (the shader's `T_*`): barriers (each a step of the state's
/// chain of dependent steps) per part of the solve, then serial loop iterations of
/// invocation 0 and events. Kept per state under `BEARING_SWEEP_MG_COUNT` ([`take_tally`]).
const TALLY_NAMES: [&str; 34] = [
    "bar init",
    "bar prep",
    "bar enter",
    "bar coarse",
    "bar descent",
    "bar csolve",
    "bar ascent",
    "bar stop",
    "bar done",
    "bar main",
    "sort iters",
    "walk iters",
    "in-place iters",
    "cycle coarsest sweeps",
    "coarse-phase sweeps",
    "V-cycles",
    "dispatches",
    "corrections",
    "candidates",
    "sweeps",
    "reductions",
    "loop iters (spent)",
    "of which reductions",
    "unused",
    "iters init",
    "iters prep",
    "iters enter",
    "iters coarse",
    "iters descent",
    "iters csolve",
    "iters ascent",
    "iters stop",
    "iters done",
    "iters main",
];
const _: () = assert!(TALLY_NAMES.len() <= N_TALLY && OUT_TALLY + N_TALLY == OUT_STRIDE);
/// The state's own dispatch count (its last entry, `OUT_STATE + 73`) and the count the
/// last dispatch wrote before its steps (`OUT_BEGIN`): unequal when llvmpipe cut that
/// dispatch's loops short (the state was not saved whole).
const OUT_COUNT: usize = OUT_STATE + 73;
const OUT_BEGIN: usize = 85;
/// Status of a slot (`ST_*`): running, done, done but more grids needed, overrun.
const ST_RUN: f64 = 0.0;
const ST_MORE: f64 = 2.0;
const ST_OVERRUN: f64 = 3.0;
/// Loop iterations, as the kernel counts them, one dispatch may run (the kernel's
/// `params.limit`): llvmpipe (lavapipe) ends a shader's loops after 65 535 iterations in
/// all, and the kernel's count is an estimate that fell short of llvmpipe's by a factor
/// 1.6-2.2 (measured: a tilted whirling state at accuracy 1e-4, `mg_probe acc 1e-4 2`, was
/// cut with a budget of 40 000 counted iterations and ran right with 30 000), so the
/// limit is 65 535 / 2.2; a dispatch that counts more is void.
const LOOP_LIMIT: u32 = 30_000;

/// Loop iterations per dispatch on hardware GPUs, which have no loop cap: ten times
/// [`LOOP_LIMIT`], so that a solve that needs several dispatches on llvmpipe (accuracy
/// 1e-4, the ladder's large grids) needs fewer dispatches and read-backs, while one
/// dispatch stays well under the device timeout (the counted iterations ran at ~2 µs
/// each on the H200, session 39's 128 × 32: ~0.6 s a dispatch at most, the poll
/// timeout is 120 s). The same arithmetic whatever the limit (the kernel is resumable).
const HARDWARE_LOOP_LIMIT: u32 = 300_000;

/// The loop limit in force: [`LOOP_LIMIT`] on a software adapter (llvmpipe),
/// [`HARDWARE_LOOP_LIMIT`] on a hardware one, or (diagnostics) the environment variable
/// `BEARING_SWEEP_MG_LOOP_LIMIT`, at least [`LOOP_LIMIT`]. The arithmetic is the same
/// whatever the limit (the kernel is resumable); only the number of dispatches and
/// read-backs changes.
fn loop_limit(software: bool) -> u32 {
    std::env::var("BEARING_SWEEP_MG_LOOP_LIMIT")
        .ok()
        .and_then(|v| v.trim().parse::<u32>().ok())
        .map_or(
            if software {
                LOOP_LIMIT
            } else {
                HARDWARE_LOOP_LIMIT
            },
            |l| l.clamp(LOOP_LIMIT, u32::MAX / 4),
        )
}
/// Loop iterations reserved for the truncated correction's candidates on top of a step's
/// parallel loops: their sort (≤ 3 × 513 at the list's 512) and walk by one invocation
/// (≤ 8 per candidate), ~5 600 at a full list; beyond the list, the in-place walk over the
/// level's nodes (4 096 at 128 × 32; larger grids overrun: an error). 5 000 was too few: a
/// squeezed JFO start state at 128 × 32 overran it (tests/finite_gpu_jfo.rs).
const SERIAL_RESERVE: u32 = 10_000;
/// Workgroup size of the kernel (`WG`) on llvmpipe (lavapipe), whose loop cap
/// [`LOOP_LIMIT`] was calibrated at this size, and on adapters without room for more.
const WG: u32 = 256;
/// Workgroup size on hardware GPUs (where the limits allow it). Measured on the H200
/// (BENCHMARKS.md "Issue 20: the multigrid kernel on the H200, session 40"; raw outputs in
/// reports/h200/raw/s40/), states/s at 64 | 1024 states per call: 256 invocations
/// 3,090 | 6,609 at the default accuracy, 3,280 | 12,371 at 128 × 32, 1,108 | 1,543 at
/// 1e-4; 1024 invocations 2,043 | 5,787, 2,214 | 9,831, 1,355 | 1,710. A quarter of the
/// strided iterations per invocation did not pay for 64 registers per invocation and 4×
/// the threads per reduction: 256 wins two settings of three at both sizes.
/// `BEARING_SWEEP_MG_WG` overrides it.
const HARDWARE_WG: u32 = 256;

/// The kernel's workgroup size on `device`: `BEARING_SWEEP_MG_WG` (diagnostics: a power of
/// two from 64 to 1024 within the device's limits), else [`WG`] on a software adapter and
/// [`HARDWARE_WG`] on a hardware one whose limits allow it (invocations per workgroup and
/// workgroup memory, ~21 KiB at 1024: the reductions' 2 × WG f64 and the candidate lists).
fn workgroup_size(device: &wgpu::Device) -> u32 {
    let limits = device.limits();
    let fits = |wg: u32| {
        wg.is_power_of_two()
            && (64..=1024).contains(&wg)
            && wg <= limits.max_compute_invocations_per_workgroup
            && wg <= limits.max_compute_workgroup_size_x
            && 16 * wg + 6 * 1024 <= limits.max_compute_workgroup_storage_size
    };
    if let Some(wg) = std::env::var("BEARING_SWEEP_MG_WG")
        .ok()
        .and_then(|v| v.trim().parse::<u32>().ok())
        .filter(|&wg| fits(wg))
    {
        return wg;
    }
    let software = device.adapter_info().device_type == wgpu::DeviceType::Cpu;
    if !software && fits(HARDWARE_WG) {
        HARDWARE_WG
    } else {
        WG
    }
}

/// The kernel's source for workgroup size `wg` (its `WG` and `LOG2_WG`).
fn kernel_source(base: &str, wg: u32) -> Result<String, BackendError> {
    let (a, b) = ("const WG: u32 = 256u;", "const LOG2_WG: u32 = 8u;");
    if !base.contains(a) || !base.contains(b) {
        return Err(BackendError::Device(
            "the finite-film multigrid kernel's source lacks its WG constants".into(),
        ));
    }
    Ok(base.replace(a, &format!("const WG: u32 = {wg}u;")).replace(
        b,
        &format!("const LOG2_WG: u32 = {}u;", wg.trailing_zeros()),
    ))
}
/// Dispatches per submission (between read-backs of the status flags).
const REPEAT: u32 = 8;
/// Arrays per level in a slot's scratch (face coefficients ×2, inverse diagonals ×2,
/// right-hand side, iterate, u0, residual).
const ARRAYS: usize = 8;
/// Column value meaning "no inlet on this row" (`NO_INLET`).
const NO_INLET: u32 = u32::MAX;
/// V-cycle limit of one grid (src/bearing/finite/solver.rs `MAX_CYCLES`).
const MAX_CYCLES: u32 = 200;
/// Device memory one chunk's scratch and fields may take on a software adapter
/// (llvmpipe: host memory), bytes; the storage binding limit caps it further (128 MiB on
/// llvmpipe: ~10 states of the B/D = 0.5 ladder per chunk).
const SOFTWARE_SCRATCH_BUDGET: u64 = 2 << 30;
/// The same on a hardware GPU: 4 GiB, the most one storage binding can hold on any Vulkan
/// device (its limit is a 32-bit count of bytes). It holds a call of 1024 default-accuracy
/// states in one chunk (the ladder of B/D = 0.5 through 512 × 64: ~3.1 MB per state with
/// its field; the states that need more grids run again in chunks of the whole ladder,
/// ~12.4 MB per state, in passes: [`MultigridPipeline::run`]), and a card with less memory fails
/// the allocation with an error (the evaluator then recomputes on the CPU with a notice).
const HARDWARE_SCRATCH_BUDGET: u64 = 4 << 30;

/// Device memory one chunk's scratch and fields may take, bytes: [`SOFTWARE_SCRATCH_BUDGET`]
/// or [`HARDWARE_SCRATCH_BUDGET`], or (diagnostics, tests) `BEARING_SWEEP_MG_SCRATCH_MIB`
/// (MiB, at least 1). The device's storage binding and buffer limits cap each buffer
/// further ([`chunk_slots`]). A pipeline keeps its buffers between calls, at most one
/// chunk's: this budget, the same again in read-back staging for the fields, and the jobs,
/// results and inlets (~1.3 KiB per state) bound its device memory, per call and per run.
fn scratch_budget(software: bool) -> u64 {
    std::env::var("BEARING_SWEEP_MG_SCRATCH_MIB")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map_or(
            if software {
                SOFTWARE_SCRATCH_BUDGET
            } else {
                HARDWARE_SCRATCH_BUDGET
            },
            |mib| mib.clamp(1, 1 << 30) << 20,
        )
}

/// Whether accuracy mode runs a group that does not fit one chunk in passes (the ladder
/// first up to the largest grid at which the whole group fits one chunk, then the states
/// that need more grids again on a larger ladder: [`MultigridPipeline::run`]): on hardware
/// GPUs, where one chunk of many states keeps the device busy and every chunk costs round
/// trips; not on llvmpipe, whose time is the arithmetic (a rerun repeats ~1/4 of the
/// state's work, its lower grids). `BEARING_SWEEP_MG_TIERED=0|1` overrides (diagnostics, tests). The loads are the
/// same bits either way: the kernel's ladder does not depend on the grids above the one
/// it stops at, and a rerun state starts from scratch.
fn tiered(software: bool) -> bool {
    match std::env::var("BEARING_SWEEP_MG_TIERED")
        .ok()
        .as_deref()
        .map(str::trim)
    {
        Some("1") => true,
        Some("0") => false,
        _ => !software,
    }
}

/// A slot's scratch and field on the hierarchy `dims`, f64: 8 arrays per level, and the
/// last level's field.
fn slot_strides(dims: &[Dims]) -> (usize, usize) {
    (
        ARRAYS * dims.iter().map(full).sum::<usize>(),
        dims.last().map_or(0, full),
    )
}

/// States per chunk on the hierarchy `dims`: within `budget` bytes of scratch and fields,
/// each buffer within the device's storage binding and buffer limits, at most
/// [`MAX_SLOTS`]; 0 if one state's scratch is beyond the limits.
fn chunk_slots(dims: &[Dims], budget: u64, limits: &wgpu::Limits) -> usize {
    let (stride, field_stride) = slot_strides(dims);
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let (scratch, field) = ((stride * 8) as u64, (field_stride * 8).max(8) as u64);
    if scratch > binding {
        return 0;
    }
    (budget / (scratch + field))
        .min(binding / scratch)
        .min(binding / field)
        .clamp(1, MAX_SLOTS as u64) as usize
}

/// States per dispatch at most (bounds one dispatch's run time under the device timeout
/// on a software device; within one row of workgroups, 65 535).
const MAX_SLOTS: usize = 4096;
const _: () = assert!(MAX_SLOTS <= 65_535);
/// Largest grid (nodes with the end rows) the kernel solves: see the module docs, "Range"
/// (a step of the largest level within the loop budget allows ~375 000 nodes; about 70 %
/// of that leaves a dispatch room for more than one such step: 2048 × 129 and 1024 × 257,
/// the ladder's last grid at B/D = 1, fit). The environment variable `BEARING_SWEEP_FINITE_GPU_MAX_NODES` (a
/// node count) overrides it (an unparsable value keeps the default).
pub const DEVICE_MAX_NODES: usize = 270_000;

/// The range in force ([`DEVICE_MAX_NODES`] or its override).
fn device_max_nodes() -> usize {
    std::env::var("BEARING_SWEEP_FINITE_GPU_MAX_NODES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(DEVICE_MAX_NODES)
}

/// The uniform block (`Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    n_levels: u32,
    top0: u32,
    mode: u32,
    stride: u32,
    inlet_stride: u32,
    field_stride: u32,
    banded: u32,
    more: u32,
    max_cycles: u32,
    budget: u32,
    limit: u32,
    cubic_start: u32,
    pad: [u32; 3],
    tolerance: f64,
    target: f64,
    floor: f64,
    loose: f64,
    lv: [[u32; 4]; MAX_LEVELS],
    lw: [[u32; 4]; MAX_LEVELS],
}

/// One level of a hierarchy: intervals around and along, coarsening to the level below.
type Dims = (usize, usize, Option<Coarsen>);

/// The hierarchy of a job on `grid`: the first grid's levels (coarsest first) and, in
/// accuracy mode, the ladder's further grids; `top0` is the first grid's level.
fn hierarchy(grid: &FiniteGrid, aspect: f64) -> (Vec<Dims>, usize) {
    let (nt, nz) = match grid.accuracy {
        Some(_) => accuracy_ladder(aspect)[0],
        None => (grid.n_theta, grid.n_z),
    };
    // As Hierarchy::build: coarsen until `coarser` says the grid is the coarsest.
    let mut dims: Vec<Dims> = vec![(nt, nz, None)];
    let (mut a, mut b) = (nt, nz);
    while let Some((c, d, how)) = coarser(a, b, aspect) {
        dims.last_mut().expect("nonempty").2 = Some(how);
        dims.push((c, d, None));
        a = c;
        b = d;
    }
    dims.reverse();
    let top0 = dims.len() - 1;
    if grid.accuracy.is_some() {
        for &(t, z) in &accuracy_ladder(aspect)[1..] {
            dims.push((t, z, Some(Coarsen::Both)));
        }
    }
    (dims, top0)
}

/// Nodes of an `nt × nz` grid with its end rows.
fn full(d: &Dims) -> usize {
    d.0 * (d.1 + 1)
}

/// The compiled multigrid pipeline on one device.
pub(crate) struct MultigridPipeline {
    pipeline: wgpu::ComputePipeline,
    /// Its workgroup size ([`workgroup_size`]) and loop limit per dispatch ([`loop_limit`]).
    wg: u32,
    limit: u32,
    /// Whether the device is a software adapter (llvmpipe).
    software: bool,
    /// The device buffers of the last chunks, reused by the next chunks and calls
    /// ([`Kept`]).
    kept: std::sync::Mutex<Kept>,
    /// The last hierarchy's trig and grooves' tables ([`MultigridPipeline::tables`]).
    tables: std::sync::Mutex<Option<Tables>>,
}

/// A hierarchy's trig and grooves' tables on the device, with what they were built from.
struct Tables {
    dims: Vec<Dims>,
    grid: FiniteGrid,
    trig: wgpu::Buffer,
    geo: wgpu::Buffer,
}

/// Device buffers a pipeline keeps between chunks and calls, each grown to the largest
/// chunk yet (so at most one chunk's: [`scratch_budget`]): allocating them per chunk cost
/// ~5 ms a chunk on the H200 (session 40), as much as the kernel. Reuse gives the same
/// results: the kernel writes every array of a level of the scratch in its set-up before
/// reading it, reads a slot's field only for a warm start (uploaded for that chunk), and
/// the results are cleared on the device before each chunk.
#[derive(Default)]
struct Kept {
    params: Option<wgpu::Buffer>,
    jobs: Option<wgpu::Buffer>,
    fields: Option<wgpu::Buffer>,
    results: Option<wgpu::Buffer>,
    inlets: Option<wgpu::Buffer>,
    scratch: Option<wgpu::Buffer>,
    /// `MAP_READ` staging for the results (each round of dispatches) and the fields.
    results_read: Option<wgpu::Buffer>,
    fields_read: Option<wgpu::Buffer>,
}

/// `slot`'s buffer if it holds `bytes`, else a new one of `bytes` (the old one dropped
/// first, so that both are never held at once), kept in `slot`.
fn grown(
    slot: &mut Option<wgpu::Buffer>,
    device: &wgpu::Device,
    label: &str,
    bytes: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let bytes = bytes.max(8);
    if let Some(b) = slot.as_ref().filter(|b| b.size() >= bytes) {
        return b.clone();
    }
    *slot = None;
    let b = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage,
        mapped_at_creation: false,
    });
    *slot = Some(b.clone());
    b
}

/// One dispatch group: jobs (indices into the call) sharing a hierarchy.
struct Group<'a> {
    dims: &'a [Dims],
    top0: usize,
    /// Levels used in this pass (`dims[..n_levels]`).
    n_levels: usize,
    /// Levels within the device's range (`dims[..range]`: those of the last pass), whose
    /// tables the passes share.
    range: usize,
    members: Vec<usize>,
}

impl MultigridPipeline {
    /// Compiles the kernel; a validation error is returned, not raised.
    pub(crate) fn new(device: &wgpu::Device) -> Result<Self, BackendError> {
        // Diagnostics: a kernel source from a file (experiments without a rebuild).
        let source = std::env::var("BEARING_SWEEP_MG_WGSL")
            .ok()
            .and_then(|path| std::fs::read_to_string(path).ok());
        let wg = workgroup_size(device);
        let source = kernel_source(source.as_deref().unwrap_or(FINITE_MG_WGSL), wg)?;
        let pipeline = compile_pipeline(
            device,
            "finite_mg.wgsl",
            &source,
            "finite film multigrid kernel",
            "the finite-film multigrid kernel",
        )?;
        let software = device.adapter_info().device_type == wgpu::DeviceType::Cpu;
        Ok(MultigridPipeline {
            pipeline,
            wg,
            limit: loop_limit(software),
            software,
            kept: std::sync::Mutex::new(Kept::default()),
            tables: std::sync::Mutex::new(None),
        })
    }

    /// Solves `jobs` on `grid` (fixed or accuracy mode, Swift–Stieber); `fields[k]` of the
    /// grid's length is job k's warm start on a fixed grid, and receives its solution if
    /// `fields_wanted` (otherwise it is left empty and no field is read back: the same
    /// loads and reports).
    ///
    /// Accuracy mode on a group too large for one chunk (with [`tiered`]): a first pass
    /// runs the ladder up to the largest grid at which the whole group fits one chunk
    /// (at least three grids, the first estimate); the states whose estimate is still
    /// above the accuracy there run again from scratch, on the largest ladder at which
    /// they fit one chunk (else on one grid more, in chunks), and so on, until the rest
    /// fits one chunk of the whole ladder or the whole ladder is reached (in chunks).
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
        out.clear();
        out.resize(jobs.len(), [f64::NAN; 4]);
        reports.clear();
        reports.resize(jobs.len(), SolveReport::default());
        // Group by hierarchy (first appearance order).
        let mut keys: Vec<(Vec<Dims>, usize)> = Vec::new();
        let mut member_of: Vec<usize> = Vec::with_capacity(jobs.len());
        for job in jobs {
            let h = hierarchy(grid, job.aspect);
            if h.0.len() > MAX_LEVELS || h.0.len() - h.1 > MAX_RUNGS {
                return Err(BackendError::Device(format!(
                    "the finite-film multigrid kernel holds {MAX_LEVELS} levels; this grid \
                     needs {}",
                    h.0.len()
                )));
            }
            let g = match keys.iter().position(|k| *k == h) {
                Some(g) => g,
                None => {
                    keys.push(h);
                    keys.len() - 1
                }
            };
            member_of.push(g);
        }
        let max_nodes = device_max_nodes();
        if grid.accuracy.is_none() && grid.n_theta * (grid.n_z + 1) > max_nodes {
            return Err(BackendError::Device(format!(
                "finite grid {}×{} is beyond the multigrid kernel's range ({max_nodes} \
                 nodes: src/backend/finite_mg.rs \"Range\")",
                grid.n_theta, grid.n_z
            )));
        }
        let mut on_cpu = Vec::new();
        for (g, (dims, top0)) in keys.iter().enumerate() {
            let members: Vec<usize> = (0..jobs.len()).filter(|&k| member_of[k] == g).collect();
            // The levels within the range (accuracy mode: the ladder up to there).
            let mut n_levels = dims.len();
            while n_levels > 0 && full(&dims[n_levels - 1]) > max_nodes {
                n_levels -= 1;
            }
            if n_levels <= *top0 {
                on_cpu.extend(members);
                continue;
            }
            let budget = scratch_budget(self.software);
            let limits = device.limits();
            let mut members = members;
            // Passes on the lower ladder while the group does not fit one chunk: each to
            // the largest grid at which all its states do, else (in chunks) to the next
            // grid, beyond the pass before (the first at least three grids, the first
            // estimate).
            let mut reached = *top0 + 2;
            while grid.accuracy.is_some()
                && tiered(self.software)
                && !members.is_empty()
                && chunk_slots(&dims[..n_levels], budget, &limits) < members.len()
            {
                let fits = (reached + 1..n_levels)
                    .rev()
                    .find(|&m| chunk_slots(&dims[..m], budget, &limits) >= members.len());
                let m = match fits {
                    Some(m) => m,
                    None if reached + 1 < n_levels => reached + 1,
                    None => break,
                };
                let pass = Group {
                    dims,
                    top0: *top0,
                    n_levels: m,
                    range: n_levels,
                    members,
                };
                members = self.dispatch_group(
                    device,
                    queue,
                    timeout,
                    jobs,
                    grid,
                    &pass,
                    fields,
                    fields_wanted,
                    out,
                    reports,
                )?;
                reached = m;
                if std::env::var_os("BEARING_SWEEP_MG_TRACE").is_some() {
                    let (t, z, _) = dims[m - 1];
                    eprintln!(
                        "mg pass to {t}×{z} of {} states: {} run again on a larger ladder",
                        pass.members.len(),
                        members.len()
                    );
                }
            }
            if members.is_empty() {
                continue;
            }
            let group = Group {
                dims,
                top0: *top0,
                n_levels,
                range: n_levels,
                members,
            };
            on_cpu.extend(self.dispatch_group(
                device,
                queue,
                timeout,
                jobs,
                grid,
                &group,
                fields,
                fields_wanted,
                out,
                reports,
            )?);
        }
        if !on_cpu.is_empty() {
            // Beyond the device's grids: the CPU solver, from scratch (as a CPU run).
            use rayon::prelude::*;
            let solved: Vec<(usize, FilmIntegrals, SolveReport, Vec<f64>)> = on_cpu
                .par_iter()
                .map_init(crate::bearing::finite::FiniteSolver::new, |solver, &k| {
                    let mut f = Vec::new();
                    let (v, r) = solver.solve(&jobs[k], grid, &mut f);
                    (k, v, r, f)
                })
                .collect();
            for (k, v, r, f) in solved {
                out[k] = v;
                reports[k] = r;
                fields[k] = if fields_wanted { f } else { Vec::new() };
            }
        }
        Ok(())
    }

    /// The kernel's trig table (cos, sin at half steps per level) and grooves' table (face
    /// factors and held pressures per node of each level; one zero without grooves) of the
    /// whole hierarchy `dims` on `grid`'s layout, kept while they stay the same (every pass
    /// and call of a sweep): a pass's level table indexes their first levels, at the same
    /// offsets as the whole hierarchy's.
    fn tables(
        &self,
        device: &wgpu::Device,
        dims: &[Dims],
        grid: &FiniteGrid,
    ) -> Result<(wgpu::Buffer, wgpu::Buffer), BackendError> {
        let mut kept = self
            .tables
            .lock()
            .map_err(|_| BackendError::Device("finite-film multigrid tables lock".into()))?;
        if let Some(t) = kept.as_ref().filter(|t| t.dims == dims && t.grid == *grid) {
            return Ok((t.trig.clone(), t.geo.clone()));
        }
        let banded = !grid.layout.is_empty();
        let mut trig: Vec<f64> = Vec::new();
        let mut geo: Vec<f64> = Vec::new();
        for d in dims {
            let dt = 2.0 * PI / d.0 as f64;
            for k in 0..2 * d.0 {
                let th = 0.5 * dt * k as f64;
                trig.push(th.cos());
                trig.push(th.sin());
            }
            if banded {
                // Grooves and arcs replace the inlet line: node 0 at angle 0.
                let held = grid.layout.held_nodes(d.0, d.1, 0.0);
                for k in 0..full(d) {
                    geo.extend_from_slice(&[held.east[k], held.north[k], held.held_pa[k]]);
                }
            }
        }
        if geo.is_empty() {
            geo.push(0.0);
        }
        let trig = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("finite mg trig"),
            contents: bytemuck::cast_slice(&trig),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let geo = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("finite mg grooves"),
            contents: bytemuck::cast_slice(&geo),
            usage: wgpu::BufferUsages::STORAGE,
        });
        *kept = Some(Tables {
            dims: dims.to_vec(),
            grid: *grid,
            trig: trig.clone(),
            geo: geo.clone(),
        });
        Ok((trig, geo))
    }

    /// Dispatches one group in chunks; returns the members that need more grids.
    #[allow(clippy::too_many_arguments)]
    fn dispatch_group(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        group: &Group,
        fields: &mut [Vec<f64>],
        fields_wanted: bool,
        out: &mut [FilmIntegrals],
        reports: &mut [SolveReport],
    ) -> Result<Vec<usize>, BackendError> {
        let dims = &group.dims[..group.n_levels];
        let accuracy = grid.accuracy.is_some();
        // Level table: scratch offsets, trig offsets, geo offsets, inlet offsets.
        let mut lv = [[0u32; 4]; MAX_LEVELS];
        let mut lw = [[0u32; 4]; MAX_LEVELS];
        let (mut so, mut to, mut go, mut io) = (0usize, 0usize, 0usize, 0usize);
        let banded = !grid.layout.is_empty();
        for (l, d) in dims.iter().enumerate() {
            let coarsen = match d.2 {
                None => 0,
                Some(Coarsen::Both) => 1,
                Some(Coarsen::Theta) => 2,
                Some(Coarsen::Zeta) => 3,
            };
            lv[l] = [d.0 as u32, d.1 as u32, coarsen, so as u32];
            lw[l] = [to as u32, go as u32, io as u32, 0];
            so += ARRAYS * full(d);
            to += 4 * d.0;
            if banded {
                go += 3 * full(d);
            }
            io += d.1 + 1;
        }
        let (trig_buf, geo_buf) = self.tables(device, &group.dims[..group.range], grid)?;
        let (stride, field_stride) = slot_strides(dims);
        debug_assert_eq!(stride, so);
        let inlet_stride = io;
        let slots = chunk_slots(dims, scratch_budget(self.software), &device.limits());
        if slots == 0 {
            return Err(BackendError::Device(format!(
                "the finite-film multigrid needs {} MiB per state, more than the device's \
                 buffer limit",
                (stride * 8) >> 20
            )));
        }
        // The first ladder grid (and its full-multigrid levels) to accuracy/10, the grids
        // after it by the CPU's rule (`ladder_rule`).
        let stop_tol = match grid.accuracy {
            Some(target) => (ALGEBRAIC_FRACTION * target).max(grid.tolerance),
            None => grid.tolerance,
        };
        let rule = ladder_rule(banded);
        let floor = match grid.accuracy {
            Some(target) => (rule.floor * target).max(grid.tolerance),
            None => grid.tolerance,
        };
        let (budget, cap_dispatches) = loop_budget(dims, self.wg as usize, self.limit)?;
        let mut redo = Vec::new();
        for chunk in group.members.chunks(slots) {
            let n = chunk.len();
            let mut job_data = Vec::with_capacity(n * JOB_STRIDE);
            let mut inlets = vec![NO_INLET; n * inlet_stride];
            let mut field_data = vec![0.0_f64; n * field_stride];
            for (s, &k) in chunk.iter().enumerate() {
                let job = &jobs[k];
                let e = &job.state.ecc;
                // Node 0 on the mid-plane's maximum film on the ladder; 0 on explicit grids.
                let theta0 = solution_theta0(job, grid);
                let warm = !accuracy
                    && fields[k].len() == field_stride
                    && fields[k].iter().all(|v| v.is_finite() && *v >= 0.0);
                if warm {
                    field_data[s * field_stride..(s + 1) * field_stride]
                        .copy_from_slice(&fields[k]);
                }
                let coarsest = FiniteGrid {
                    n_theta: dims[0].0,
                    n_z: dims[0].1,
                    accuracy: None,
                    ..*grid
                };
                job_data.extend_from_slice(e);
                job_data.extend_from_slice(&job.state.rate);
                job_data.extend_from_slice(&[
                    job.aspect,
                    job.supply,
                    coarsest.relaxation(job.aspect),
                    theta0,
                    theta0.cos(),
                    theta0.sin(),
                    if warm { 1.0 } else { 0.0 },
                    0.0,
                ]);
                if grid.max_film_inlet {
                    // The column nearest the maximum film per row (multigrid.rs
                    // Level::setup), per level.
                    for (l, d) in dims.iter().enumerate() {
                        let (nt, nz) = (d.0, d.1);
                        let dt = 2.0 * PI / nt as f64;
                        let dz = 1.0 / nz as f64;
                        for j in 1..nz {
                            let zeta = j as f64 * dz;
                            let ex = e[0] + (e[2] - e[0]) * zeta;
                            let ey = e[1] + (e[3] - e[1]) * zeta;
                            if ex != 0.0 || ey != 0.0 {
                                let th = ((-ey).atan2(-ex) - theta0).rem_euclid(2.0 * PI);
                                let i = (th / dt).round() as usize % nt;
                                inlets[s * inlet_stride + lw[l][2] as usize + j] = i as u32;
                            }
                        }
                    }
                }
            }
            let params = Params {
                count: n as u32,
                n_levels: dims.len() as u32,
                top0: group.top0 as u32,
                mode: u32::from(accuracy),
                stride: stride as u32,
                inlet_stride: inlet_stride as u32,
                field_stride: field_stride as u32,
                banded: u32::from(banded),
                more: u32::from(group.n_levels < group.dims.len()),
                max_cycles: MAX_CYCLES,
                budget,
                limit: self.limit,
                cubic_start: u32::from(rule.cubic_start),
                pad: [0; 3],
                tolerance: stop_tol,
                target: grid.accuracy.unwrap_or(0.0),
                floor,
                loose: rule.loose,
                lv,
                lw,
            };
            let any_warm = job_data.chunks(JOB_STRIDE).any(|j| j[14] > 0.5);
            let (fv, rv) = self.dispatch(
                device,
                queue,
                timeout,
                &params,
                &[&trig_buf, &geo_buf],
                &job_data,
                &inlets,
                any_warm.then_some(field_data.as_slice()),
                (n * stride * 8) as u64,
                cap_dispatches,
                fields_wanted,
            )?;
            for (s, &k) in chunk.iter().enumerate() {
                let r = &rv[s * OUT_STRIDE..(s + 1) * OUT_STRIDE];
                if r[OUT_STATE] == ST_MORE {
                    redo.push(k);
                    continue;
                }
                let (nt, nz) = (r[7] as usize, r[8] as usize);
                out[k] = [r[0], r[1], r[2], r[3]];
                fields[k].clear();
                if let Some(f) = fv.get(s) {
                    fields[k].extend_from_slice(f);
                }
                reports[k] = SolveReport {
                    sweeps: r[4] as u32,
                    iteration_error: r[5],
                    converged: r[6] > 0.5,
                    n_theta: nt as u32,
                    n_z: nz as u32,
                    error_estimate: if !accuracy {
                        0.0
                    } else if r[9] < 0.0 {
                        f64::INFINITY
                    } else {
                        r[9]
                    },
                    accuracy_met: r[10] > 0.5,
                };
            }
        }
        Ok(redo)
    }

    /// One chunk's solve: uploads, dispatches the resumable kernel until every slot's
    /// status is set (at most `cap_dispatches` dispatches), reads back the results and, if
    /// `fields_wanted`, each slot's field on its last grid (`n_theta × (n_z + 1)` values,
    /// the slot's result 7 and 8; not the whole stride of the ladder's largest grid; none
    /// without: an empty list). `field_data`: the warm starts (`None`: no slot has one;
    /// the kernel then reads no field). The buffers are the pipeline's [`Kept`] ones,
    /// written with `write_buffer`. A slot still running after the cap, or one whose
    /// dispatch overran the loop limit, is an error.
    #[allow(clippy::too_many_arguments)]
    fn dispatch(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        timeout: Duration,
        params: &Params,
        shared: &[&wgpu::Buffer; 2],
        job_data: &[f64],
        inlets: &[u32],
        field_data: Option<&[f64]>,
        scratch_bytes: u64,
        cap_dispatches: u32,
        fields_wanted: bool,
    ) -> Result<(Vec<Vec<f64>>, Vec<f64>), BackendError> {
        const WHAT: &str = "finite-film multigrid";
        let n = params.count as usize;
        let trace = std::env::var_os("BEARING_SWEEP_MG_TRACE").is_some();
        let started = std::time::Instant::now();
        // An empty inlet table (no max-film inlet) still needs a binding.
        let inl: &[u32] = if inlets.is_empty() {
            &[NO_INLET]
        } else {
            inlets
        };
        let field_bytes = (n * params.field_stride as usize * 8) as u64;
        let result_bytes = (n * OUT_STRIDE * 8) as u64;
        // Held to the end of the chunk: a second caller on this pipeline (none today: a
        // backend's pipelines serve its own `&mut self` calls) waits instead of sharing it.
        let mut kept = self
            .kept
            .lock()
            .map_err(|_| BackendError::Device("finite-film multigrid buffers lock".into()))?;
        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let st = wgpu::BufferUsages::STORAGE;
        let dst = wgpu::BufferUsages::COPY_DST;
        let src = wgpu::BufferUsages::COPY_SRC;
        let read = wgpu::BufferUsages::MAP_READ | dst;
        let k = &mut *kept;
        let params_buf = grown(
            &mut k.params,
            device,
            "finite mg params",
            std::mem::size_of::<Params>() as u64,
            wgpu::BufferUsages::UNIFORM | dst,
        );
        let jobs_buf = grown(
            &mut k.jobs,
            device,
            "finite mg jobs",
            (job_data.len() * 8) as u64,
            st | dst,
        );
        let fields_buf = grown(
            &mut k.fields,
            device,
            "finite mg fields",
            field_bytes,
            st | src | dst,
        );
        let results_buf = grown(
            &mut k.results,
            device,
            "finite mg results",
            result_bytes,
            st | src | dst,
        );
        let inlets_buf = grown(
            &mut k.inlets,
            device,
            "finite mg inlets",
            (inl.len() * 4) as u64,
            st | dst,
        );
        let scratch = grown(
            &mut k.scratch,
            device,
            "finite mg scratch",
            scratch_bytes,
            st,
        );
        let results_read = grown(
            &mut k.results_read,
            device,
            "finite mg results readback",
            result_bytes,
            read,
        );
        if let Some(e) = pollster::block_on(scope.pop()) {
            // Not kept: the next call allocates afresh.
            *k = Kept::default();
            return Err(BackendError::Device(format!(
                "allocating the finite-film multigrid's buffers for {n} states: {e}"
            )));
        }
        queue.write_buffer(&params_buf, 0, bytemuck::bytes_of(params));
        queue.write_buffer(&jobs_buf, 0, bytemuck::cast_slice(job_data));
        queue.write_buffer(&inlets_buf, 0, bytemuck::cast_slice(inl));
        if let Some(data) = field_data {
            queue.write_buffer(&fields_buf, 0, bytemuck::cast_slice(data));
        }
        // Every buffer lives across the dispatches (the solve's state is in them).
        let bufs = [
            &params_buf,
            shared[0],
            &jobs_buf,
            &fields_buf,
            &results_buf,
            &inlets_buf,
            shared[1],
            &scratch,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = bufs
            .iter()
            .enumerate()
            .map(|(b, buf)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buf.as_entire_binding(),
            })
            .collect();
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("finite mg bindings"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(BackendError::Device(format!(
                "binding the finite-film multigrid's buffers for {n} states: {e}"
            )));
        }
        let buffers_ms = started.elapsed().as_secs_f64() * 1e3;
        let mut dispatched = 0u32;
        let res = loop {
            // Results only, until every slot is done.
            let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
            let mut enc =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            if dispatched == 0 {
                // Zeros: every slot at its first phase, status running.
                enc.clear_buffer(&results_buf, 0, Some(result_bytes));
            }
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(WHAT),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                for _ in 0..REPEAT {
                    pass.dispatch_workgroups(n as u32, 1, 1);
                }
            }
            enc.copy_buffer_to_buffer(&results_buf, 0, &results_read, 0, result_bytes);
            let sub = queue.submit(Some(enc.finish()));
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(BackendError::Device(format!(
                    "dispatching {n} {WHAT} states: {e}"
                )));
            }
            let res = map_read(device, sub, &results_read, result_bytes, timeout, WHAT)?;
            dispatched += REPEAT;
            let status = |s: usize| res[s * OUT_STRIDE + OUT_STATE];
            if trace {
                // Diagnostics: per running state, phase, level, cycle, V-cycle step and
                // coarsest sweep after this round.
                let running: Vec<String> = (0..n)
                    .filter(|&s| status(s) == ST_RUN)
                    .map(|s| {
                        let r = &res[s * OUT_STRIDE + OUT_STATE..];
                        format!("{s}:{}/{}/{}/{}/{}", r[1], r[2], r[3], r[12], r[13])
                    })
                    .collect();
                eprintln!(
                    "mg dispatches {dispatched} ({:.3} ms, {n} states): running {} {}",
                    started.elapsed().as_secs_f64() * 1e3,
                    running.len(),
                    running[..running.len().min(8)].join(" ")
                );
            }
            let cut = |s: usize| res[s * OUT_STRIDE + OUT_COUNT] != res[s * OUT_STRIDE + OUT_BEGIN];
            if let Some(s) = (0..n).find(|&s| status(s) == ST_OVERRUN || cut(s)) {
                return Err(BackendError::Device(format!(
                    "the finite-film multigrid kernel ran past its loop limit ({} \
                     iterations per dispatch) on state {s} of {n}: its loads are void",
                    self.limit
                )));
            }
            if (0..n).all(|s| status(s) != ST_RUN) {
                break res;
            }
            if dispatched >= cap_dispatches {
                let s = (0..n).find(|&s| status(s) == ST_RUN).unwrap_or(0);
                return Err(BackendError::Device(format!(
                    "the finite-film multigrid kernel did not finish state {s} of {n} in \
                     {dispatched} dispatches (the cap for this grid: more work than its \
                     cycle limits allow, so it would not terminate)"
                )));
            }
        };
        let kernel_ms = started.elapsed().as_secs_f64() * 1e3 - buffers_ms;
        // Each slot's field on its last grid (none for a slot the host solves again).
        let stride = params.field_stride as u64;
        let ranges: Vec<(u64, u64)> = (0..n)
            .map(|s| {
                let r = &res[s * OUT_STRIDE..];
                let len = if !fields_wanted || r[OUT_STATE] == ST_MORE {
                    0
                } else {
                    (r[7] as u64 * (r[8] as u64 + 1)).min(stride)
                };
                (s as u64 * stride, len)
            })
            .collect();
        let total: u64 = ranges.iter().map(|r| r.1).sum();
        let flat = if total == 0 {
            Vec::new()
        } else {
            let staging = grown(
                &mut k.fields_read,
                device,
                "finite mg fields readback",
                total * 8,
                read,
            );
            let mut enc =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            let mut at = 0;
            for &(offset, len) in ranges.iter().filter(|r| r.1 > 0) {
                enc.copy_buffer_to_buffer(&fields_buf, offset * 8, &staging, at * 8, len * 8);
                at += len;
            }
            let sub = queue.submit(Some(enc.finish()));
            map_read(
                device,
                sub,
                &staging,
                total * 8,
                timeout,
                "finite-film multigrid fields",
            )?
        };
        let mut at = 0;
        let fields: Vec<Vec<f64>> = if fields_wanted {
            ranges
                .iter()
                .map(|&(_, len)| {
                    let f = flat[at..at + len as usize].to_vec();
                    at += len as usize;
                    f
                })
                .collect()
        } else {
            Vec::new()
        };
        if trace {
            eprintln!(
                "mg chunk of {n} states: buffers {buffers_ms:.3} ms, dispatches and status \
                 {kernel_ms:.3} ms ({dispatched} dispatches), fields read {:.3} ms ({} KiB of \
                 {} KiB{}), workgroup {}",
                started.elapsed().as_secs_f64() * 1e3 - buffers_ms - kernel_ms,
                flat.len() * 8 / 1024,
                field_bytes / 1024,
                if fields_wanted { "" } else { ", not wanted" },
                self.wg
            );
        }
        if std::env::var_os("BEARING_SWEEP_MG_COUNT").is_some() {
            keep_tally(&res, n);
        }
        drop(kept);
        Ok((fields, res))
    }
}

/// Diagnostics (`BEARING_SWEEP_MG_COUNT`): the kernel's tally of the states solved since
/// the last [`take_tally`], one row of [`TALLY_NAMES`] per state.
static TALLY: std::sync::Mutex<Vec<Vec<f64>>> = std::sync::Mutex::new(Vec::new());

/// Diagnostics: the tally rows collected under `BEARING_SWEEP_MG_COUNT` (emptied), with the
/// counters' names; each row's counts are per state, summed over its dispatches.
pub fn take_tally() -> (Vec<&'static str>, Vec<Vec<f64>>) {
    let rows = TALLY
        .lock()
        .map(|mut t| std::mem::take(&mut *t))
        .unwrap_or_default();
    (TALLY_NAMES.to_vec(), rows)
}

/// Keeps the tally of a chunk's `n` states (`res`: their result blocks).
fn keep_tally(res: &[f64], n: usize) {
    if let Ok(mut t) = TALLY.lock() {
        for s in 0..n {
            let o = s * OUT_STRIDE + OUT_TALLY;
            t.push(res[o..o + TALLY_NAMES.len()].to_vec());
        }
    }
}

/// How the kernel's ladder iterates its grids after the first: the CPU's rule for the
/// ladder it runs (src/bearing/finite/solver.rs `FiniteSolver::solve_accuracy`): the plain
/// 360° film's Simpson-summed ladder [`LadderRule::default`], grooves and arcs every grid
/// to [`ALGEBRAIC_FRACTION`] of the accuracy from the bilinear start (the rule before
/// session 36, which the CPU keeps for them). Diagnostics: the environment variable
/// `BEARING_SWEEP_MG_LADDER_RULE=LOOSE,cubic|linear,FLOOR` (examples/zeta_probe.rs's form)
/// replaces the plain film's rule (`0,linear,0.1`: the kernel before session 37, bit for
/// bit); an unparsable value keeps the default.
fn ladder_rule(banded: bool) -> LadderRule {
    if banded {
        return LadderRule {
            loose: 0.0,
            cubic_start: false,
            floor: ALGEBRAIC_FRACTION,
        };
    }
    std::env::var("BEARING_SWEEP_MG_LADDER_RULE")
        .ok()
        .and_then(|v| parse_rule(&v))
        .unwrap_or_default()
}

/// `LOOSE,cubic|linear,FLOOR` as a [`LadderRule`] (`None` if malformed).
fn parse_rule(v: &str) -> Option<LadderRule> {
    let parts: Vec<&str> = v.trim().split(',').map(str::trim).collect();
    let [loose, start, floor] = parts.as_slice() else {
        return None;
    };
    let cubic_start = match *start {
        "cubic" => true,
        "linear" => false,
        _ => return None,
    };
    let (loose, floor) = (loose.parse::<f64>().ok()?, floor.parse::<f64>().ok()?);
    (loose >= 0.0 && floor > 0.0).then_some(LadderRule {
        loose,
        cubic_start,
        floor,
    })
}

/// Loop iterations of a strided loop over `n` nodes for the kernel's invocation 0
/// (`loops`).
fn loops(n: usize, wg: usize) -> usize {
    n.div_ceil(wg) + 1
}

/// The kernel's per-dispatch budget for a hierarchy and the cap on dispatches of a state.
///
/// Budget: the dispatch starts no further step once it has counted this many loop
/// iterations, so it stays within [`LOOP_LIMIT`] if no step costs more than
/// `LOOP_LIMIT − budget − SERIAL_RESERVE`. The largest step is on the largest level (a
/// strided loop of `I = loops(nodes)` iterations): the entry into a level (right-hand
/// side, the freezes of the levels below with the inlet line's walks, the loads: ≲ 8 I),
/// the descent (two sweeps, residual, restriction: ≲ 4 I) or the set-up and prolongation
/// of a ladder grid with its cubic rows in ζ (≲ 3.5 I); 12 I + 400 bounds them all. A grid whose step leaves less
/// than 2 000 iterations of budget (about 375 000 nodes) is beyond the kernel.
///
/// Cap: an upper bound on the dispatches a state needs, from the kernel's own limits
/// (every level iterated to `MAX_CYCLES` V-cycles, every coarsest solve to
/// `COARSEST_SWEEPS` sweeps of ~20 iterations): twice the work bound over what a dispatch
/// that does not finish does at least. A state not done then does not terminate (a
/// defect): an error, not loads. (Far above what states need: at 1024 × 128 the cap is
/// thousands of dispatches, a state needs tens.)
fn loop_budget(dims: &[Dims], wg: usize, limit: u32) -> Result<(u32, u32), BackendError> {
    let loops = |n| loops(n, wg);
    let largest = dims.iter().map(full).max().unwrap_or(0);
    let step = 12 * loops(largest) + 400;
    let free = (limit - SERIAL_RESERVE) as usize;
    if step + 2_000 > free {
        return Err(BackendError::Device(format!(
            "the finite-film multigrid kernel solves grids of at most ~375 000 nodes \
             (one step of its largest level within a dispatch's loop limit); this one has \
             {largest}"
        )));
    }
    let budget = free - step;
    // Diagnostics: a smaller budget (loop iterations) from the environment.
    let budget = std::env::var("BEARING_SWEEP_MG_BUDGET")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .map_or(budget, |b| b.clamp(1_000, budget));
    // Coarsest solve: up to 4000 sweeps of ≲ 90 loop iterations at any workgroup size
    // (multigrid.rs COARSEST_SWEEPS; the sweep, its reduction's two rounds of fan-in, the
    // history: `coarsest_step`).
    let coarsest = 4_000 * 90;
    let cycle: usize = dims.iter().map(|d| 16 * loops(full(d))).sum::<usize>() + coarsest;
    let levels = dims.len();
    let work = levels * (MAX_CYCLES as usize * cycle + 16 * loops(largest));
    // A dispatch that does not finish its state runs at least `budget` less its start
    // (~250 iterations) of the state's work.
    let cap = (2 * work / (budget - 250) + 2 * REPEAT as usize).min(u32::MAX as usize / 2) as u32;
    Ok((budget as u32, cap))
}
