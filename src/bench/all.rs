//! `bench all`: every work-precision benchmark in one command (film loads on CPU and GPU,
//! backend throughput against batch size, rotor integrators on the paper example and its
//! stiff variant, lockstep batches), written into one folder with an `index.md` that
//! lists the machine, the settings, the headline figures (each with its error) and the
//! files. `--full` uses the settings of BENCHMARKS.md (about 2 min on the shared 2-core
//! machine of BENCHMARKS.md); the default quick settings take about 20-30 s there.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::backend::{BenchOptions, BenchReport, BenchTarget};
use super::loads::{bench_loads, bench_loads_markdown, BenchLoadsOptions, BenchLoadsReport};
use super::{bench_backend, bench_rotor, bench_rotor_batch, BenchRotorOptions};
use crate::app::AppError;
use crate::backend::{BackendError, GpuOptions};
use crate::bearing::Accuracy;
use crate::plot::{line_plot_svg, Scale, Series};

/// Viscosity of the stiff rotor variant, Pa·s (83 times the paper's 0.0242; BENCHMARKS.md
/// "A stiff film").
pub const STIFF_VISCOSITY_PA_S: f64 = 2.0;

/// What `bench all` runs.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchAllOptions {
    /// Output folder (subfolders `loads/`, `backend/`, `rotor/` and `index.md`).
    pub out: PathBuf,
    /// `bench loads` settings (its `out` is replaced by `OUT/loads`).
    pub loads: BenchLoadsOptions,
    /// `bench backend` settings (the target falls back to the CPU without an adapter).
    pub backend: BenchOptions,
    /// `bench rotor` settings (its `out` is replaced by `OUT/rotor`, `viscosity` unused).
    pub rotor: BenchRotorOptions,
    /// Also run the stiff variant (viscosity [`STIFF_VISCOSITY_PA_S`]).
    pub rotor_stiff: bool,
    /// Lockstep batch sizes of `bench rotor --batch` (empty: skipped).
    pub rotor_batch: Vec<usize>,
    /// Simulated time of the lockstep batches, s.
    pub rotor_batch_t_end: f64,
    /// Label of the settings for the index (`quick`, `full`, ...).
    pub label: String,
}

impl BenchAllOptions {
    /// Quick settings (about 20-30 s on the 2-core machine of BENCHMARKS.md): fewer
    /// states and shorter timings than BENCHMARKS.md, the rotor studies over 0.1 s.
    pub fn quick(out: PathBuf) -> Self {
        BenchAllOptions {
            loads: BenchLoadsOptions {
                states: 500,
                min_time_s: 0.2,
                ..BenchLoadsOptions::default()
            },
            backend: BenchOptions {
                sizes: vec![1, 100, 10_000, 100_000],
                min_time_s: 0.3,
                max_reps: 20,
                ..BenchOptions::default()
            },
            rotor: BenchRotorOptions {
                t_end: 0.1,
                accuracy: 1e-12,
                repeats: 1,
                out: PathBuf::new(),
                viscosity: None,
            },
            rotor_stiff: true,
            rotor_batch: vec![1, 16, 64],
            rotor_batch_t_end: 0.1,
            label: "quick".into(),
            out,
        }
    }

    /// The settings of the figures in BENCHMARKS.md (about 2 min on 2 cores).
    pub fn full(out: PathBuf) -> Self {
        BenchAllOptions {
            loads: BenchLoadsOptions::default(),
            backend: BenchOptions {
                min_time_s: 2.0,
                ..BenchOptions::default()
            },
            rotor: BenchRotorOptions {
                t_end: 0.5,
                accuracy: 1e-12,
                repeats: 3,
                out: PathBuf::new(),
                viscosity: None,
            },
            rotor_stiff: true,
            rotor_batch: vec![1, 16, 64, 256],
            rotor_batch_t_end: 0.1,
            label: "full: the settings of BENCHMARKS.md".into(),
            out,
        }
    }
}

