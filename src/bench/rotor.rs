//! `bearing-sweep bench rotor`: work-precision of the integrators on the paper example.
//! Each configuration runs alone (one variant, CPU backend on one thread); the error is
//! the largest distance between its sampled `G` and a tight-tolerance reference.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::app::AppError;
use crate::backend::{CpuBackend, LoadEvaluator};
use crate::bearing::Accuracy;
use crate::integrate::Method;
use crate::plot::{line_plot_svg, Scale, Series};
use crate::rotor::{load_scene, simulate_batch, Scene, SimResult};

/// Options of `bench rotor`.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchRotorOptions {
    /// Simulated time, s.
    pub t_end: f64,
    /// Film-load accuracy level (tight, so the load rule's error does not limit the study).
    pub accuracy: f64,
    /// Timing repeats (the fastest counts).
    pub repeats: usize,
    /// Output folder for the SVG diagrams.
    pub out: PathBuf,
    /// Lubricant viscosity of both bearings, Pa·s, replacing the paper's 0.0242 (a
    /// stiffer film: the stiff variant of the study). `None`: the paper's example.
    pub viscosity: Option<f64>,
}

/// One measured configuration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RotorBenchRow {
    /// Method name.
    pub method: &'static str,
    /// `rtol = atol` (adaptive) or the fixed step in s (rk4).
    pub setting: f64,
    /// Max over samples of `|G - G_ref|`, m.
    pub error_m: f64,
    /// Error at `t_end`, m.
    pub end_error_m: f64,
    /// Fastest wall time, s.
    pub wall_s: f64,
    /// Film-load evaluations for integration.
    pub load_evaluations: u64,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Status (`finished` or the failure).
    pub status: String,
}

/// Results of the study.
#[derive(Debug)]
pub struct BenchRotorReport {
    /// Rows, per method in order of tolerance.
    pub rows: Vec<RotorBenchRow>,
    /// The reference run's counters and its distance to a second reference (Radau5).
    pub reference: String,
    /// Markdown table.
    pub table: String,
    /// SVG files written.
    pub files: Vec<PathBuf>,
}

fn base_scene(t_end: f64) -> Result<Scene, AppError> {
    let text = include_str!("../../sweeps/paper-example.json");
    let mut s = load_scene(text)
        .map_err(|e| AppError::input(e.path, e.reason))?
        .remove(0);
    s.integrator.t_end = t_end;
    Ok(s)
}

fn one(scene: &Scene, accuracy: Accuracy) -> (SimResult, f64) {
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(accuracy, Some(1))));
    let t0 = Instant::now();
    let r = simulate_batch(std::slice::from_ref(scene), &mut ev, &mut |_, _| {}).remove(0);
    (r, t0.elapsed().as_secs_f64())
}

fn distance(a: &SimResult, b: &SimResult) -> (f64, f64) {
    let n = a.samples.t.len().min(b.samples.t.len());
    let mut max = 0.0f64;
    let mut last = f64::NAN;
    for k in 0..n {
        let d = (a.samples.x_g[k] - b.samples.x_g[k]).hypot(a.samples.y_g[k] - b.samples.y_g[k]);
        max = max.max(d);
        last = d;
    }
    (max, last)
}

