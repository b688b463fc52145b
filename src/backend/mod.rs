//! Batched film-load evaluation: one interface over the CPU and GPU kernels, and the
//! evaluator that validates, packs, dispatches, falls back and finishes loads.

mod calibrate;
mod cpu;
mod evaluator;
mod finite;
#[cfg(feature = "gpu")]
mod finite_gpu;
#[cfg(feature = "gpu")]
mod finite_jfo;
#[cfg(feature = "gpu")]
mod finite_mg;
#[cfg(feature = "gpu")]
mod gpu;
#[cfg(not(feature = "gpu"))]
#[path = "gpu_absent.rs"]
mod gpu;
mod gpu_kernel;
mod shared;
mod states;

pub use calibrate::{cache_file, Calibration};
pub use cpu::CpuBackend;
pub use evaluator::{
    BearingPlan, EvalStats, EvaluatorOptions, LoadEvaluator, LoadRequest, LoadResult,
    DEFAULT_CPU_BELOW, PARALLEL_HOST_STATES,
};
pub use finite::effective_model;
#[cfg(feature = "gpu")]
pub use finite_mg::take_tally as take_mg_tally;
pub use gpu::GpuBackend;
pub use gpu_kernel::{
    check_lanes, kernel_source, kernel_source_lanes, relative_difference, GpuOptions, GpuTiming,
    FINITE_MAX_NODES, FINITE_WGSL, HARDWARE_DEFAULT_LANES, HARDWARE_DEFAULT_SLOTS, KERNEL_WGSL,
    KERNEL_WORKGROUP_SIZE,
};
pub use shared::{DispatchStats, Dispatcher, SharedBackend};
pub use states::bench_states;

use crate::bearing::finite::{FiniteGrid, FiniteJob, JfoHistory, SolveReport};
use crate::bearing::{Accuracy, FilmIntegrals, PackedState, RuleSettings};

/// Which backend a user asked for.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum BackendKind {
    /// The CPU kernel on all cores (the reference).
    Cpu,
    /// The WGSL kernel through wgpu; an error when no adapter exists.
    Gpu,
    /// A hardware GPU for large enough batches, else the CPU, with a one-line notice
    /// ([`choose_backend`]).
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

    /// As [`FilmBackend::integrate_finite`], with the caller saying whether it uses the
    /// fields (a warm start of its next call, film friction and flow, a JFO history):
    /// with `fields_wanted` false every `fields[k]` comes back empty, and a device backend
    /// skips reading them back (on a hardware GPU the read-back cost more than the kernel:
    /// BENCHMARKS.md, session 40). Loads and reports are the same bits either way. The
    /// default solves with the fields and drops them.
    fn integrate_finite_with(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        fields_wanted: bool,
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.integrate_finite(jobs, grid, fields, out, reports)?;
        if !fields_wanted {
            fields.iter_mut().for_each(Vec::clear);
        }
        Ok(())
    }

    /// Mass-conserving (JFO) films on the fixed `grid` with a film history per job (issue
    /// 27, rotor runs: `histories[k]` `None` is a steady film, an empty slice all steady),
    /// otherwise as [`FilmBackend::integrate_finite`]. The default is the CPU JFO solver on
    /// rayon's global pool.
    fn integrate_finite_jfo(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<JfoHistory>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        finite::cpu_integrate_jfo(jobs, grid, fields, histories, out, reports);
        Ok(())
    }

    /// Why this backend runs, when [`choose_backend`] created it.
    fn choice(&self) -> Option<BackendChoice> {
        None
    }

    /// Dispatches a [`Dispatcher`] should keep in flight at once on this backend (it asks
    /// [`FilmBackend::sibling`] for the others): 1 unless the backend says otherwise.
    fn dispatch_slots(&self) -> usize {
        1
    }

    /// Another backend on the same device with buffers of its own, for a second dispatch
    /// in flight beside this one; the same settings, and integrals identical state for
    /// state. `None` (the default): the backend has no such sibling.
    fn sibling(&self) -> Option<Box<dyn FilmBackend>> {
        None
    }

    /// How a [`Dispatcher`] merges requests on this backend: `Some((m, linger))` waits up
    /// to `linger` for `m` requests before a dispatch; `None` (the default) dispatches as
    /// soon as the device is free.
    fn merge_policy(&self) -> Option<(usize, std::time::Duration)> {
        None
    }
}