/// What `bench all` wrote.
#[derive(Debug)]
pub struct BenchAllReport {
    /// Every file written, `index.md` last.
    pub files: Vec<PathBuf>,
    /// The index's text.
    pub index: String,
    /// Wall time of the whole run, s.
    pub wall_s: f64,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> AppError + '_ {
    move |source| AppError::Io {
        path: path.display().to_string(),
        source,
    }
}

fn write(path: PathBuf, text: &str, files: &mut Vec<PathBuf>) -> Result<(), AppError> {
    std::fs::write(&path, text).map_err(io(&path))?;
    files.push(path);
    Ok(())
}

/// The machine line of the index: CPU model (as `lscpu`'s "Model name"), logical CPUs and
/// the load average (the benchmarks' machine may be shared).
pub fn machine_description() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cpus = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{model}, {cpus} logical CPUs, load average {}",
        load_average()
    )
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "n/a".into())
}

fn backend_svg(report: &BenchReport) -> Result<String, AppError> {
    let curve = |name: &str, kernel: bool| -> Vec<(f64, f64)> {
        report
            .rows
            .iter()
            .filter(|r| r.backend == name)
            .map(|r| {
                let rate = if kernel {
                    r.kernel_states_per_s
                } else {
                    r.end_to_end_states_per_s
                };
                (r.size as f64, rate)
            })
            .collect()
    };
    let series: Vec<Series<'_>> = [
        ("cpu, end to end", curve("cpu", false)),
        ("cpu, kernel", curve("cpu", true)),
        ("gpu, end to end", curve("gpu", false)),
        ("gpu, kernel", curve("gpu", true)),
    ]
    .into_iter()
    .filter(|(_, p)| !p.is_empty())
    .map(|(label, points)| Series { label, points })
    .collect();
    line_plot_svg(
        "Film-load throughput against batch size (Table 2 bearing)",
        "states per call",
        "states per second",
        &series,
        Scale::Log,
        Scale::Log,
    )
    .map_err(|e| AppError::input("plot", e))
}

/// Runs the backend benchmark on both backends, or on the CPU alone with a note when no
/// GPU adapter exists.
fn run_backend(
    opts: &BenchOptions,
    notes: &mut Vec<String>,
) -> Result<(BenchReport, String), AppError> {
    match bench_backend(opts) {
        Err(AppError::Backend(e @ BackendError::NoAdapter(_)))
            if opts.target != BenchTarget::Cpu =>
        {
            notes.push(format!("backend benchmark: GPU skipped ({e})"));
            bench_backend(&BenchOptions {
                target: BenchTarget::Cpu,
                ..opts.clone()
            })
        }
        other => other,
    }
}

fn fmt_rate(x: f64) -> String {
    format!("{x:.3e}")
}

/// Headline figures of the loads benchmark, each with its error.
fn loads_headlines(r: &BenchLoadsReport, s: &mut String) {
    let default = format!("{:e}", Accuracy::default().rtol());
    for row in r.rows.iter().filter(|x| x.setting == default) {
        let rate = match row.evals_per_s_1thread {
            Some(one) => format!(
                "{} evals/s on 1 thread, {} on {} threads",
                fmt_rate(one),
                fmt_rate(row.evals_per_s_parallel),
                r.parallel_threads
            ),
            None => format!(
                "{} evals/s in batches of {} (`{}`)",
                fmt_rate(row.evals_per_s_parallel),
                row.batch_states,
                row.device
            ),
        };
        let _ = writeln!(
            s,
            "| film loads, {} at level 1e-6 | {rate} | max rel. error {:.2e} (median {:.2e}) vs adaptive reference 1e-14, {} states | [loads](loads/bench-loads.md) |",
            row.method, row.max_rel_error, row.median_rel_error, row.error_states
        );
    }
    let rule_error = r
        .rows
        .iter()
        .find(|x| x.method == "rule" && x.setting == default)
        .map_or(f64::NAN, |x| x.max_rel_error);
    let _ = writeln!(
        s,
        "| rule at 1e-6 vs brute-force baseline at max error <= 1e-6 (1 thread) | {:.0}x faster | rule max rel. error {rule_error:.2e}; baseline {} | [loads](loads/bench-loads.md) |",
        r.speedup_at_1e6,
        r.speedup_note.replace('|', "/")
    );
}

