//! `bench loads`: evaluations per second against relative error of the load vector for
//! the default rule at each accuracy level and for the brute-force baseline at several
//! grids, on one thread and on all cores (issue 2's benchmark), plus the rule on the GPU
//! backend (f64 and f32 kernels, one large batch per call) at each level when an adapter
//! exists (issue 6).

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::app::AppError;
use crate::backend::{
    BackendError, CpuBackend, FilmBackend, GpuBackend, GpuOptions, LoadEvaluator, LoadRequest,
    LoadResult, Precision,
};
use crate::bearing::reference::reference_loads;
use crate::bearing::{
    baseline_loads, pack_state, Accuracy, BearingParams, BearingState, FilmRule, ACCURACY_LEVELS,
};
use crate::plot::{line_plot_svg, Scale, Series};

/// Options of `bench loads`.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchLoadsOptions {
    /// Threads of the parallel runs (`None`: all cores).
    pub threads: Option<usize>,
    /// Benchmark states (random tilted, squeezed, larger end eccentricity <= 0.95).
    pub states: usize,
    /// Output folder for `bench-loads.{json,md,svg}`.
    pub out: PathBuf,
    /// Baseline grids `n` (an `n × n` grid in θ × z).
    pub baseline_grids: Vec<usize>,
    /// Minimum wall time of one timing, s.
    pub min_time_s: f64,
    /// States per GPU call for the GPU rows' timing (distinct states drawn like the
    /// benchmark states, see [`gpu_timing_batch`]); 0 skips the GPU rows.
    pub gpu_batch: usize,
}

impl Default for BenchLoadsOptions {
    fn default() -> Self {
        BenchLoadsOptions {
            threads: None,
            states: 2000,
            out: PathBuf::from("out/bench"),
            baseline_grids: vec![32, 64, 128, 256, 512, 1024, 2048],
            min_time_s: 0.5,
            gpu_batch: DEFAULT_GPU_BATCH,
        }
    }
}

/// States per GPU call in the GPU rows: large enough that the ~0.1-0.2 ms round trip of a
/// call is amortised (`bench backend`: throughput is flat from ~1e4 states on lavapipe).
pub const DEFAULT_GPU_BATCH: usize = 100_000;

/// One method at one setting.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoadsRow {
    /// `"rule"` or `"baseline"` (CPU), `"rule-gpu-f64"` or `"rule-gpu-f32"` (GPU backend).
    pub method: String,
    /// The accuracy level (rule) or `"n×n"` grid (baseline).
    pub setting: String,
    /// Device: `"cpu"` or the GPU adapter's description.
    pub device: String,
    /// Evaluations per second on one thread (`None` for GPU rows).
    pub evals_per_s_1thread: Option<f64>,
    /// Evaluations per second on the parallel pool (CPU rows) or on the GPU, batched
    /// (`batch_states` per call, whole `LoadEvaluator::evaluate` round trip).
    pub evals_per_s_parallel: f64,
    /// States per timed call: the benchmark states (CPU rule), the timing subset
    /// (baseline) or `gpu_batch` (GPU rows).
    pub batch_states: usize,
    /// Largest relative error of the load vector over the states measured.
    pub max_rel_error: f64,
    /// Median relative error.
    pub median_rel_error: f64,
    /// States the error was measured on.
    pub error_states: usize,
    /// Mean `z`-slices per state (the rule's cost measure; `n` for the baseline).
    pub mean_slices: f64,
}

/// Everything `bench loads` measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchLoadsReport {
    /// Bearing used (the paper's Table 2).
    pub bearing: BearingParams,
    /// Number of benchmark states.
    pub states: usize,
    /// Threads of the parallel runs.
    pub parallel_threads: usize,
    /// Rows, rule first.
    pub rows: Vec<LoadsRow>,
    /// Rule rate at the 1e-6 level over the baseline rate needed for a max error of 1e-6,
    /// on one thread.
    pub speedup_at_1e6: f64,
    /// How the baseline's rate at 1e-6 was obtained (measured or extrapolated).
    pub speedup_note: String,
    /// Notes: GPU rows skipped (no adapter) or computed with a fallback.
    pub notes: Vec<String>,
}

/// xorshift64*: deterministic benchmark states.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        (x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn in_disc(&mut self, r: f64) -> (f64, f64) {
        let rho = r * self.uniform().sqrt();
        let a = std::f64::consts::TAU * self.uniform();
        (rho * a.cos(), rho * a.sin())
    }
}

