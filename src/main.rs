//! The `bearing-sweep` command line: argument parsing only; the work is in the library.

use std::process::ExitCode;

use bearing_sweep::backend::bench::{BenchOptions, BenchTarget};
use bearing_sweep::backend::BackendKind;
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::cli::{bench_backend, eval_json, read_input, CliError, EvalOptions};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "bearing-sweep",
    version,
    about = "Rigid rotors in hydrodynamic journal bearings, batched on CPU and GPU"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Film loads of bearing states: `{"bearing": {...}, "states": [...]}` -> `{"loads": [...]}`.
    Eval {
        /// Input JSON file, `-` for standard input.
        file: String,
        /// Backend: cpu, gpu or auto.
        #[arg(long, default_value = "cpu")]
        backend: BackendKind,
        /// Relative accuracy of the load vector (1e-3, 1e-6, 1e-9 or 1e-12; rounded tighter).
        #[arg(long, default_value_t = 1e-6)]
        accuracy: f64,
    },
    /// Benchmarks (Markdown report on stdout).
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Backend throughput and latency against batch size, CPU and GPU.
    Backend {
        /// Backends: cpu, gpu or both.
        #[arg(long, default_value = "both")]
        backend: String,
        /// Batch sizes, comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "1,10,100,1000,10000,100000,1000000"
        )]
        sizes: Vec<usize>,
        /// Accuracy level of the rule.
        #[arg(long, default_value_t = 1e-6)]
        accuracy: f64,
        /// CPU backend threads.
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Seconds to spend per measurement (repeats up to --max-reps).
        #[arg(long, default_value_t = 1.0)]
        min_time: f64,
        /// Most repetitions per measurement.
        #[arg(long, default_value_t = 50)]
        max_reps: usize,
        /// Also write the report as JSON to this file.
        #[arg(long)]
        json: Option<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval {
            file,
            backend,
            accuracy,
        } => read_input(&file)
            .and_then(|text| eval_json(&text, EvalOptions { backend, accuracy }))
            .map(|(out, notices)| {
                for n in notices {
                    eprintln!("{n}");
                }
                println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
            }),
        Command::Bench {
            what:
                BenchCommand::Backend {
                    backend,
                    sizes,
                    accuracy,
                    threads,
                    min_time,
                    max_reps,
                    json,
                },
        } => run_bench_backend(&backend, sizes, accuracy, threads, min_time, max_reps, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run_bench_backend(
    backend: &str,
    sizes: Vec<usize>,
    accuracy: f64,
    threads: usize,
    min_time: f64,
    max_reps: usize,
    json: Option<String>,
) -> Result<(), CliError> {
    let target = match backend {
        "cpu" => BenchTarget::Cpu,
        "gpu" => BenchTarget::Gpu,
        "both" => BenchTarget::Both,
        other => {
            return Err(CliError::input(
                "--backend",
                format!("`{other}` (expected cpu, gpu or both)"),
            ))
        }
    };
    if sizes.is_empty() || sizes.contains(&0) {
        return Err(CliError::input("--sizes", "batch sizes must be at least 1"));
    }
    let accuracy = Accuracy::new(accuracy).ok_or_else(|| {
        CliError::input(
            "--accuracy",
            format!("{accuracy} is not a positive number >= 1e-12"),
        )
    })?;
    let options = BenchOptions {
        sizes,
        accuracy,
        cpu_threads: threads.max(1),
        target,
        min_time_s: min_time,
        max_reps,
        // BEARING_SWEEP_GPU_PRECISION=f32 benchmarks the f32 kernel.
        gpu: bearing_sweep::backend::GpuOptions::from_env()?,
        ..BenchOptions::default()
    };
    let (report, md) = bench_backend(&options)?;
    println!("{md}");
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        std::fs::write(&path, text).map_err(|source| CliError::Io { path, source })?;
    }
    Ok(())
}
