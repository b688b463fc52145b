//! Backend throughput and latency against batch size (`bearing-sweep bench backend`):
//! end to end through [`LoadEvaluator`] and the kernel alone, the error against the CPU
//! kernel, flops per state counted from the kernel's operations, and the batch size where
//! the GPU overtakes the CPU. Measurement only; the CLI prints the report.

use std::time::Instant;

use crate::backend::{
    bench_states, relative_difference, BackendError, CpuBackend, FilmBackend, GpuBackend,
    GpuOptions, LoadEvaluator, LoadRequest, LoadResult, Precision,
};
use crate::bearing::{
    pack_state, Accuracy, BearingParams, FilmRule, PackedState, RuleSettings, Singularities,
};

/// Which backends a benchmark runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchTarget {
    /// The CPU backend only.
    Cpu,
    /// The GPU backend only.
    Gpu,
    /// Both, CPU first.
    Both,
}

impl std::str::FromStr for BenchTarget {
    type Err = String;
    /// `cpu`, `gpu` or `both` (`bench backend --backend`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cpu" => Ok(BenchTarget::Cpu),
            "gpu" => Ok(BenchTarget::Gpu),
            "both" => Ok(BenchTarget::Both),
            other => Err(format!("`{other}` (expected cpu, gpu or both)")),
        }
    }
}

/// Benchmark parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Batch sizes (states per call).
    pub sizes: Vec<usize>,
    /// Rule accuracy level.
    pub accuracy: Accuracy,
    /// CPU backend threads.
    pub cpu_threads: usize,
    /// Backends to run.
    pub target: BenchTarget,
    /// Repeat a measurement until this much time is spent (s), within `max_reps`.
    pub min_time_s: f64,
    /// Most repetitions per measurement.
    pub max_reps: usize,
    /// Largest end eccentricity ratio of the random states.
    pub max_ratio: f64,
    /// GPU options (precision, chunk size, lanes per state).
    pub gpu: GpuOptions,
    /// The device's FP64 (or, for an f32 kernel, FP32) vector peak, GFLOP/s, for the
    /// achieved fraction of peak (`None`: not reported). The H200's and H100's FP64 vector
    /// peak is 34 000 GFLOP/s (NVIDIA's data sheets).
    pub peak_gflops: Option<f64>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            sizes: vec![1, 10, 100, 1_000, 10_000, 100_000, 1_000_000],
            accuracy: Accuracy::default(),
            cpu_threads: 2,
            target: BenchTarget::Both,
            min_time_s: 1.0,
            max_reps: 50,
            max_ratio: 0.95,
            gpu: GpuOptions::default(),
            peak_gflops: None,
        }
    }
}

/// One backend at one batch size.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BackendRow {
    /// `cpu` or `gpu`.
    pub backend: String,
    /// Device description.
    pub device: String,
    /// Invocations per state of the GPU kernel (`None` on the CPU).
    pub lanes: Option<u32>,
    /// Kernel precision.
    pub precision: Precision,
    /// States per call.
    pub size: usize,
    /// Repetitions timed.
    pub reps: usize,
    /// Median round trip of one `LoadEvaluator::evaluate` call (validate, pack, kernel,
    /// transfers, finish), s.
    pub end_to_end_s: f64,
    /// `size / end_to_end_s`.
    pub end_to_end_states_per_s: f64,
    /// Median kernel time alone (no packing, no transfers), s.
    pub kernel_s: f64,
    /// How `kernel_s` was measured: `timestamp` (GPU timestamp queries), `wall` (GPU
    /// submit-to-completion of the dispatch alone) or `cpu` (the CPU backend's call on
    /// packed states).
    pub kernel_timer: &'static str,
    /// `size / kernel_s`.
    pub kernel_states_per_s: f64,
    /// Counted flops of the batch over `kernel_s`, GFLOP/s: the rule's flops, once per
    /// state (with several lanes per state every lane repeats the state's root search and
    /// panel walk; those repeats are not counted, so this stays the useful rate).
    pub kernel_gflops: f64,
    /// `kernel_gflops` over [`BenchOptions::peak_gflops`], when given.
    pub peak_fraction: Option<f64>,
    /// Microseconds per state of the round trip beyond the kernel (validate, pack,
    /// deduplicate, upload, launch, read back, finish): `(end_to_end_s - kernel_s) / size`.
    pub host_us_per_state: f64,
    /// Largest relative error of the load vector against the single-thread CPU kernel
    /// over the batch (at most 4096 states compared).
    pub max_rel_error: f64,
}