/// Tilted, squeezed states of the Table 2 bearing: end eccentricities uniform in the disc
/// of radius 0.95, end velocities up to `δ ω0` in any direction, spin 100 rad/s.
pub fn bench_states(params: &BearingParams, n: usize) -> Vec<BearingState> {
    let mut rng = Rng(0xBE4C_0002);
    let d = params.clearance;
    let omega = 100.0;
    (0..n)
        .map(|_| {
            let (ei, ej) = (rng.in_disc(0.95), rng.in_disc(0.95));
            let (vi, vj) = (rng.in_disc(1.0), rng.in_disc(1.0));
            BearingState {
                xi: ei.0 * d,
                yi: ei.1 * d,
                xj: ej.0 * d,
                yj: ej.1 * d,
                vxi: vi.0 * d * omega,
                vyi: vi.1 * d * omega,
                vxj: vj.0 * d * omega,
                vyj: vj.1 * d * omega,
                omega,
            }
        })
        .collect()
}

/// The GPU rows' timing batch: `n` distinct states drawn like the benchmark states (its
/// first states are the benchmark states). Repeating the benchmark states instead would
/// time the evaluator's dedupe, which integrates each distinct state once, not the kernel
/// (issue 23 item 8: a 2.9e6 evals/s headline against 1.3e5 on distinct states).
pub fn gpu_timing_batch(params: &BearingParams, n: usize) -> Vec<LoadRequest> {
    bench_states(params, n)
        .into_iter()
        .map(|state| LoadRequest { bearing: 0, state })
        .collect()
}

fn rel_error(a: &[f64; 4], e: &[f64; 4]) -> f64 {
    let num: f64 = a.iter().zip(e).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = e.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

fn vector(v: [f64; 4], b: f64) -> [f64; 4] {
    [v[0], v[1], v[2] / b, v[3] / b]
}

fn max_and_median(mut errs: Vec<f64>) -> (f64, f64) {
    errs.sort_by(f64::total_cmp);
    (
        errs.last().copied().unwrap_or(f64::NAN),
        errs.get(errs.len() / 2).copied().unwrap_or(f64::NAN),
    )
}

/// Runs `f` (which does `work` evaluations) until `min_time_s` has passed; evaluations/s.
fn rate(min_time_s: f64, work: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm-up
    let start = Instant::now();
    let mut reps = 0usize;
    loop {
        f();
        reps += 1;
        let t = start.elapsed().as_secs_f64();
        if t >= min_time_s {
            return (reps * work) as f64 / t;
        }
    }
}

fn rule_row(
    params: &BearingParams,
    states: &[BearingState],
    reference: &[[f64; 4]],
    level: f64,
    opts: &BenchLoadsOptions,
) -> LoadsRow {
    let acc = Accuracy::new(level).expect("calibrated level");
    let requests: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let bearings = [*params];
    let mut out: Vec<LoadResult> = Vec::new();
    let timed = |threads: Option<usize>, out: &mut Vec<LoadResult>| {
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(acc, threads)));
        rate(opts.min_time_s, states.len(), || {
            ev.evaluate(&bearings, &requests, out)
        })
    };
    let single = timed(Some(1), &mut out);
    let parallel = timed(opts.threads, &mut out);
    let errs: Vec<f64> = out
        .iter()
        .zip(reference)
        .map(|(r, e)| match r {
            Ok(l) => rel_error(&l.load_vector(params.length), e),
            Err(_) => f64::INFINITY,
        })
        .collect();
    let (max, median) = max_and_median(errs);
    let rule = FilmRule::new(acc.settings());
    let slices: u64 = states
        .iter()
        .filter_map(|s| pack_state(params, s).ok())
        .map(|p| rule.integrate(&p.state).1 as u64)
        .sum();
    LoadsRow {
        method: "rule".into(),
        setting: format!("{level:e}"),
        device: "cpu".into(),
        evals_per_s_1thread: Some(single),
        evals_per_s_parallel: parallel,
        batch_states: states.len(),
        max_rel_error: max,
        median_rel_error: median,
        error_states: states.len(),
        mean_slices: slices as f64 / states.len() as f64,
    }
}