/// Runs the study and writes `<prefix>-work-precision-time.svg` and `<prefix>-work-precision-loads.svg` (prefix `rotor`, or `rotor-stiff` with a viscosity override).
pub fn bench_rotor(opts: &BenchRotorOptions) -> Result<BenchRotorReport, AppError> {
    let accuracy = Accuracy::new(opts.accuracy)
        .ok_or_else(|| AppError::input("--accuracy", "not a calibrated level"))?;
    let mut base = base_scene(opts.t_end)?;
    if let Some(mu) = opts.viscosity {
        if !(mu.is_finite() && mu > 0.0) {
            return Err(AppError::input(
                "--viscosity",
                format!("must be positive ({mu})"),
            ));
        }
        for b in &mut base.bearings {
            b.viscosity = Some(mu);
        }
    }
    let prefix = if opts.viscosity.is_some() {
        "rotor-stiff"
    } else {
        "rotor"
    };
    let mut reference = base.clone();
    reference.integrator.rtol = 1e-13;
    reference.integrator.atol = 1e-13;
    let (ref_run, ref_wall) = one(&reference, accuracy);
    let mut check = base.clone();
    check.integrator.method = Method::Radau5;
    check.integrator.rtol = 1e-12;
    check.integrator.atol = 1e-12;
    let (check_run, _) = one(&check, accuracy);
    let (ref_gap, _) = distance(&ref_run, &check_run);
    let reference_line = format!(
        "reference: dopri5 at rtol = atol = 1e-13 ({} steps, {} load evaluations, {:.2} s); \
         its distance to radau5 at 1e-12: {:.2e} m",
        ref_run.stats.steps, ref_run.stats.load_evaluations, ref_wall, ref_gap
    );
    let mut configs: Vec<(Method, f64)> = Vec::new();
    for tol in [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10] {
        configs.push((Method::Dopri5, tol));
    }
    for tol in [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10] {
        configs.push((Method::Radau5, tol));
    }
    for h in [1e-4, 5e-5, 2.5e-5, 1.25e-5, 6.25e-6] {
        configs.push((Method::Rk4, h));
    }
    let mut rows = Vec::new();
    for (method, setting) in configs {
        let mut s = base.clone();
        s.integrator.method = method;
        if method == Method::Rk4 {
            s.integrator.fixed_step = Some(setting);
        } else {
            s.integrator.rtol = setting;
            s.integrator.atol = setting;
        }
        let mut best = f64::INFINITY;
        let mut result = None;
        for _ in 0..opts.repeats.max(1) {
            let (r, wall) = one(&s, accuracy);
            best = best.min(wall);
            result = Some(r);
        }
        let r = result.expect("at least one repeat");
        let (err, end_err) = distance(&r, &ref_run);
        rows.push(RotorBenchRow {
            method: method.name(),
            setting,
            error_m: err,
            end_error_m: end_err,
            wall_s: best,
            load_evaluations: r.stats.load_evaluations,
            steps: r.stats.steps,
            rejected: r.stats.rejected,
            status: r.status.to_string(),
        });
    }
    let mut table = String::from(
        "| method | rtol = atol / step | max err G (m) | err G at t_end (m) | wall (s) | load evaluations | steps | rejected | status |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in &rows {
        table.push_str(&format!(
            "| {} | {:.3e}{} | {:.2e} | {:.2e} | {:.4} | {} | {} | {} | {} |\n",
            r.method,
            r.setting,
            if r.method == "rk4" { " s" } else { "" },
            r.error_m,
            r.end_error_m,
            r.wall_s,
            r.load_evaluations,
            r.steps,
            r.rejected,
            r.status
        ));
    }
    std::fs::create_dir_all(&opts.out).map_err(|source| AppError::Io {
        path: opts.out.display().to_string(),
        source,
    })?;
    let mut files = Vec::new();
    let finished: Vec<&RotorBenchRow> = rows
        .iter()
        .filter(|r| r.status == "finished" && r.error_m > 0.0)
        .collect();
    for (file, x_label, pick) in [
        (
            "work-precision-time.svg",
            "wall time [s]",
            (|r: &RotorBenchRow| r.wall_s) as fn(&RotorBenchRow) -> f64,
        ),
        (
            "work-precision-loads.svg",
            "film-load evaluations",
            (|r: &RotorBenchRow| r.load_evaluations as f64) as fn(&RotorBenchRow) -> f64,
        ),
    ] {
        let series: Vec<Series<'_>> = ["dopri5", "radau5", "rk4"]
            .iter()
            .map(|m| Series {
                label: m,
                points: finished
                    .iter()
                    .filter(|r| r.method == *m)
                    .map(|r| (pick(r), r.error_m))
                    .collect(),
            })
            .filter(|s| !s.points.is_empty())
            .collect();
        let file = format!("{prefix}-{file}");
        let svg = line_plot_svg(
            &format!(
                "Paper rotor{}, {} s: max |G - G_ref| vs work",
                opts.viscosity
                    .map_or(String::new(), |mu| format!(" (viscosity {mu} Pa s)")),
                opts.t_end
            ),
            x_label,
            "max error of G [m]",
            &series,
            Scale::Log,
            Scale::Log,
        )
        .map_err(|e| AppError::input("plot", e))?;
        let p: PathBuf = Path::new(&opts.out).join(&file);
        std::fs::write(&p, svg).map_err(|source| AppError::Io {
            path: p.display().to_string(),
            source,
        })?;
        files.push(p);
    }
    Ok(BenchRotorReport {
        rows,
        reference: reference_line,
        table,
        files,
    })
}