/// Below this requested accuracy an f32 kernel cannot keep its promise (its rounding
/// error reaches ~1e-5 near the wall); `gpu` and `auto` then say so.
const F32_ACCURACY_FLOOR: f64 = 1e-5;

/// Why a backend runs: what was asked for, what runs, and the reason (recorded in
/// result.json and printed as one line on stderr when `auto` chose).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BackendChoice {
    /// The `--backend` value.
    pub requested: BackendKind,
    /// The backend that runs: `"cpu"` or `"gpu"`.
    pub backend: String,
    /// Why (for `cpu` and `gpu`: "requested").
    pub reason: String,
}

impl BackendChoice {
    /// The one stderr line of an `auto` choice: the reason without its parenthesised
    /// details (the driver's words, the benchmark behind a rule), which stay in the
    /// output's `backend_choice`, so that a CPU run's line stays short.
    pub fn line(&self) -> String {
        let target = if self.backend == "gpu" { "GPU" } else { "CPU" };
        let reason = without_final_parenthesis(&self.reason);
        format!("notice: backend auto: {reason}; using the {target} backend")
    }
}

/// `text` without a final ` (...)` group (nested parentheses inside it, such as an
/// adapter's name, are kept together with it; a text not ending in `)` is returned whole).
fn without_final_parenthesis(text: &str) -> &str {
    if !text.ends_with(')') {
        return text;
    }
    let mut depth = 0i32;
    for (i, c) in text.char_indices().rev() {
        match c {
            ')' => depth += 1,
            '(' => {
                depth -= 1;
                if depth == 0 {
                    return text[..i].trim_end();
                }
            }
            _ => {}
        }
    }
    text
}

/// Gives the process a private `XDG_RUNTIME_DIR` when it has none (or one that is not an
/// existing absolute folder): the Vulkan loader's window-system layers (lavapipe's
/// included) print `error: XDG_RUNTIME_DIR is invalid or not set` on stderr while
/// enumerating adapters otherwise, although nothing is wrong. Call it first thing in
/// `main`, before any thread starts (it sets an environment variable).
pub fn ensure_xdg_runtime_dir() {
    let usable = std::env::var_os("XDG_RUNTIME_DIR")
        .map(std::path::PathBuf::from)
        .is_some_and(|p| p.is_absolute() && p.is_dir());
    if usable {
        return;
    }
    // SAFETY: getuid has no preconditions and cannot fail.
    let uid = unsafe { libc::getuid() };
    let dir = std::env::temp_dir().join(format!("bearing-sweep-runtime-{uid}"));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The XDG spec asks for a folder only its user can enter.
        let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
    }
    std::env::set_var("XDG_RUNTIME_DIR", &dir);
}

/// The CPU backend at `accuracy` as the choice for a `kind` request, with `reason`, and
/// for `auto` the one-line notice of the choice.
pub fn chosen_cpu(
    kind: BackendKind,
    accuracy: Accuracy,
    reason: String,
) -> (Box<dyn FilmBackend>, Vec<String>) {
    let choice = BackendChoice {
        requested: kind,
        backend: "cpu".into(),
        reason,
    };
    let notices = if kind == BackendKind::Auto {
        vec![choice.line()]
    } else {
        Vec::new()
    };
    let backend = Box::new(CpuBackend::new(accuracy, None));
    (Box::new(Chosen { backend, choice }), notices)
}

/// Creates the backend of `kind` at `accuracy`. Returns the backend and, for `auto`,
/// the one-line notice of its choice (plus a second line when the GPU kernel's f32 cannot
/// reach `accuracy`). Without a batch size `auto` assumes a large batch (sweeps); see
/// [`choose_backend`].
pub fn create_backend(
    kind: BackendKind,
    accuracy: Accuracy,
) -> Result<(Box<dyn FilmBackend>, Option<String>), BackendError> {
    let (backend, notices) = choose_backend(kind, accuracy, None)?;
    Ok((backend, (!notices.is_empty()).then(|| notices.join("\n"))))
}

