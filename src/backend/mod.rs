//! Batched film-load evaluation: one interface over the CPU and GPU kernels, and the
//! evaluator that validates, packs, dispatches, falls back and finishes loads.

mod cpu;
mod evaluator;

pub use cpu::CpuBackend;
pub use evaluator::{EvalStats, LoadEvaluator, LoadRequest, LoadResult};

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
}

/// Creates the backend of `kind` at `accuracy`. Returns the backend and, for `auto`
/// falling back to the CPU, the one-line notice to show the user.
pub fn create_backend(
    kind: BackendKind,
    accuracy: Accuracy,
) -> Result<(Box<dyn FilmBackend>, Option<String>), BackendError> {
    match kind {
        BackendKind::Cpu => Ok((Box::new(CpuBackend::new(accuracy, None)), None)),
        BackendKind::Gpu | BackendKind::Auto => {
            let err = BackendError::NoAdapter("this build has no GPU backend yet".into());
            if kind == BackendKind::Gpu {
                Err(err)
            } else {
                Ok((
                    Box::new(CpuBackend::new(accuracy, None)),
                    Some(format!("notice: {err}; using the CPU backend")),
                ))
            }
        }
    }
}