/// CPU time of the calling thread, s (Linux `/proc/thread-self/schedstat`; `None`
/// elsewhere). On a shared machine this is steadier than wall time.
fn thread_cpu_s() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// The markdown header of the [`bench_rotor_batch`] rows.
pub const ROTOR_BATCH_TABLE_HEADER: &str = "| variants | threads | finished | evaluator calls (batch) | states per call | wall batch (s) | main-thread CPU batch (s) | evaluator calls (one by one) | wall one by one (s) | main-thread CPU one by one (s) |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";

/// Lockstep batch against one-by-one runs: `n` paper-rotor variants (spins spread over
/// 60-140 rad/s, dopri5 at the default tolerance, 1e-6 loads) on the CPU backend with
/// `threads` threads. Returns a markdown table row set.
pub fn bench_rotor_batch(n: usize, t_end: f64, threads: Option<usize>) -> Result<String, AppError> {
    let base = base_scene(t_end)?;
    let accuracy = Accuracy::default();
    let scenes: Vec<Scene> = (0..n)
        .map(|k| {
            let mut s = base.clone();
            s.name = format!("v{k}");
            s.initial.spin = 60.0 + 80.0 * k as f64 / (n.max(2) - 1) as f64;
            s
        })
        .collect();
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(accuracy, threads)));
    let t0 = Instant::now();
    let c0 = thread_cpu_s();
    let batch = simulate_batch(&scenes, &mut ev, &mut |_, _| {});
    let batch_wall = t0.elapsed().as_secs_f64();
    let batch_cpu = c0.and_then(|c| thread_cpu_s().map(|c1| c1 - c));
    let calls = ev.stats().calls;
    let states = ev.stats().states;
    let mut seq_wall = 0.0;
    let mut seq_calls = 0;
    let c0 = thread_cpu_s();
    for s in &scenes {
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(accuracy, threads)));
        let t0 = Instant::now();
        let r = simulate_batch(std::slice::from_ref(s), &mut ev, &mut |_, _| {});
        seq_wall += t0.elapsed().as_secs_f64();
        seq_calls += ev.stats().calls;
        debug_assert_eq!(r[0].status, batch[0].status);
    }
    let seq_cpu = c0.and_then(|c| thread_cpu_s().map(|c1| c1 - c));
    let cpu = |c: Option<f64>| c.map_or("n/a".to_string(), |c| format!("{c:.3}"));
    let finished = batch.iter().filter(|r| r.status.is_finished()).count();
    Ok(format!(
        "| {n} | {} | {finished} | {calls} | {:.0} | {batch_wall:.3} | {} | {seq_calls} | {seq_wall:.3} | {} |\n",
        threads.map_or("all".to_string(), |t| t.to_string()),
        states as f64 / calls.max(1) as f64,
        cpu(batch_cpu),
        cpu(seq_cpu),
    ))
}