/// The rule on the GPU backend at every accuracy level, f64 then f32 kernel: the error on
/// the benchmark states against the reference, the rate on `opts.gpu_batch` distinct
/// states per call ([`gpu_timing_batch`]). Adapters without f64, or none at all, leave a
/// note instead of rows; a call that fell back to the CPU is noted and its row dropped.
fn gpu_rows(
    params: &BearingParams,
    states: &[BearingState],
    reference: &[[f64; 4]],
    opts: &BenchLoadsOptions,
    notes: &mut Vec<String>,
) -> Vec<LoadsRow> {
    let bearings = [*params];
    let requests: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let batch = gpu_timing_batch(params, opts.gpu_batch);
    let mut rows = Vec::new();
    for (precision, tag) in [(Precision::F64, "f64"), (Precision::F32, "f32")] {
        for &level in ACCURACY_LEVELS.iter() {
            let acc = Accuracy::new(level).expect("calibrated level");
            let gpu = GpuBackend::new(
                acc,
                GpuOptions {
                    precision: Some(precision),
                    ..GpuOptions::default()
                },
            );
            let gpu = match gpu {
                Ok(g) => g,
                Err(e @ BackendError::NoAdapter(_)) => {
                    notes.push(format!("GPU {tag} rows skipped: {e}"));
                    break;
                }
                Err(e) => {
                    notes.push(format!("GPU {tag} row at {level:e} skipped: {e}"));
                    continue;
                }
            };
            let device = gpu.info().device;
            let mut ev = LoadEvaluator::new(Box::new(gpu));
            let mut out: Vec<LoadResult> = Vec::new();
            ev.evaluate(&bearings, &requests, &mut out);
            let errs: Vec<f64> = out
                .iter()
                .zip(reference)
                .map(|(r, e)| match r {
                    Ok(l) => rel_error(&l.load_vector(params.length), e),
                    Err(_) => f64::INFINITY,
                })
                .collect();
            let (max, median) = max_and_median(errs);
            let rate = rate(opts.min_time_s, batch.len(), || {
                ev.evaluate(&bearings, &batch, &mut out)
            });
            let fallbacks = ev.take_notices();
            if !fallbacks.is_empty() {
                notes.push(format!(
                    "GPU {tag} row at {level:e} dropped (the evaluator fell back to the CPU): {}",
                    fallbacks.join("; ")
                ));
                continue;
            }
            rows.push(LoadsRow {
                method: format!("rule-gpu-{tag}"),
                setting: format!("{level:e}"),
                device,
                evals_per_s_1thread: None,
                evals_per_s_parallel: rate,
                batch_states: batch.len(),
                max_rel_error: max,
                median_rel_error: median,
                error_states: states.len(),
                // Same rule, same panels: the CPU row's slice count holds.
                mean_slices: f64::NAN,
            });
        }
    }
    rows
}

/// States the baseline's error is measured on (1024² costs ~10 ms a state).
const BASELINE_ERROR_STATES: usize = 200;

fn baseline_row(
    params: &BearingParams,
    states: &[BearingState],
    reference: &[[f64; 4]],
    n: usize,
    opts: &BenchLoadsOptions,
    pool: &rayon::ThreadPool,
) -> LoadsRow {
    // n² grid points per state: errors on the same first `BASELINE_ERROR_STATES` states
    // at every grid (so that the observed order compares like with like), each timing
    // pass on ~2e7 points (the rate hardly depends on the state).
    let take = BASELINE_ERROR_STATES.min(states.len());
    let subset = &states[..(20_000_000 / (n * n)).clamp(4, take)];
    let eval = |s: &BearingState| vector(baseline_loads(params, s, n, n), params.length);
    let single = rate(opts.min_time_s, subset.len(), || {
        for s in subset {
            std::hint::black_box(eval(s));
        }
    });
    let parallel = pool.install(|| {
        rate(opts.min_time_s, subset.len(), || {
            subset.par_iter().for_each(|s| {
                std::hint::black_box(eval(s));
            })
        })
    });
    let errs: Vec<f64> = pool.install(|| {
        subset
            .par_iter()
            .zip(&reference[..take])
            .map(|(s, e)| rel_error(&eval(s), e))
            .collect()
    });
    let (max, median) = max_and_median(errs);
    LoadsRow {
        method: "baseline".into(),
        setting: format!("{n}x{n}"),
        device: "cpu".into(),
        evals_per_s_1thread: Some(single),
        evals_per_s_parallel: parallel,
        batch_states: subset.len(),
        max_rel_error: max,
        median_rel_error: median,
        error_states: take,
        mean_slices: n as f64,
    }
}