/// Creates the backend of `kind` at `accuracy` for calls of about `states_per_call`
/// bearing states (`None`: large, as in a sweep). Returns the backend, whose
/// [`FilmBackend::choice`] says why it runs, and the notices for stderr (for `auto`
/// first its one-line choice).
///
/// `auto` takes a hardware GPU adapter when the calls carry at least
/// [`DEFAULT_CPU_BELOW`] states (below that the evaluator would route every call to the
/// CPU anyway) and the CPU otherwise: when the calls are small, when no adapter exists,
/// or when the adapter is a software rasteriser (lavapipe: the same CPU, no faster than
/// the CPU backend), even one named by `WGPU_ADAPTER_NAME`. `gpu` takes any adapter,
/// software included. The GPU adapter follows `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`, its
/// precision `BEARING_SWEEP_GPU_PRECISION` (see [`GpuOptions::from_env`]).
pub fn choose_backend(
    kind: BackendKind,
    accuracy: Accuracy,
    states_per_call: Option<usize>,
) -> Result<(Box<dyn FilmBackend>, Vec<String>), BackendError> {
    choose_backend_for_film(kind, accuracy, states_per_call, false)
}

/// States per call and per host thread below which `auto` keeps finite-film calls on the
/// CPU. Measured on an H200 against its host's 16 threads at the default accuracy
/// (BENCHMARKS.md "Issue 20, session 41: the multigrid kernel's host side on the H200"): a
/// GPU call is at least one state's chain of kernel steps, ~16-18 ms however few the
/// states on a GPU whose clock is still ramping up from idle (as a one-off call meets it),
/// while a CPU thread solves ~2,000-2,800 default-accuracy states/s; so the GPU lost 4× at
/// 64 states per call and won 1.55× at 1024, a crossover near 600 on 16 threads, ~36 per
/// thread (40: the round number above it, the CPU's side of a tie). Once warm, 64 states
/// per call were level with the 16 threads (session 42: 12,922-14,519 against
/// 13,252-14,378 states/s); the crossover is kept for the cold, one-off calls.
pub const FINITE_CPU_BELOW_PER_THREAD: usize = 40;

/// The finite film's `auto` crossover on this host: [`FINITE_CPU_BELOW_PER_THREAD`] times
/// rayon's threads.
pub fn finite_cpu_below() -> usize {
    FINITE_CPU_BELOW_PER_THREAD * rayon::current_num_threads().max(1)
}

/// The crossover `auto` applies to calls of this film: [`DEFAULT_CPU_BELOW`] for the short
/// film, [`finite_cpu_below`] where the calls may carry finite-film states.
pub fn auto_cpu_below(finite: bool) -> usize {
    if finite {
        finite_cpu_below().max(DEFAULT_CPU_BELOW)
    } else {
        DEFAULT_CPU_BELOW
    }
}

/// [`choose_backend`] for calls whose bearings may use the finite film (`finite`: a
/// bearing's `model` is `finite` or `auto`): `auto` then takes the GPU only from
/// [`auto_cpu_below`]`(true)` states per call.
pub fn choose_backend_for_film(
    kind: BackendKind,
    accuracy: Accuracy,
    states_per_call: Option<usize>,
    finite: bool,
) -> Result<(Box<dyn FilmBackend>, Vec<String>), BackendError> {
    let cpu = |reason: String| chosen_cpu(kind, accuracy, reason);
    let below = auto_cpu_below(finite);
    let film = if finite { "finite-film " } else { "" };
    match (kind, states_per_call) {
        (BackendKind::Cpu, _) => return Ok(cpu("requested".into())),
        (BackendKind::Auto, Some(n)) if n < below => {
            return Ok(cpu(format!(
                "{n} bearing states per call, below the {film}GPU crossover of {below}"
            )))
        }
        _ => {}
    }
    let g = match open_gpu(kind, accuracy)? {
        Ok(g) => g,
        Err(reason) => return Ok(cpu(reason)),
    };
    let device = g.info().device;
    let reason = match (kind, states_per_call) {
        (BackendKind::Gpu, _) => "requested".to_string(),
        (_, Some(n)) => format!("hardware adapter `{device}`, {n} bearing states per call"),
        (_, None) => format!("hardware adapter `{device}`"),
    };
    Ok(chosen_gpu(kind, accuracy, g, reason))
}