/// Flops per state of the kernel, counted (see [`flop_count`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FlopCount {
    /// States counted.
    pub states: usize,
    /// Mean panels per state.
    pub panels: f64,
    /// Mean slices (closed-form arc evaluations) per state.
    pub slices: f64,
    /// Mean Durand-Kerner sweeps per state.
    pub root_iterations: f64,
    /// Mean flops per state.
    pub flops: f64,
}

/// The whole benchmark.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BenchReport {
    /// One row per backend and size.
    pub rows: Vec<BackendRow>,
    /// Flops per state for the benchmark's states.
    pub flops: FlopCount,
    /// Smallest size from which the GPU's end-to-end throughput stays above the CPU's.
    pub crossover_end_to_end: Option<usize>,
    /// The same for kernel throughput.
    pub crossover_kernel: Option<usize>,
    /// Notices (GPU missing, fallbacks).
    pub notices: Vec<String>,
    /// The evaluator's host path alone at each size (a kernel that returns at once).
    pub host_path: Vec<HostRow>,
}

/// The host path of one evaluator call without a kernel: validate, pack, deduplicate,
/// finish the loads (rayon's pool for calls of at least `PARALLEL_HOST_STATES`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HostRow {
    /// States per call.
    pub size: usize,
    /// Repetitions timed.
    pub reps: usize,
    /// Median call, s.
    pub host_s: f64,
    /// `1e6 * host_s / size`.
    pub us_per_state: f64,
}

/// A kernel that answers at once (zero integrals: a film without pressure), so that an
/// evaluator call over it times the host path alone.
struct NullKernel(RuleSettings);

impl FilmBackend for NullKernel {
    fn info(&self) -> crate::backend::BackendInfo {
        crate::backend::BackendInfo {
            name: "null".into(),
            device: "none (host path alone)".into(),
            precision: Precision::F64,
        }
    }
    fn settings(&self) -> RuleSettings {
        self.0
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<crate::bearing::FilmIntegrals>,
    ) -> Result<(), BackendError> {
        out.clear();
        out.resize(states.len(), [0.0; 4]);
        Ok(())
    }
}

// Flops of the WGSL kernel's pieces, counted by hand from shaders/film.wgsl: add, sub,
// mul, div and sqrt count 1 each, a multiply-add 2; comparisons, selects and moves 0.
/// One closed-form slice (`slice_integrals`, the series branch): ~43 in `atan2_arith`,
/// 45 in `sin_cos_small`, 79 in the three series, the rest in the arc geometry.
pub const FLOPS_SLICE: f64 = 273.0;
/// Per Gauss node besides the slice: node position, slice arguments, weight, 4 sums.
pub const FLOPS_NODE: f64 = 24.0;
/// Per panel: `panel_end` with its poles (6 + 6 per complex singularity, counted with
/// the state's singularities) and the panel length.
pub const FLOPS_PANEL_BASE: f64 = 7.0;
/// Per complex singularity per panel in `panel_end`.
pub const FLOPS_PANEL_PER_SINGULARITY: f64 = 6.0;
/// `singularities` without the root finder's sweeps: poles, kink, quartic coefficients,
/// root finder setup.
pub const FLOPS_SINGULARITY_SETUP: f64 = 95.0;

/// Flops of one Durand-Kerner sweep over a monic polynomial of degree `n`: per root a
/// Horner evaluation (7 per step), the product of differences (8 per factor), the
/// complex division (11) and the update and convergence measure (4).
pub fn flops_root_sweep(n: usize) -> f64 {
    let n = n as f64;
    n * (7.0 * n + 8.0 * (n - 1.0) + 15.0)
}

