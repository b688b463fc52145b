//! Batched film-load evaluation: one interface over the CPU and GPU kernels, and the
//! evaluator that validates, packs, dispatches, falls back and finishes loads.

pub mod bench;
mod cpu;
mod evaluator;
mod finite;
mod gpu;

pub use cpu::CpuBackend;
pub use evaluator::{
    EvalStats, EvaluatorOptions, LoadEvaluator, LoadRequest, LoadResult, DEFAULT_CPU_BELOW,
};
pub use finite::effective_model;
pub use gpu::{kernel_source, relative_difference, GpuBackend, GpuOptions, GpuTiming, KERNEL_WGSL};

use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::{Accuracy, FilmIntegrals, PackedState, RuleSettings};

/// Which backend a user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendKind {
    /// The CPU kernel on all cores (the reference).
    Cpu,
    /// The WGSL kernel through wgpu; an error when no adapter exists.
    Gpu,
    /// The GPU when an adapter exists, else the CPU with a one-line notice.
    #[default]
    Auto,
}

impl std::str::FromStr for BackendKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cpu" => Ok(BackendKind::Cpu),
            "gpu" => Ok(BackendKind::Gpu),
            "auto" => Ok(BackendKind::Auto),
            other => Err(format!(
                "unknown backend `{other}` (expected cpu, gpu or auto)"
            )),
        }
    }
}

/// Floating-point precision a backend computes in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// IEEE double.
    F64,
    /// IEEE single, on nondimensional variables.
    F32,
}

/// What a backend is, for reports.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BackendInfo {
    /// `"cpu"` or `"gpu"`.
    pub name: String,
    /// Device description (CPU thread count, or the adapter's name and driver).
    pub device: String,
    /// Arithmetic precision of the kernel.
    pub precision: Precision,
}

/// A backend failure (the whole call, not one state).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BackendError {
    /// `gpu` was asked for and no adapter exists.
    #[error("no GPU adapter found ({0}); use --backend cpu or auto")]
    NoAdapter(String),
    /// The device was lost, ran out of memory or timed out.
    #[error("GPU device failure: {0}")]
    Device(String),
}

/// A kernel that turns packed states into film integrals, in order. Implementations
/// build their resources once and reuse them across calls.
pub trait FilmBackend: Send {
    /// Name, device and precision.
    fn info(&self) -> BackendInfo;
    /// The rule's parameters (identical across backends at one accuracy).
    fn settings(&self) -> RuleSettings;
    /// Integrals of every state, written to `out` (resized to `states.len()`).
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError>;

    /// Finite-length film integrals of every job on `grid` (docs/finite-film.md), in
    /// order. `fields[k]` is job k's warm start (a vector of another length: cold start)
    /// and receives its converged field; `reports` one solve report per job. The default
    /// is the CPU solver on rayon's global pool.
    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        finite::cpu_integrate_finite(jobs, grid, fields, out, reports, true);
        Ok(())
    }
}

/// Below this requested accuracy an f32 kernel cannot keep its promise (its rounding
/// error reaches ~1e-5 near the wall); `gpu` and `auto` then say so.
const F32_ACCURACY_FLOOR: f64 = 1e-5;

/// Creates the backend of `kind` at `accuracy`. Returns the backend and, for `auto`
/// falling back to the CPU (or a GPU limited to f32), the one-line notice to show the user.
/// The GPU adapter follows `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`, its precision
/// `BEARING_SWEEP_GPU_PRECISION` (see [`GpuOptions::from_env`]). `auto` passes over a
/// software adapter (lavapipe: the same CPU, no faster than the CPU backend) unless
/// `WGPU_ADAPTER_NAME` names it.
pub fn create_backend(
    kind: BackendKind,
    accuracy: Accuracy,
) -> Result<(Box<dyn FilmBackend>, Option<String>), BackendError> {
    if kind == BackendKind::Cpu {
        return Ok((Box::new(CpuBackend::new(accuracy, None)), None));
    }
    let cpu_instead = |why: String| -> (Box<dyn FilmBackend>, Option<String>) {
        (
            Box::new(CpuBackend::new(accuracy, None)),
            Some(format!("notice: {why}; using the CPU backend")),
        )
    };
    let gpu = GpuOptions::from_env().and_then(|o| GpuBackend::new(accuracy, o));
    match gpu {
        Ok(g)
            if kind == BackendKind::Auto
                && g.is_software()
                && std::env::var_os("WGPU_ADAPTER_NAME").is_none() =>
        {
            Ok(cpu_instead(format!(
                "the only GPU adapter is the software rasteriser `{}` (use --backend gpu to \
                 run on it)",
                g.info().device
            )))
        }
        Ok(mut g) => {
            let mut notice = g.take_notice();
            if g.precision() == Precision::F32 && accuracy.rtol() < F32_ACCURACY_FLOOR {
                let n = format!(
                    "notice: the GPU kernel runs in f32 (agreement with f64 ~1e-5), looser than \
                     the requested accuracy {:e}",
                    accuracy.rtol()
                );
                notice = Some(match notice {
                    Some(prev) => format!("{prev}\n{n}"),
                    None => n,
                });
            }
            Ok((Box::new(g), notice))
        }
        Err(e) if kind == BackendKind::Auto => Ok(cpu_instead(e.to_string())),
        Err(e) => Err(e),
    }
}
