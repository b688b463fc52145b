//! The `bearing-sweep` command line: argument parsing only; the work is in the library.

use std::process::ExitCode;

use bearing_sweep::backend::BackendKind;
use bearing_sweep::bench::{bench_loads, bench_loads_markdown, BenchLoadsOptions};
use bearing_sweep::cli::{eval_json, read_input, EvalOptions};
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
    /// Benchmarks (timings and errors written as JSON, markdown and SVG).
    Bench {
        #[command(subcommand)]
        what: BenchWhat,
    },
}

#[derive(Subcommand)]
enum BenchWhat {
    /// Film loads: evaluations/s against error, graded rule at each accuracy level vs the
    /// brute-force baseline, one thread and parallel.
    Loads {
        /// Threads of the parallel runs (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Number of benchmark states.
        #[arg(long, default_value_t = 2000)]
        states: usize,
        /// Output folder for bench-loads.{json,md,svg}.
        #[arg(long, default_value = "out/bench")]
        out: std::path::PathBuf,
        /// Baseline grids n (n × n in θ × z), comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "32,64,128,256,512,1024,2048"
        )]
        grids: Vec<usize>,
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
                BenchWhat::Loads {
                    threads,
                    states,
                    out,
                    grids,
                },
        } => bench_loads(&BenchLoadsOptions {
            threads,
            states,
            out,
            baseline_grids: grids,
            ..Default::default()
        })
        .map(|report| {
            print!("{}", bench_loads_markdown(&report));
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