/// Mean counted flops per state of the kernel over `states`: slices and panels from the
/// CPU rule (the same march), root-finder sweeps replayed, the pieces' counts above.
pub fn flop_count(settings: RuleSettings, states: &[PackedState]) -> FlopCount {
    let rule = FilmRule::new(settings);
    let mut total = FlopCount {
        states: states.len(),
        ..FlopCount::default()
    };
    for s in states {
        let (_, slices) = rule.integrate(s);
        let slices = slices as f64;
        let aligned = s.ecc[0] == s.ecc[2]
            && s.ecc[1] == s.ecc[3]
            && s.rate[0] == s.rate[2]
            && s.rate[1] == s.rate[3];
        let mut flops = slices * (FLOPS_SLICE + FLOPS_NODE);
        if !aligned {
            let panels = slices / settings.nodes as f64;
            let (n, sweeps) = Singularities::of(s, &settings).root_work;
            // Complex singularities: the quartic's roots and at most the rate zero.
            let sing = n as f64 + 1.0;
            flops += FLOPS_SINGULARITY_SETUP
                + sweeps as f64 * flops_root_sweep(n)
                + panels * (FLOPS_PANEL_BASE + FLOPS_PANEL_PER_SINGULARITY * sing);
            total.panels += panels;
            total.root_iterations += sweeps as f64;
        } else {
            total.panels += 1.0;
        }
        total.slices += slices;
        total.flops += flops;
    }
    let n = states.len().max(1) as f64;
    total.panels /= n;
    total.slices /= n;
    total.root_iterations /= n;
    total.flops /= n;
    total
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Times `f` until `min_time_s` is spent or `max_reps` runs; returns the median seconds
/// and the repetitions.
fn time_reps(min_time_s: f64, max_reps: usize, mut f: impl FnMut() -> f64) -> (f64, usize) {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < max_reps.max(1)
        && (times.is_empty() || start.elapsed().as_secs_f64() < min_time_s)
    {
        times.push(f());
    }
    let reps = times.len();
    (median(&mut times), reps)
}

fn load_error(params: &BearingParams, got: &LoadResult, want: &LoadResult) -> f64 {
    match (got, want) {
        (Ok(g), Ok(w)) => {
            relative_difference(&g.load_vector(params.length), &w.load_vector(params.length))
        }
        (Err(a), Err(b)) if a.code() == b.code() => 0.0,
        _ => f64::INFINITY,
    }
}

/// Runs the benchmark.
pub fn run_bench(options: &BenchOptions) -> Result<BenchReport, BackendError> {
    let max_size = options.sizes.iter().copied().max().unwrap_or(1);
    let (params, all_requests) = bench_states(max_size, options.max_ratio, 0xbe_4c_11);
    let all_packed: Vec<PackedState> = all_requests
        .iter()
        .filter_map(|r| pack_state(&params, &r.state).ok())
        .filter(|p| p.rate_scale > 0.0)
        .map(|p| p.state)
        .collect();
    let settings = options.accuracy.settings();
    let flops = flop_count(settings, &all_packed[..all_packed.len().min(20_000)]);
    let mut report = BenchReport {
        rows: Vec::new(),
        flops,
        crossover_end_to_end: None,
        crossover_kernel: None,
        notices: Vec::new(),
        host_path: Vec::new(),
    };
    {
        let mut evaluator = LoadEvaluator::new(Box::new(NullKernel(settings)));
        let mut out = Vec::new();
        for &size in &options.sizes {
            let requests = &all_requests[..size];
            evaluator.evaluate(std::slice::from_ref(&params), requests, &mut out);
            let (host_s, reps) = time_reps(options.min_time_s, options.max_reps, || {
                let t = Instant::now();
                evaluator.evaluate(std::slice::from_ref(&params), requests, &mut out);
                t.elapsed().as_secs_f64()
            });
            report.host_path.push(HostRow {
                size,
                reps,
                host_s,
                us_per_state: 1e6 * host_s / size as f64,
            });
        }
    }
    let mut runs: Vec<(Box<dyn FilmBackend>, Option<GpuBackend>)> = Vec::new();
    let mut lanes = None;
    if options.target != BenchTarget::Gpu {
        runs.push((
            Box::new(CpuBackend::with_settings(
                settings,
                Some(options.cpu_threads),
            )),
            None,
        ));
    }
    if options.target != BenchTarget::Cpu {
        let plain = GpuBackend::with_settings(settings, options.gpu.clone())?;
        let profiled = GpuBackend::with_settings(
            settings,
            GpuOptions {
                profile: true,
                ..options.gpu.clone()
            },
        )?;
        lanes = Some(plain.lanes());
        runs.push((Box::new(plain), Some(profiled)));
    }
    for (backend, mut profiled) in runs {
        let info = backend.info();
        let mut evaluator = LoadEvaluator::new(backend);
        let mut cpu_kernel = CpuBackend::with_settings(settings, Some(options.cpu_threads));
        let mut out = Vec::new();
        let mut integrals = Vec::new();
        for &size in &options.sizes {
            let requests = &all_requests[..size];
            let packed = &all_packed[..size.min(all_packed.len())];
            // Counted flops of this batch (its first 20 000 states, scaled).
            let counted = packed.len().min(20_000);
            let batch_flops = if counted == 0 {
                0.0
            } else {
                flop_count(settings, &packed[..counted]).flops * packed.len() as f64
            };
            // Warm-up (allocations, pipeline caches), then the timed end-to-end calls.
            evaluator.evaluate(std::slice::from_ref(&params), requests, &mut out);
            let (e2e, reps) = time_reps(options.min_time_s, options.max_reps, || {
                let t = Instant::now();
                evaluator.evaluate(std::slice::from_ref(&params), requests, &mut out);
                t.elapsed().as_secs_f64()
            });
            report.notices.extend(evaluator.take_notices());
            // Error against the single-thread CPU kernel on up to 4096 states.
            let stride = (size / 4096).max(1);
            let sample: Vec<LoadRequest> = requests.iter().step_by(stride).copied().collect();
            let mut ref_eval =
                LoadEvaluator::new(Box::new(CpuBackend::with_settings(settings, Some(1))));
            let mut want = Vec::new();
            ref_eval.evaluate(std::slice::from_ref(&params), &sample, &mut want);
            let max_rel_error = out
                .iter()
                .step_by(stride)
                .zip(&want)
                .map(|(g, w)| load_error(&params, g, w))
                .fold(0.0, f64::max);
            // Kernel alone.
            let (kernel_s, kernel_timer) = match profiled.as_mut() {
                None => {
                    let (t, _) = time_reps(options.min_time_s, options.max_reps, || {
                        let t = Instant::now();
                        let _ = cpu_kernel.integrate(packed, &mut integrals);
                        t.elapsed().as_secs_f64()
                    });
                    (t, "cpu")
                }
                Some(g) => {
                    g.integrate(packed, &mut integrals)?;
                    let mut timer = "wall";
                    let (t, _) = time_reps(options.min_time_s, options.max_reps, || {
                        if g.integrate(packed, &mut integrals).is_err() {
                            return f64::NAN;
                        }
                        let tm = g.last_timing();
                        match tm.kernel_device_s {
                            Some(d) => {
                                timer = "timestamp";
                                d
                            }
                            None => tm.kernel_wall_s.unwrap_or(f64::NAN),
                        }
                    });
                    (t, timer)
                }
            };
            let kernel_gflops = batch_flops / kernel_s * 1e-9;
            report.rows.push(BackendRow {
                backend: info.name.clone(),
                device: info.device.clone(),
                lanes: if profiled.is_some() { lanes } else { None },
                precision: info.precision,
                size,
                reps,
                end_to_end_s: e2e,
                end_to_end_states_per_s: size as f64 / e2e,
                kernel_s,
                kernel_timer,
                kernel_states_per_s: packed.len() as f64 / kernel_s,
                kernel_gflops,
                peak_fraction: options
                    .peak_gflops
                    .filter(|p| *p > 0.0)
                    .map(|p| kernel_gflops / p),
                host_us_per_state: 1e6 * (e2e - kernel_s) / size as f64,
                max_rel_error,
            });
        }
    }
    let crossover = |rate: fn(&BackendRow) -> f64| -> Option<usize> {
        let mut first = None;
        for &size in &options.sizes {
            let get = |name: &str| {
                report
                    .rows
                    .iter()
                    .find(|r| r.backend == name && r.size == size)
                    .map(rate)
            };
            match (get("gpu"), get("cpu")) {
                (Some(g), Some(c)) if g >= c => {
                    first.get_or_insert(size);
                }
                (Some(_), Some(_)) => first = None,
                _ => return None,
            }
        }
        first
    };
    report.crossover_end_to_end = crossover(|r| r.end_to_end_states_per_s);
    report.crossover_kernel = crossover(|r| r.kernel_states_per_s);
    Ok(report)
}