/// Runs everything and writes `OUT/index.md` with the files of each benchmark.
pub fn bench_all(opts: &BenchAllOptions) -> Result<BenchAllReport, AppError> {
    let start = Instant::now();
    let machine_before = machine_description();
    std::fs::create_dir_all(&opts.out).map_err(io(&opts.out))?;
    let mut files = Vec::new();
    let mut notes = Vec::new();
    let mut headlines = String::new();
    let mut timings = String::new();

    // Film loads: CPU rule and baseline, GPU rule (f64, f32).
    let t = Instant::now();
    let loads_out = opts.out.join("loads");
    let loads = bench_loads(&BenchLoadsOptions {
        out: loads_out.clone(),
        ..opts.loads.clone()
    })?;
    for f in ["bench-loads.json", "bench-loads.md", "bench-loads.svg"] {
        files.push(loads_out.join(f));
    }
    loads_headlines(&loads, &mut headlines);
    notes.extend(loads.notes.iter().map(|n| format!("loads: {n}")));
    let _ = writeln!(
        timings,
        "| loads | {} states, grids {:?}, min {} s per timing, GPU batch {} | {:.1} |",
        opts.loads.states,
        opts.loads.baseline_grids,
        opts.loads.min_time_s,
        opts.loads.gpu_batch,
        t.elapsed().as_secs_f64()
    );

    // Backend throughput against batch size.
    let t = Instant::now();
    let backend_out = opts.out.join("backend");
    std::fs::create_dir_all(&backend_out).map_err(io(&backend_out))?;
    let backend_opts = BenchOptions {
        gpu: GpuOptions::from_env()?,
        ..opts.backend.clone()
    };
    let (backend, backend_md) = run_backend(&backend_opts, &mut notes)?;
    write(
        backend_out.join("bench-backend.md"),
        &backend_md,
        &mut files,
    )?;
    let json = serde_json::to_string_pretty(&backend)
        .map_err(|e| AppError::input("report", e.to_string()))?;
    write(backend_out.join("bench-backend.json"), &json, &mut files)?;
    write(
        backend_out.join("bench-backend.svg"),
        &backend_svg(&backend)?,
        &mut files,
    )?;
    if let Some(&largest) = backend_opts.sizes.iter().max() {
        for row in backend.rows.iter().filter(|r| r.size == largest) {
            let _ = writeln!(
                headlines,
                "| backend {} ({:?}) at {} states per call | {} states/s end to end, {} kernel ({:.2} GFLOP/s counted) | max rel. error {:.1e} vs the CPU kernel (rule level {:e}) | [backend](backend/bench-backend.md) |",
                row.backend,
                row.precision,
                row.size,
                fmt_rate(row.end_to_end_states_per_s),
                fmt_rate(row.kernel_states_per_s),
                row.kernel_gflops,
                row.max_rel_error,
                backend_opts.accuracy.rtol()
            );
        }
    }
    let _ = writeln!(
        timings,
        "| backend | sizes {:?}, min {} s, max {} reps | {:.1} |",
        backend_opts.sizes,
        backend_opts.min_time_s,
        backend_opts.max_reps,
        t.elapsed().as_secs_f64()
    );

    // Rotor integrators: paper example, stiff variant, lockstep batches.
    let rotor_out = opts.out.join("rotor");
    let mut rotor_md = String::new();
    let mut variants = vec![None];
    if opts.rotor_stiff {
        variants.push(Some(STIFF_VISCOSITY_PA_S));
    }
    for viscosity in variants {
        let t = Instant::now();
        let r = bench_rotor(&BenchRotorOptions {
            out: rotor_out.clone(),
            viscosity,
            ..opts.rotor.clone()
        })?;
        let title = viscosity.map_or("Paper example".to_string(), |mu| {
            format!("Stiff variant: viscosity {mu} Pa·s")
        });
        let _ = write!(
            rotor_md,
            "## {title}, {} s, film loads at {:e}\n\n{}\n\n{}\n",
            opts.rotor.t_end, opts.rotor.accuracy, r.reference, r.table
        );
        for row in r
            .rows
            .iter()
            .filter(|x| x.setting == 1e-6 && x.method != "rk4")
        {
            let _ = writeln!(
                headlines,
                "| rotor{}, {} at rtol = atol = 1e-6, {} s | {:.3} s wall, {} load evaluations, {} steps | max \\|G - G_ref\\| {:.2e} m vs dopri5 at 1e-13 | [rotor](rotor/bench-rotor.md) |",
                viscosity.map_or(String::new(), |mu| format!(" (viscosity {mu} Pa·s)")),
                row.method,
                opts.rotor.t_end,
                row.wall_s,
                row.load_evaluations,
                row.steps,
                row.error_m
            );
        }
        files.extend(r.files);
        let _ = writeln!(
            timings,
            "| rotor{} | t_end {} s, {} repeat(s) | {:.1} |",
            viscosity.map_or(String::new(), |mu| format!(" (viscosity {mu})")),
            opts.rotor.t_end,
            opts.rotor.repeats,
            t.elapsed().as_secs_f64()
        );
    }
    if !opts.rotor_batch.is_empty() {
        let t = Instant::now();
        let _ = write!(
            rotor_md,
            "## Lockstep batches, {} s, CPU backend on 1 thread\n\n\
             | variants | threads | finished | evaluator calls (batch) | states per call | wall batch (s) | main-thread CPU batch (s) | evaluator calls (one by one) | wall one by one (s) | main-thread CPU one by one (s) |\n\
             | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
            opts.rotor_batch_t_end
        );
        for &n in &opts.rotor_batch {
            rotor_md.push_str(&bench_rotor_batch(n, opts.rotor_batch_t_end, Some(1))?);
        }
        let _ = writeln!(
            timings,
            "| rotor batches | sizes {:?}, t_end {} s | {:.1} |",
            opts.rotor_batch,
            opts.rotor_batch_t_end,
            t.elapsed().as_secs_f64()
        );
    }
    write(rotor_out.join("bench-rotor.md"), &rotor_md, &mut files)?;

    let wall_s = start.elapsed().as_secs_f64();
    let mut index = String::new();
    let _ = writeln!(index, "# bearing-sweep benchmarks ({})\n", opts.label);
    let _ = writeln!(
        index,
        "Command: `bearing-sweep bench all --out {}{}` (bearing-sweep {}, `--release`).\n",
        opts.out.display(),
        if opts.label.starts_with("full") {
            " --full"
        } else {
            ""
        },
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(index, "Machine: {machine_before} (at the start); load average {} at the end. Timings on a shared machine scatter; the counts (load evaluations, steps, slices, flops) and the errors do not.\n", load_average());
    let _ = writeln!(index, "Total wall time: {wall_s:.1} s.\n");
    let _ = writeln!(index, "## Headline figures\n");
    let _ = writeln!(index, "| figure | value | error (against) | details |");
    let _ = writeln!(index, "| --- | --- | --- | --- |");
    index.push_str(&headlines);
    let _ = writeln!(index, "\n## Parts\n");
    let _ = writeln!(index, "| part | settings | wall (s) |");
    let _ = writeln!(index, "| --- | --- | ---: |");
    index.push_str(&timings);
    let _ = writeln!(index, "\n## Files\n");
    for f in &files {
        let rel = f.strip_prefix(&opts.out).unwrap_or(f);
        let _ = writeln!(index, "- [{0}]({0})", rel.display());
    }
    if !notes.is_empty() {
        let _ = writeln!(index, "\n## Notes\n");
        for n in &notes {
            let _ = writeln!(index, "- {n}");
        }
    }
    let _ = writeln!(index, "\n## Film loads\n\n{}", bench_loads_markdown(&loads));
    write(opts.out.join("index.md"), &index, &mut files)?;
    Ok(BenchAllReport {
        files,
        index,
        wall_s,
    })
}
