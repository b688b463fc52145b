//! The `bearing-sweep` command line: argument parsing only; the work is in the library.

use std::process::ExitCode;

use bearing_sweep::backend::BackendKind;
use bearing_sweep::cli::{
    eval_json, merge_command, read_input, run_command, EvalOptions, SweepRunOptions,
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
    /// Run a sweep spec (or a friction map): streams variants to OUT.jsonl, writes OUT.
    Run {
        /// Sweep spec JSON (see README, "Sweeps").
        spec: String,
        /// Result file (default `<spec stem>.out.json`, with a shard `<stem>.shard-K-of-N.out.json`).
        #[arg(long)]
        out: Option<std::path::PathBuf>,
        /// Run only shard K of N (variant i belongs to shard i mod N).
        #[arg(long)]
        shard: Option<Shard>,
        /// Variants per lockstep batch, or `auto`.
        #[arg(long, default_value = "auto")]
        batch_size: BatchSize,
        /// Backend for the film loads: cpu, gpu or auto.
        #[arg(long, default_value = "cpu")]
        backend: BackendKind,
        /// Relative accuracy of the film loads.
        #[arg(long, default_value_t = 1e-6)]
        accuracy: f64,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Merge shard results into the result of the unsharded run.
    Merge {
        /// Merged result file.
        out: String,
        /// Shard result files.
        #[arg(required = true)]
        shards: Vec<String>,
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
        Command::Run {
            spec,
            out,
            shard,
            batch_size,
            backend,
            accuracy,
            quiet,
        } => {
            let opts = SweepRunOptions {
                out,
                shard,
                batch: batch_size,
                backend,
                accuracy,
                quiet,
            };
            run_command(&spec, &opts, &mut |n| eprintln!("{n}")).map(|lines| {
                for l in lines {
                    eprintln!("{l}");
                }
            })
        }
        Command::Merge { out, shards } => merge_command(&out, &shards).map(|lines| {
            for l in lines {
                eprintln!("{l}");
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