/// The baseline's single-thread rate at a max error of `target`: measured at the coarsest
/// grid reaching it, else extrapolated from the two finest grids' observed order
/// (error ∝ n^-p, cost ∝ n²).
fn baseline_rate_at(rows: &[LoadsRow], grids: &[usize], target: f64) -> (f64, String) {
    let base: Vec<(&LoadsRow, usize)> = rows
        .iter()
        .filter(|r| r.method == "baseline")
        .zip(grids.iter().copied())
        .collect();
    if let Some((r, n)) = base.iter().find(|(r, _)| r.max_rel_error <= target) {
        return (
            r.evals_per_s_1thread.unwrap_or(f64::NAN),
            format!(
                "measured: the {n}x{n} baseline grid reaches max error {:.2e}",
                r.max_rel_error
            ),
        );
    }
    if base.len() < 2 {
        return (f64::NAN, "no baseline grids measured".into());
    }
    let (r1, n1) = base[base.len() - 2];
    let (r2, n2) = base[base.len() - 1];
    let order = (r1.max_rel_error / r2.max_rel_error).ln() / (n2 as f64 / n1 as f64).ln();
    let n_needed = n2 as f64 * (r2.max_rel_error / target).powf(1.0 / order);
    let rate = r2.evals_per_s_1thread.unwrap_or(f64::NAN) * (n2 as f64 / n_needed).powi(2);
    // The baseline's asymptotic order is 2 (kinks at the arc ends); a higher observed
    // order between the finest grids makes the extrapolation favour the baseline.
    let n_order2 = n2 as f64 * (r2.max_rel_error / target).sqrt();
    (
        rate,
        format!(
            "extrapolated: no grid up to {n2}x{n2} reaches {target:e} (max error {:.2e} there); \
             the observed order {order:.2} between {n1} and {n2} gives n ≈ {n_needed:.0}, and \
             the rate scales as 1/n²; the asymptotic order 2 would give n ≈ {n_order2:.0} and \
             a {:.1} times larger speed-up",
            r2.max_rel_error,
            (n_order2 / n_needed).powi(2)
        ),
    )
}

/// The report as a markdown table with the speed-up sentence.
pub fn bench_loads_markdown(report: &BenchLoadsReport) -> String {
    let mut md = String::new();
    md.push_str(&format!(
        "Load vector `(W_x, W_y, M_x/B, M_y/B)`, Table 2 bearing, {} tilted squeezed states \
         (end eccentricity ratios <= 0.95, spin 100 rad/s); errors against the adaptive \
         reference at 1e-14; parallel = {} threads (CPU rows), one batch of `batch` states \
         per call (GPU rows: the whole `LoadEvaluator::evaluate` round trip, on distinct states \
         drawn like the benchmark states, so the evaluator's dedupe removes none).\n\n",
        report.states, report.parallel_threads
    ));
    let mut devices: Vec<&str> = Vec::new();
    for r in report.rows.iter().filter(|r| r.device != "cpu") {
        if !devices.contains(&r.device.as_str()) {
            devices.push(&r.device);
        }
    }
    for d in devices {
        md.push_str(&format!("GPU device: `{d}`\n\n"));
    }
    md.push_str(
        "| method | setting | evals/s (1 thread) | evals/s (parallel / GPU) | batch | max rel. error | median rel. error | error states | mean slices |\n",
    );
    md.push_str("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for r in &report.rows {
        md.push_str(&format!(
            "| {} | {} | {} | {:.3e} | {} | {:.2e} | {:.2e} | {} | {} |\n",
            r.method,
            r.setting,
            r.evals_per_s_1thread
                .map_or("–".to_string(), |x| format!("{x:.3e}")),
            r.evals_per_s_parallel,
            r.batch_states,
            r.max_rel_error,
            r.median_rel_error,
            r.error_states,
            if r.mean_slices.is_finite() {
                format!("{:.1}", r.mean_slices)
            } else {
                "as CPU".to_string()
            }
        ));
    }
    md.push_str(&format!(
        "\nAt 1e-6 error the default rule is {:.0} times faster than the baseline (one thread; {}).\n",
        report.speedup_at_1e6, report.speedup_note
    ));
    for n in &report.notes {
        md.push_str(&format!("\nNote: {n}\n"));
    }
    md
}