/// The GPU backend for a `kind` request, or for `auto` the reason to take the CPU
/// instead (no adapter, a failing one, or a software rasteriser).
fn open_gpu(
    kind: BackendKind,
    accuracy: Accuracy,
) -> Result<Result<GpuBackend, String>, BackendError> {
    let g = match GpuOptions::from_env().and_then(|o| GpuBackend::new(accuracy, o)) {
        Ok(g) => g,
        Err(BackendError::NoAdapter(why)) if kind == BackendKind::Auto => {
            return Ok(Err(format!("no GPU adapter ({why})")))
        }
        Err(e) if kind == BackendKind::Auto => return Ok(Err(e.to_string())),
        Err(e) => return Err(e),
    };
    let device = g.info().device;
    if kind == BackendKind::Auto && g.is_software() {
        // The adapter's short name in the notice line; its full description (driver and
        // versions) in the final parenthesis, which the line leaves out.
        let short = device.split(" (").next().unwrap_or(&device);
        return Ok(Err(format!(
            "the GPU adapter `{short}` is a software rasteriser (`{device}`; use --backend gpu to run on it)"
        )));
    }
    Ok(Ok(g))
}

/// `g` as the choice for a `kind` request with `reason`, and its notices (for `auto`
/// first its one-line choice).
fn chosen_gpu(
    kind: BackendKind,
    accuracy: Accuracy,
    mut g: GpuBackend,
    reason: String,
) -> (Box<dyn FilmBackend>, Vec<String>) {
    let choice = BackendChoice {
        requested: kind,
        backend: "gpu".into(),
        reason,
    };
    let mut notices = Vec::new();
    if kind == BackendKind::Auto {
        notices.push(choice.line());
    }
    notices.extend(g.take_notice());
    if g.precision() == Precision::F32 && accuracy.rtol() < F32_ACCURACY_FLOOR {
        notices.push(format!(
            "notice: the GPU kernel runs in f32 (agreement with f64 ~1e-5), looser than the \
             requested accuracy {:e}",
            accuracy.rtol()
        ));
    }
    (
        Box::new(Chosen {
            backend: Box::new(g),
            choice,
        }),
        notices,
    )
}

/// `auto` takes the GPU for a rotor sweep only when its predicted film-load cost per
/// variant-stage is below this fraction of the CPU's: the model leaves out the host work
/// that the GPU path adds (packing, merging, waiting for a dispatch's stragglers).
const SWEEP_GPU_MARGIN: f64 = 0.5;

/// Creates the backend of `kind` for a short-film rotor sweep at `accuracy` with
/// `bearings` bearings per variant, `variants` variants per lockstep batch and `threads`
/// host threads. `cpu` and `gpu` are as [`choose_backend`]; `auto` opens a hardware
/// adapter (else the CPU, as [`choose_backend`]) and decides from a [`Calibration`] of
/// it (cached per device: [`cache_file`]): the GPU when its film loads per variant-stage
/// are predicted at most [`SWEEP_GPU_MARGIN`] of the CPU's on `threads` threads. The
/// choice's reason gives both figures and what was measured.
/// `BEARING_SWEEP_CALIBRATION=off` skips the calibration (a hardware adapter is taken),
/// `=refresh` measures anew.
pub fn choose_sweep_backend(
    kind: BackendKind,
    accuracy: Accuracy,
    bearings: usize,
    variants: usize,
    threads: usize,
) -> Result<(Box<dyn FilmBackend>, Vec<String>), BackendError> {
    let off = std::env::var("BEARING_SWEEP_CALIBRATION").is_ok_and(|v| v == "off");
    if kind != BackendKind::Auto || off {
        return choose_backend(kind, accuracy, None);
    }
    let mut g = match open_gpu(kind, accuracy)? {
        Ok(g) => g,
        Err(reason) => return Ok(chosen_cpu(kind, accuracy, reason)),
    };
    let cal = match Calibration::cached(&mut g, accuracy) {
        Ok(c) if c.is_usable() => c,
        Ok(c) => {
            return Ok(chosen_cpu(
                kind,
                accuracy,
                format!("the GPU calibration is unusable ({})", c.summary()),
            ))
        }
        Err(e) => {
            return Ok(chosen_cpu(
                kind,
                accuracy,
                format!("the GPU failed its calibration ({e})"),
            ))
        }
    };
    let (gpu, reason) = cal.sweep_prefers_gpu(bearings, variants, threads, SWEEP_GPU_MARGIN);
    if gpu {
        Ok(chosen_gpu(kind, accuracy, g, reason))
    } else {
        Ok(chosen_cpu(kind, accuracy, reason))
    }
}

