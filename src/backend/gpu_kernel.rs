//! What the GPU backend is built from and reports, independent of any device: the WGSL
//! kernel source and its f32 variant, the build options, the timing record and the
//! agreement measure. Compiled with or without the `gpu` feature (the shader is validated
//! by naga in `cargo test` either way).

use std::time::Duration;

use super::{BackendError, Precision};
use crate::bearing::FilmIntegrals;

/// The kernel's WGSL source as shipped (f64).
pub const KERNEL_WGSL: &str = include_str!("../../shaders/film.wgsl");

/// The finite-film kernel's WGSL source.
pub const FINITE_WGSL: &str = include_str!("../../shaders/finite.wgsl");

/// Largest interior field `n_theta × (n_z − 1)` the finite-film kernel holds in workgroup
/// memory (`MAX_NODES` in the shader).
pub const FINITE_MAX_NODES: usize = 1664;

/// Default wait for one chunk before the device counts as hung: generous for 2^20
/// states on a software rasteriser (~2 s on 2 cores), far below any watchdog.
const DEFAULT_TIMEOUT: Duration = Duration::from_secs(120);

/// The f32 replacement of the shader's precision block: same names, tolerances scaled to
/// f32 rounding (6e-8).
const F32_PRECISION_BLOCK: &str = "alias real = f32;
// Durand-Kerner stops when no root moves more than this (relative): ~30 ulp of f32.
const ROOT_TOL: real = 2e-6;
// Leading quartic terms below this fraction of the polynomial at |t| = 2 are dropped.
const DROP_TOL: real = 1e-6;
// The poles are kept at least 2 ulp of 1.0 outside [0, 1].
const POLE_PAD: real = 2.4e-7;
";

const BEGIN_MARK: &str = "// BEGIN PRECISION\n";
const END_MARK: &str = "// END PRECISION\n";

/// The kernel source for `precision` (the shipped f64 kernel with its precision block
/// swapped for f32 when asked).
pub fn kernel_source(precision: Precision) -> String {
    match precision {
        Precision::F64 => KERNEL_WGSL.to_string(),
        Precision::F32 => {
            let begin = KERNEL_WGSL
                .find(BEGIN_MARK)
                .expect("film.wgsl has a BEGIN PRECISION marker")
                + BEGIN_MARK.len();
            let end = KERNEL_WGSL
                .find(END_MARK)
                .expect("film.wgsl has an END PRECISION marker");
            format!(
                "{}{}{}",
                &KERNEL_WGSL[..begin],
                F32_PRECISION_BLOCK,
                &KERNEL_WGSL[end..]
            )
        }
    }
}

/// The shader's lane-count line, swapped by [`kernel_source_lanes`].
const LANES_LINE: &str = "const LANES: u32 = 1u;\n";

/// Invocations per workgroup of the short-film kernel (`WG_SIZE` in the shader): the
/// largest lane count.
pub const KERNEL_WORKGROUP_SIZE: u32 = 64;

/// Lanes per state on a hardware GPU unless told otherwise ([`GpuOptions::lanes`]). On the
/// H200 (reports/h200/raw/kernel-early/, BENCHMARKS.md "Issue 26, kernel pass") the kernel
/// alone at 1 450 states (a sweep's dispatch) took 0.58 ms with 1 lane, 0.24 ms with 4 and
/// 0.13 ms with 16, at 1e6 states it did 1.4e8, 1.07e8 and 5.4e7 states/s; the sweep's
/// dispatches cost ~0.23-0.25 ms whatever the lanes (fixed overhead). 4 keeps three
/// quarters of the large-batch rate and most of the small-batch gain.
pub const HARDWARE_DEFAULT_LANES: u32 = 4;

/// Dispatch slots on a hardware GPU unless told otherwise ([`GpuOptions::slots`]): one. A
/// second slot on the H200 did not overlap the round trips (still ~0.24 ms per dispatch)
/// and split the merged batches (30 000 dispatches of ~970 states instead of 20 000 of
/// ~1 460): the 4 096-variant sweep took 7.7 s instead of 5.5-5.8 s.
pub const HARDWARE_DEFAULT_SLOTS: usize = 1;