fn write(path: &Path, text: &str) -> Result<(), AppError> {
    std::fs::write(path, text).map_err(|source| AppError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Runs the benchmark and writes `bench-loads.json`, `bench-loads.md` and
/// `bench-loads.svg` into `opts.out`.
pub fn bench_loads(opts: &BenchLoadsOptions) -> Result<BenchLoadsReport, AppError> {
    if opts.states == 0 {
        return Err(AppError::input("--states", "must be at least 1"));
    }
    if !(opts.min_time_s.is_finite() && opts.min_time_s >= 0.0) {
        return Err(AppError::input(
            "--min-time",
            format!(
                "must be a non-negative number of seconds ({})",
                opts.min_time_s
            ),
        ));
    }
    if let Some(&n) = opts.baseline_grids.iter().find(|&&n| n == 0) {
        return Err(AppError::input(
            "--grids",
            format!("grid size {n} must be at least 1"),
        ));
    }
    std::fs::create_dir_all(&opts.out).map_err(|source| AppError::Io {
        path: opts.out.display().to_string(),
        source,
    })?;
    let params = BearingParams::paper_table2();
    let states = bench_states(&params, opts.states);
    let reference: Vec<[f64; 4]> = states
        .par_iter()
        .map(|s| {
            reference_loads(&params, s, 1e-14)
                .map(|v| vector(v, params.length))
                .unwrap_or([f64::NAN; 4])
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| AppError::input("--threads", e.to_string()))?;
    let mut rows: Vec<LoadsRow> = ACCURACY_LEVELS
        .iter()
        .map(|&level| rule_row(&params, &states, &reference, level, opts))
        .collect();
    for &n in &opts.baseline_grids {
        rows.push(baseline_row(&params, &states, &reference, n, opts, &pool));
    }
    let mut notes = Vec::new();
    if opts.gpu_batch > 0 {
        rows.extend(gpu_rows(&params, &states, &reference, opts, &mut notes));
    } else {
        notes.push("GPU rows not run (gpu batch 0)".into());
    }
    let default_rate = rows
        .iter()
        .find(|r| r.method == "rule" && r.setting == format!("{:e}", Accuracy::default().rtol()))
        .and_then(|r| r.evals_per_s_1thread)
        .unwrap_or(f64::NAN);
    let (base_rate, note) = baseline_rate_at(&rows, &opts.baseline_grids, 1e-6);
    let report = BenchLoadsReport {
        bearing: params,
        states: opts.states,
        parallel_threads: pool.current_num_threads(),
        rows,
        speedup_at_1e6: default_rate / base_rate,
        speedup_note: note,
        notes,
    };
    let json = serde_json::to_string_pretty(&report)
        .map_err(|e| AppError::input("report", e.to_string()))?;
    write(&opts.out.join("bench-loads.json"), &json)?;
    write(
        &opts.out.join("bench-loads.md"),
        &bench_loads_markdown(&report),
    )?;
    let curve = |method: &str, parallel: bool| -> Vec<(f64, f64)> {
        report
            .rows
            .iter()
            .filter(|r| r.method == method)
            .map(|r| {
                let rate = if parallel {
                    r.evals_per_s_parallel
                } else {
                    r.evals_per_s_1thread.unwrap_or(f64::NAN)
                };
                // A rule error at rounding level reads as 1e-16 on the log axis.
                (rate, r.max_rel_error.max(1e-16))
            })
            .collect()
    };
    let series = [
        Series {
            label: "graded rule, 1 thread",
            points: curve("rule", false),
        },
        Series {
            label: "graded rule, parallel",
            points: curve("rule", true),
        },
        Series {
            label: "baseline, 1 thread",
            points: curve("baseline", false),
        },
        Series {
            label: "baseline, parallel",
            points: curve("baseline", true),
        },
        Series {
            label: "graded rule, GPU f64 (batched)",
            points: curve("rule-gpu-f64", true),
        },
        Series {
            label: "graded rule, GPU f32 (batched)",
            points: curve("rule-gpu-f32", true),
        },
    ];
    let series: Vec<Series<'_>> = series
        .into_iter()
        .filter(|s| !s.points.is_empty())
        .collect();
    let svg = line_plot_svg(
        "Film loads: work-precision (Table 2 bearing, eps <= 0.95)",
        "evaluations per second",
        "max relative error of (Wx, Wy, Mx/B, My/B)",
        &series,
        Scale::Log,
        Scale::Log,
    )
    .map_err(|e| AppError::input("plot", e))?;
    write(&opts.out.join("bench-loads.svg"), &svg)?;
    Ok(report)
}
