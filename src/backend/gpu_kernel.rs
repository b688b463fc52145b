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
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            precision: None,
            max_chunk: None,
            timeout: DEFAULT_TIMEOUT,
            profile: false,
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
