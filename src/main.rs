//! The `bearing-sweep` command line: argument parsing only; the work is in the library.

use std::process::ExitCode;

use bearing_sweep::backend::BackendKind;
use bearing_sweep::cli::{
    bench_rotor, bench_rotor_batch, eval_json, is_sweep_spec, merge_command, read_input,
    run_command, run_scene_file, BenchRotorOptions, EvalOptions, RunOptions, SweepRunOptions,
};
use bearing_sweep::sweep::runner::{BatchSize, Shard};
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
    /// Simulate a scene file (writes OUT/<file stem>/result.json and SVG figures 7-10), or
    /// run a sweep spec (a file with `base` or `kind`; writes OUT/<spec stem>/result.json,
    /// streaming variants to result.jsonl, resumable; see README "Sweeps").
    Run {
        /// Scene file or sweep spec (JSON).
        file: String,
        /// Output root folder.
        #[arg(long, default_value = "out")]
        out: std::path::PathBuf,
        /// Backend for the film loads: cpu, gpu or auto.
        #[arg(long, default_value = "cpu")]
        backend: BackendKind,
        /// Relative accuracy of the film loads (1e-3, 1e-6, 1e-9 or 1e-12).
        #[arg(long, default_value_t = 1e-6)]
        accuracy: f64,
        /// Sweeps: run only shard K of N (variant i belongs to shard i mod N).
        #[arg(long)]
        shard: Option<Shard>,
        /// Sweeps: variants per lockstep batch, or `auto`.
        #[arg(long, default_value = "auto")]
        batch_size: BatchSize,
        /// Sweeps: no progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Merge sweep shard results into the result of the unsharded run.
    Merge {
        /// Merged result file.
        out: String,
        /// Shard result files.
        #[arg(required = true)]
        shards: Vec<String>,
    },
    /// Work-precision of the integrators on the paper example (BENCHMARKS.md): prints a
    /// markdown table, writes log-log SVG diagrams to --out.
    BenchRotor {
        /// Simulated time, s.
        #[arg(long, default_value_t = 0.5)]
        t_end: f64,
        /// Film-load accuracy level.
        #[arg(long, default_value_t = 1e-12)]
        accuracy: f64,
        /// Timing repeats per configuration (the fastest counts).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Output folder for the diagrams.
        #[arg(long, default_value = "out/bench-rotor")]
        out: std::path::PathBuf,
        /// Instead of the work-precision study: lockstep batches of these sizes against
        /// one-by-one runs (comma-separated, e.g. 1,16,256).
        #[arg(long, value_delimiter = ',')]
        batch: Vec<usize>,
        /// CPU threads for --batch (default: all).
        #[arg(long)]
        threads: Option<usize>,
        /// Replace both bearings' viscosity (Pa·s): the stiff variant of the study.
        #[arg(long)]
        viscosity: Option<f64>,
    },
}

fn print_lines(lines: Vec<String>) {
    for l in lines {
        eprintln!("{l}");
    }
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
        Command::Run {
            file,
            out,
            backend,
            accuracy,
            shard,
            batch_size,
            quiet,
        } => read_input(&file).and_then(|text| {
            if is_sweep_spec(&text) {
                let opts = SweepRunOptions {
                    out,
                    shard,
                    batch: batch_size,
                    backend,
                    accuracy,
                    quiet,
                };
                run_command(&file, &text, &opts, &mut |n| eprintln!("{n}")).map(print_lines)
            } else {
                if shard.is_some() {
                    return Err(bearing_sweep::cli::CliError::input(
                        "--shard",
                        "only sweep specs are sharded (this file is a scene: wrap it as {\"base\": \"FILE\"})",
                    ));
                }
                let report = run_scene_file(
                    &file,
                    &text,
                    &RunOptions {
                        backend,
                        accuracy,
                        out,
                    },
                )?;
                for n in report.notices {
                    eprintln!("{n}");
                }
                for l in report.lines {
                    println!("{l}");
                }
                for f in report.files {
                    println!("wrote {}", f.display());
                }
                Ok(())
            }
        }),
        Command::Merge { out, shards } => merge_command(&out, &shards).map(print_lines),
        Command::BenchRotor {
            t_end,
            batch,
            threads,
            ..
        } if !batch.is_empty() => {
            println!("| variants | threads | finished | evaluator calls (batch) | states per call | wall batch (s) | main-thread CPU batch (s) | evaluator calls (one by one) | wall one by one (s) | main-thread CPU one by one (s) |");
            println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |");
            batch
                .iter()
                .try_for_each(|&n| bench_rotor_batch(n, t_end, threads).map(|row| print!("{row}")))
        }
        Command::BenchRotor {
            t_end,
            accuracy,
            repeats,
            out,
            viscosity,
            ..
        } => bench_rotor(&BenchRotorOptions {
            t_end,
            accuracy,
            repeats,
            out,
            viscosity,
        })
        .map(|r| {
            println!("{}\n", r.reference);
            print!("{}", r.table);
            for f in r.files {
                println!("wrote {}", f.display());
            }
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