/// Most dispatch slots accepted ([`GpuOptions::slots`]): each holds its own buffers.
pub const MAX_SLOTS: usize = 8;

/// Checks a lane count: a power of two from 1 to [`KERNEL_WORKGROUP_SIZE`].
pub fn check_lanes(lanes: u32) -> Result<u32, BackendError> {
    if lanes.is_power_of_two() && lanes <= KERNEL_WORKGROUP_SIZE {
        Ok(lanes)
    } else {
        Err(BackendError::NoAdapter(format!(
            "{lanes} lanes per state (expected a power of two from 1 to {KERNEL_WORKGROUP_SIZE})"
        )))
    }
}

/// The kernel source for `precision` with `lanes` invocations per state (a power of two
/// up to [`KERNEL_WORKGROUP_SIZE`]; 1 is the shipped source).
pub fn kernel_source_lanes(precision: Precision, lanes: u32) -> Result<String, BackendError> {
    let lanes = check_lanes(lanes)?;
    let src = kernel_source(precision);
    assert!(
        src.contains(LANES_LINE),
        "film.wgsl declares `{LANES_LINE}`"
    );
    Ok(src.replacen(LANES_LINE, &format!("const LANES: u32 = {lanes}u;\n"), 1))
}

/// How to build a [`GpuBackend`].
#[derive(Clone, Debug, PartialEq)]
pub struct GpuOptions {
    /// Precision to use: `None` picks f64 where offered, else f32; `Some(F64)` fails on
    /// an adapter without `SHADER_F64`.
    pub precision: Option<Precision>,
    /// Most states per dispatch (`None`: 2^20, capped by the device's limits).
    pub max_chunk: Option<usize>,
    /// Wait for one chunk before the device counts as hung.
    pub timeout: Duration,
    /// Time the kernel separately from the transfers (an extra wait per chunk; uses
    /// timestamp queries where the adapter has them).
    pub profile: bool,
    /// Invocations per state of the short-film kernel (a power of two up to 64): `None`
    /// picks 1 on a software rasteriser (lavapipe: every lane repeats the state's root
    /// search on the same cores) and [`HARDWARE_DEFAULT_LANES`] on a hardware GPU. Results differ
    /// between lane counts by rounding only (the slices' sum is associated differently);
    /// a backend keeps its count for every dispatch, so merged dispatches stay
    /// reproducible.
    pub lanes: Option<u32>,
    /// Dispatches a shared dispatcher keeps in flight at once (1 to 8), each slot with its
    /// own buffers on the device: `None` picks 1 on a software rasteriser (it computes on
    /// the host's cores, which the host threads need) and [`HARDWARE_DEFAULT_SLOTS`] (also
    /// 1) on a hardware GPU.
    pub slots: Option<usize>,
    /// Wait for a dispatch by polling the device in a loop (one host core busy while a
    /// dispatch is in flight) instead of blocking on its fence: `None` or `Some(false)`
    /// block. An experiment against the fence's wake-up latency on hardware GPUs
    /// (`BEARING_SWEEP_GPU_WAIT=spin`).
    pub spin_wait: Option<bool>,
    /// Merge policy of a shared dispatcher: `Some((m, linger))` lets the requester that
    /// finds the device free wait up to `linger` until `m` requests (at most as many as
    /// joined the previous dispatch) have joined its batch, so that fewer, larger
    /// dispatches pay the round trip's fixed cost; `None` (default) dispatches at once.
    /// An experiment (`BEARING_SWEEP_GPU_MERGE=m:microseconds`).
    pub merge: Option<(usize, Duration)>,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            precision: None,
            max_chunk: None,
            timeout: DEFAULT_TIMEOUT,
            profile: false,
            lanes: None,
            slots: None,
            spin_wait: None,
            merge: None,
        }
    }
}

