//! `bearing-sweep bench backend`: runs [`super::backend::run_bench`] and formats
//! its report as Markdown (for BENCHMARKS.md) and JSON.

use std::fmt::Write;

use super::backend::{run_bench, BenchOptions, BenchReport};
use crate::app::AppError;

/// Runs the backend benchmark; returns the report and its Markdown rendering. Without a
/// peak in `options`, `BEARING_SWEEP_PEAK_GFLOPS` (GFLOP/s, e.g. 34000 for the FP64 vector
/// peak of an H100 or H200) sets it, for the achieved fraction of peak.
pub fn bench_backend(options: &BenchOptions) -> Result<(BenchReport, String), AppError> {
    let mut options = options.clone();
    if options.peak_gflops.is_none() {
        if let Ok(v) = std::env::var("BEARING_SWEEP_PEAK_GFLOPS") {
            let peak = v
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|p| *p > 0.0)
                .ok_or_else(|| {
                    AppError::input(
                        "BEARING_SWEEP_PEAK_GFLOPS",
                        format!("`{v}` (expected a positive number of GFLOP/s)"),
                    )
                })?;
            options.peak_gflops = Some(peak);
        }
    }
    let options = &options;
    let report = run_bench(options)?;
    let md = render(&report, options);
    Ok((report, md))
}

fn render(r: &BenchReport, o: &BenchOptions) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Accuracy level {:e}, end eccentricity ratios up to {}, CPU backend on {} threads.\n",
        o.accuracy.rtol(),
        o.max_ratio,
        o.cpu_threads
    );
    let mut devices: Vec<String> = Vec::new();
    for row in &r.rows {
        let lanes = row
            .lanes
            .map_or(String::new(), |l| format!(", {l} lane(s) per state"));
        let d = format!(
            "- `{}`: {} ({:?}{lanes})",
            row.backend, row.device, row.precision
        );
        if !devices.contains(&d) {
            devices.push(d);
        }
    }
    let _ = writeln!(s, "{}\n", devices.join("\n"));
    let _ = writeln!(
        s,
        "| backend | batch | reps | round trip (s) | states/s end to end | kernel (s) | kernel timer | states/s kernel | GFLOP/s | % of peak | host µs/state | max rel. error vs CPU |"
    );
    let _ = writeln!(
        s,
        "| --- | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: |"
    );
    for row in &r.rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.3e} | {:.3e} | {:.3e} | {} | {:.3e} | {:.2} | {} | {:.3} | {:.1e} |",
            row.backend,
            row.size,
            row.reps,
            row.end_to_end_s,
            row.end_to_end_states_per_s,
            row.kernel_s,
            row.kernel_timer,
            row.kernel_states_per_s,
            row.kernel_gflops,
            row.peak_fraction
                .map_or("-".to_string(), |f| format!("{:.2}", 100.0 * f)),
            row.host_us_per_state,
            row.max_rel_error
        );
    }
    let host: Vec<String> = r
        .host_path
        .iter()
        .map(|h| {
            format!(
                "{} states: {:.3} µs/state ({} reps)",
                h.size, h.us_per_state, h.reps
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "\nHost path alone (validate, pack, deduplicate, finish; a kernel that returns at once, \
         rayon's {} thread(s)): {}.",
        rayon::current_num_threads(),
        host.join("; ")
    );
    let f = &r.flops;
    let _ = writeln!(
        s,
        "\nFlops per state (counted, mean over {} states): {:.0} ({:.2} panels, {:.1} slices, {:.1} root-finder sweeps).",
        f.states, f.flops, f.panels, f.slices, f.root_iterations
    );
    let both = ["cpu", "gpu"]
        .iter()
        .all(|b| r.rows.iter().any(|row| row.backend == *b));
    if both {
        let fmt =
            |c: Option<usize>| c.map_or("none in the sizes run".to_string(), |n| n.to_string());
        let _ = writeln!(
            s,
            "GPU overtakes CPU from batch size: end to end {}, kernel alone {}.",
            fmt(r.crossover_end_to_end),
            fmt(r.crossover_kernel)
        );
    }
    for n in &r.notices {
        let _ = writeln!(s, "\n{n}");
    }
    s
}