/// A backend with the reason it was chosen; everything else is the inner backend's
/// (every trait method must be forwarded here, or the wrapper would hide an override).
struct Chosen {
    backend: Box<dyn FilmBackend>,
    choice: BackendChoice,
}

impl FilmBackend for Chosen {
    fn info(&self) -> BackendInfo {
        self.backend.info()
    }
    fn settings(&self) -> RuleSettings {
        self.backend.settings()
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        self.backend.integrate(states, out)
    }
    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.backend
            .integrate_finite(jobs, grid, fields, out, reports)
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
        self.backend
            .integrate_finite_with(jobs, grid, fields, fields_wanted, out, reports)
    }
    fn integrate_finite_jfo(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<JfoHistory>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.backend
            .integrate_finite_jfo(jobs, grid, fields, histories, out, reports)
    }
    fn choice(&self) -> Option<BackendChoice> {
        Some(self.choice.clone())
    }
    fn dispatch_slots(&self) -> usize {
        self.backend.dispatch_slots()
    }
    fn sibling(&self) -> Option<Box<dyn FilmBackend>> {
        self.backend.sibling()
    }
    fn merge_policy(&self) -> Option<(usize, std::time::Duration)> {
        self.backend.merge_policy()
    }
}

#[cfg(test)]
mod notice_tests {
    use super::without_final_parenthesis as strip;

    #[test]
    fn the_auto_notice_drops_only_the_final_parenthesis() {
        assert_eq!(
            strip("no GPU adapter (no Vulkan loader: details)"),
            "no GPU adapter"
        );
        assert_eq!(
            strip("the GPU adapter `llvmpipe (LLVM 15.0.6, 256 bits)` is a software rasteriser (use --backend gpu to run on it)"),
            "the GPU adapter `llvmpipe (LLVM 15.0.6, 256 bits)` is a software rasteriser"
        );
        assert_eq!(
            strip("2 bearing states per call, below the GPU crossover of 64"),
            "2 bearing states per call, below the GPU crossover of 64"
        );
    }
}

#[cfg(test)]
mod crossover_tests {
    use super::*;

    /// `auto` keeps finite-film calls on the CPU up to the finite film's own crossover
    /// (40 states per host thread, above the short film's 64), whatever adapter exists:
    /// the decision is made before an adapter is opened, and its reason names the film.
    #[test]
    fn auto_keeps_finite_film_calls_below_their_crossover_on_the_cpu() {
        let threads = rayon::current_num_threads().max(1);
        let below = auto_cpu_below(true);
        assert_eq!(
            below,
            (40 * threads).max(DEFAULT_CPU_BELOW),
            "threads {threads}"
        );
        assert_eq!(auto_cpu_below(false), DEFAULT_CPU_BELOW);
        let n = below - 1;
        let (b, _) = choose_backend_for_film(BackendKind::Auto, Accuracy::default(), Some(n), true)
            .expect("the CPU backend");
        let choice = b.choice().expect("auto records its choice");
        assert_eq!(choice.backend, "cpu");
        assert_eq!(
            choice.reason,
            format!("{n} bearing states per call, below the finite-film GPU crossover of {below}")
        );
        // The short film at the same size is past its crossover: not decided by size
        // (an adapter or its absence decides), so its reason does not cite a crossover.
        let (b, _) = choose_backend_for_film(
            BackendKind::Auto,
            Accuracy::default(),
            Some(n.max(64)),
            false,
        )
        .expect("a backend");
        let reason = b.choice().expect("auto records its choice").reason;
        assert!(!reason.contains("crossover"), "{reason}");
    }
}