impl GpuOptions {
    /// Defaults overridden by `BEARING_SWEEP_GPU_PRECISION` (`f32` or `f64`).
    pub fn from_env() -> Result<Self, BackendError> {
        let mut o = GpuOptions::default();
        if let Ok(p) = std::env::var("BEARING_SWEEP_GPU_PRECISION") {
            o.precision = match p.trim().to_lowercase().as_str() {
                "f32" => Some(Precision::F32),
                "f64" => Some(Precision::F64),
                "" | "auto" => None,
                other => {
                    return Err(BackendError::NoAdapter(format!(
                        "BEARING_SWEEP_GPU_PRECISION=`{other}` (expected f32, f64 or auto)"
                    )))
                }
            };
        }
        if let Ok(l) = std::env::var("BEARING_SWEEP_GPU_LANES") {
            let l = l.trim();
            o.lanes = match l {
                "" | "auto" => None,
                _ => Some(
                    l.parse::<u32>()
                        .map_err(|_| {
                            BackendError::NoAdapter(format!(
                                "BEARING_SWEEP_GPU_LANES=`{l}` (expected auto or a power of \
                                 two from 1 to {KERNEL_WORKGROUP_SIZE})"
                            ))
                        })
                        .and_then(check_lanes)?,
                ),
            };
        }
        if let Ok(v) = std::env::var("BEARING_SWEEP_GPU_WAIT") {
            o.spin_wait = match v.trim() {
                "" | "block" => None,
                "spin" => Some(true),
                other => {
                    return Err(BackendError::NoAdapter(format!(
                        "BEARING_SWEEP_GPU_WAIT=`{other}` (expected block or spin)"
                    )))
                }
            };
        }
        if let Ok(v) = std::env::var("BEARING_SWEEP_GPU_MERGE") {
            let v = v.trim();
            o.merge = match v {
                "" | "off" => None,
                _ => {
                    let parsed = v.split_once(':').and_then(|(m, us)| {
                        Some((
                            m.trim().parse::<usize>().ok()?,
                            us.trim().parse::<u64>().ok()?,
                        ))
                    });
                    match parsed {
                        Some((m, us)) if m >= 1 && us <= 1_000_000 => {
                            Some((m, Duration::from_micros(us)))
                        }
                        _ => {
                            return Err(BackendError::NoAdapter(format!(
                                "BEARING_SWEEP_GPU_MERGE=`{v}` (expected off or \
                                 REQUESTS:MICROSECONDS, e.g. 12:200, at most 1 s)"
                            )))
                        }
                    }
                }
            };
        }
        if let Ok(v) = std::env::var("BEARING_SWEEP_GPU_SLOTS") {
            let v = v.trim();
            o.slots = match v {
                "" | "auto" => None,
                _ => match v.parse::<usize>() {
                    Ok(n) if (1..=MAX_SLOTS).contains(&n) => Some(n),
                    _ => {
                        return Err(BackendError::NoAdapter(format!(
                            "BEARING_SWEEP_GPU_SLOTS=`{v}` (expected auto or 1 to {MAX_SLOTS})"
                        )))
                    }
                },
            };
        }
        Ok(o)
    }
}

/// Time spent in the last [`FilmBackend::integrate`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct GpuTiming {
    /// Chunks (dispatches) the call took.
    pub chunks: u32,
    /// Whole call, seconds: packing, upload, kernel, readback, conversion.
    pub total_s: f64,
    /// Submit-to-completion wall time of the dispatches alone (profiling only), s.
    pub kernel_wall_s: Option<f64>,
    /// Device time of the dispatches from timestamp queries (profiling only), s.
    pub kernel_device_s: Option<f64>,
}

/// Relative difference of two integral vectors (Euclidean norms), the measure in which
/// backends must agree.
pub fn relative_difference(a: &FilmIntegrals, b: &FilmIntegrals) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let n: f64 = b.iter().map(|x| x * x).sum();
    if n == 0.0 {
        d.sqrt()
    } else {
        (d / n).sqrt()
    }
}
