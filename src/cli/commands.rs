//! Each subcommand's call into the library (`app`, `service`, `bench`): options built
//! from the arguments, notices and report lines printed, the error mapped to the exit
//! status.

use std::process::ExitCode;

use super::args::*;
use crate::app::{
    coefficients_json_with, stability_scene_file, CoefficientFormat, CoefficientOptions,
    StabilityOptions,
};
use crate::app::{
    eval_file, is_sweep_spec, merge_command, print_text, read_input, run_command, run_scene_file,
    AppError, EvalOptions, SceneRunOptions, StdoutWriter, SweepRunOptions,
};
#[cfg(feature = "service")]
use crate::app::{submit_command, SubmitOptions};
use crate::bench::backend::{BenchOptions, BenchTarget};
use crate::bench::{
    bench_all, bench_backend, bench_loads, bench_loads_markdown, bench_rotor, bench_rotor_batch,
    BenchAllOptions, BenchLoadsOptions, BenchRotorOptions,
};
#[cfg(feature = "postgres")]
use crate::service::pg::{worker_command, WorkerCommandOptions};
#[cfg(feature = "service")]
use crate::service::serve_command;

/// Runs the parsed command line; the exit status: success, or 2 after the error on
/// standard error (a closed standard output ends quietly).
pub fn run(cli: Cli) -> ExitCode {
    let result = match cli.command {
        Command::Eval(a) => {
            let file = a.file.clone();
            eval(a).map_err(|e| name_file(&file, e))
        }
        Command::Run(a) => {
            // A batch run: its stored samples on huge pages (`crate::allocator`).
            crate::allocator::use_huge_pages();
            let file = a.file.clone();
            run_cmd(a).map_err(|e| name_file(&file, e))
        }
        Command::Merge(a) => merge_command(&a.out, &a.shards).map(print_lines),
        #[cfg(feature = "service")]
        Command::Serve(a) => serve(a),
        #[cfg(feature = "service")]
        Command::Submit(a) => {
            let file = a.spec.clone();
            submit(a).map_err(|e| name_file(&file, e))
        }
        Command::Coefficients(a) => {
            let file = a.file.clone();
            coefficients_cmd(a).map_err(|e| name_file(&file, e))
        }
        Command::Stability(a) => {
            let file = a.file.clone();
            stability_cmd(a).map_err(|e| name_file(&file, e))
        }
        Command::Finite(a) => finite_cmd(a),
        #[cfg(feature = "postgres")]
        Command::Worker(a) => worker(a),
        Command::Bench { what } => match what {
            BenchCommand::All(a) => bench_all_cmd(a),
            #[cfg(feature = "postgres")]
            BenchCommand::Queue(a) => bench_queue_cmd(a),
            BenchCommand::Loads(a) => bench_loads_cmd(a),
            BenchCommand::Backend(a) => run_bench_backend(
                &a.backend, a.sizes, a.accuracy, a.threads, a.min_time, a.max_reps, a.json,
            ),
            BenchCommand::Rotor(a) if !a.batch.is_empty() => bench_rotor_batch_cmd(a),
            BenchCommand::Rotor(a) => bench_rotor_cmd(a),
            #[cfg(feature = "service")]
            BenchCommand::Serve(a) => bench_serve_cmd(a),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of stdout went away (`… | head`): nothing left to tell anyone.
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => {
            // Messages may quote user input; a backstop against echoing megabytes.
            let message = crate::json::shorten(&e.to_string(), crate::json::MAX_MESSAGE_CHARS);
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

/// A JSON syntax error or a duplicate key in the input file `file` names the file (the
/// JSON path alone does not say which file a command was reading); other input errors
/// name their JSON path as before.
fn name_file(file: &str, e: AppError) -> AppError {
    match e {
        AppError::Input { path, reason }
            if reason.starts_with("not valid JSON") || reason.starts_with("duplicate key") =>
        {
            let name = if file == "-" { "standard input" } else { file };
            let path = if path == "$" {
                name.to_string()
            } else {
                format!("{name}: {path}")
            };
            AppError::Input { path, reason }
        }
        other => other,
    }
}

/// `finite`: the model-error map and the finite-film benchmark.
fn finite_cmd(a: FiniteArgs) -> Result<(), AppError> {
    if let Some(dir) = &a.map {
        let (md, files) = crate::app::error_map_files(dir, a.map_resolution)?;
        for path in files {
            eprintln!("wrote {}", path.display());
        }
        println!("{md}");
    }
    if a.bench && a.cavitation == "jfo" {
        println!(
            "{}",
            crate::bench::finite::bench_finite_jfo(a.states.max(1), a.reps.max(1), a.gpu)
        );
    } else if a.bench {
        println!(
            "{}",
            crate::bench::finite::bench_finite(a.states.max(1), a.reps.max(1), a.gpu)
        );
        println!(
            "{}",
            crate::bench::finite::bench_finite_rotor(a.rotor_t_end)
        );
    }
    if a.map.is_none() && !a.bench {
        return Err(AppError::input("finite", "give --map DIR and/or --bench"));
    }
    Ok(())
}

/// Notices and report lines go to stderr.
fn print_lines(lines: Vec<String>) {
    for l in lines {
        eprintln!("{l}");
    }
}

/// `coefficients`: linearised K and C, JSON (or ROSS CSV) on stdout.
fn coefficients_cmd(a: CoefficientsArgs) -> Result<(), AppError> {
    let format: CoefficientFormat = a
        .format
        .parse()
        .map_err(|r| AppError::input("--format", r))?;
    let text = read_input(&a.file)?;
    let (out, notices) = coefficients_json_with(
        &text,
        CoefficientOptions {
            backend: a.backend,
            accuracy: a.accuracy,
        },
    )?;
    for n in notices {
        eprintln!("{n}");
    }
    if let Some(n) = format.notice() {
        eprintln!("{n}");
    }
    print_text(&format.render(&out))
}

/// `stability`: modes, threshold and Campbell diagram of a scene.
fn stability_cmd(a: StabilityArgs) -> Result<(), AppError> {
    let text = read_input(&a.file)?;
    let (out, files, notices) = stability_scene_file(
        &a.file,
        &text,
        &StabilityOptions {
            backend: a.backend,
            accuracy: a.accuracy,
            speeds: a.speeds,
            out: Some(a.out),
        },
    )?;
    for n in notices {
        eprintln!("{n}");
    }
    for f in files {
        eprintln!("wrote {}", f.display());
    }
    print_text(&(serde_json::to_string_pretty(&out).unwrap_or_default() + "\n"))
}

/// `eval`: film loads of the states in a file, JSON on stdout.
fn eval(a: EvalArgs) -> Result<(), AppError> {
    let mut out = StdoutWriter::new();
    let notices = eval_file(
        &a.file,
        &mut out,
        EvalOptions {
            backend: a.backend,
            accuracy: a.accuracy,
        },
    )?;
    for n in notices {
        eprintln!("{n}");
    }
    out.finish()
}

/// `--max-memory` (e.g. 512M, 8G) as a budget; absent: the 2 GiB default.
fn max_memory_flag(flag: Option<&str>) -> Result<crate::budget::MemoryBudget, AppError> {
    Ok(match flag {
        Some(m) => crate::budget::MemoryBudget::new(
            crate::budget::parse_size(m).map_err(|r| AppError::input("--max-memory", r))?,
        ),
        None => crate::budget::MemoryBudget::default(),
    })
}

/// `run`: a sweep spec goes to the sweep runner, anything else is a scene file.
fn run_cmd(a: RunArgs) -> Result<(), AppError> {
    let max_memory = max_memory_flag(a.max_memory.as_deref())?;
    let text = read_input(&a.file)?;
    if is_sweep_spec(&text) {
        return run_sweep_file(a, &text, max_memory);
    }
    // Implausible values warn before the run (a mistyped unit can cost minutes).
    if let Ok(doc) = serde_json::from_str::<serde_json::Value>(&text) {
        for w in crate::app::scene_file_warnings(&doc) {
            eprintln!("{w}");
        }
    }
    if a.shard.is_some() {
        return Err(AppError::input(
            "--shard",
            "only sweep specs are sharded (this file is a scene: wrap it as {\"base\": \"FILE\"})",
        ));
    }
    let report = run_scene_file(
        &a.file,
        &text,
        &SceneRunOptions {
            out: a.out,
            options: crate::sweep::SweepOptions {
                backend: a.backend,
                accuracy: crate::sweep::RequestedAccuracy::new(a.accuracy)
                    .map_err(|r| AppError::input("--accuracy", r))?,
                full_model: a.full_model,
                max_memory,
            },
        },
    )?;
    for n in report.notices {
        eprintln!("{n}");
    }
    let mut out = StdoutWriter::new();
    for l in report.lines {
        out.line(&l)?;
    }
    for f in report.files {
        out.line(&format!("wrote {}", f.display()))?;
    }
    out.finish()
}

/// `run` of a sweep spec: resumable, shardable, streamed.
fn run_sweep_file(
    a: RunArgs,
    text: &str,
    max_memory: crate::budget::MemoryBudget,
) -> Result<(), AppError> {
    let accuracy = crate::sweep::RequestedAccuracy::new(a.accuracy)
        .map_err(|r| AppError::input("--accuracy", r))?;
    let opts = SweepRunOptions {
        out: a.out,
        quiet: a.quiet,
        runner: crate::sweep::runner::RunnerOptions {
            shard: a.shard,
            batch: a.batch_size,
        },
        sweep: crate::sweep::SweepOptions {
            backend: a.backend,
            accuracy,
            full_model: a.full_model,
            max_memory,
        },
    };
    run_command(&a.file, text, &opts, &mut |n| eprintln!("{n}")).map(print_lines)
}

#[cfg(feature = "service")]
/// `serve`: the sweep service until SIGTERM / Ctrl-C.
fn serve(a: ServeArgs) -> Result<(), AppError> {
    let config = crate::service::ServiceConfig {
        bind: a.bind,
        data: a.data,
        token: a.token,
        max_running: a.max_running,
        max_body_bytes: a.max_body_bytes,
        max_variants: a.max_variants,
        max_queued: a.max_queued,
        eval_window: std::time::Duration::from_secs_f64(a.eval_window_ms.clamp(0.0, 1e3) / 1e3),
        eval_backend: a.eval_backend,
        database: a.database,
        max_request_bytes: crate::budget::parse_size(&a.max_request_memory)
            .map_err(|e| AppError::input("--max-request-memory", e))?,
        max_states_in_flight: a.max_states_in_flight,
        header_timeout: std::time::Duration::from_secs_f64(a.header_timeout_s.clamp(0.1, 3600.0)),
        max_connections_per_client: a.max_connections_per_client,
        ..Default::default()
    };
    serve_command(config, &mut |n| eprintln!("{n}"))
}

#[cfg(feature = "service")]
/// `submit`: a sweep spec to a running service.
fn submit(a: SubmitArgs) -> Result<(), AppError> {
    let text = read_input(&a.spec)?;
    let lines = submit_command(
        &text,
        &SubmitOptions {
            server: a.server,
            token: a.token,
            wait: a.wait,
            backend: a.backend,
            accuracy: a.accuracy,
            full_model: a.full_model,
        },
    )?;
    for l in lines {
        println!("{l}");
    }
    Ok(())
}

#[cfg(feature = "postgres")]
/// `worker`: pulls work from a PostgreSQL queue until stopped.
fn worker(a: WorkerArgs) -> Result<(), AppError> {
    let max_memory = max_memory_flag(a.max_memory.as_deref())?;
    worker_command(&WorkerCommandOptions {
        database: a.database,
        backend: a.backend,
        batch: a.batch,
        lease_ttl_s: a.lease_ttl,
        heartbeat_s: a.heartbeat,
        exit_when_idle_s: a.exit_when_idle,
        id: a.id,
        max_memory,
    })
    .map(print_lines)
}

#[cfg(feature = "service")]
/// `bench serve`: load generator for the service.
fn bench_serve_cmd(a: BenchServeArgs) -> Result<(), AppError> {
    let md = crate::bench::bench_serve(&crate::bench::LoadOptions {
        server: a.server,
        clients: a.clients,
        states: a.states,
        duration_s: a.duration,
        window_ms: a.window_ms,
        sweep: a.sweep,
        sweep_repeats: a.sweep_repeats,
    })
    .map_err(|e| AppError::input("bench serve", e.to_string()))?;
    print!("{md}");
    Ok(())
}

#[cfg(feature = "postgres")]
/// `bench queue`: figures of the PostgreSQL queue.
fn bench_queue_cmd(a: BenchQueueArgs) -> Result<(), AppError> {
    let exe = std::env::current_exe().map_err(|source| AppError::Io {
        path: "current executable".into(),
        source,
    })?;
    let md = crate::bench::bench_queue(&crate::bench::QueueBenchOptions {
        database: a.database,
        exe,
        workers: a.workers,
        batch: a.batch.max(1),
        grid: a.grid.max(1),
        overhead_batches: a.overhead_batches.max(1),
        storm_workers: a.storm_workers.max(1),
        storm_s: a.storm_seconds.max(0.1),
        scratch: a.out,
    })
    .map_err(|e| AppError::input("--database", e.to_string()))?;
    print!("{md}");
    Ok(())
}

/// `bench all`: every benchmark into one folder with an index.
fn bench_all_cmd(a: BenchAllArgs) -> Result<(), AppError> {
    let opts = if a.full {
        BenchAllOptions::full(a.out)
    } else {
        BenchAllOptions::quick(a.out)
    };
    let r = bench_all(&opts)?;
    print_text(&r.index)?;
    eprintln!("wrote {} files in {:.1} s", r.files.len(), r.wall_s);
    Ok(())
}

/// `bench loads`: work-precision of the load quadrature.
fn bench_loads_cmd(a: BenchLoadsArgs) -> Result<(), AppError> {
    let report = bench_loads(&BenchLoadsOptions {
        threads: a.threads,
        states: a.states,
        out: a.out,
        baseline_grids: a.grids,
        gpu_batch: a.gpu_batch,
        min_time_s: a.min_time,
    })?;
    print_text(&bench_loads_markdown(&report))
}

/// `bench rotor --batch`: lockstep batches against one-by-one runs.
fn bench_rotor_batch_cmd(a: BenchRotorArgs) -> Result<(), AppError> {
    print_text(crate::bench::ROTOR_BATCH_TABLE_HEADER)?;
    a.batch.iter().try_for_each(|&n| {
        bench_rotor_batch(n, a.t_end, a.threads).and_then(|row| print_text(&row))
    })
}

/// `bench rotor`: work-precision of the integrators on the paper example.
fn bench_rotor_cmd(a: BenchRotorArgs) -> Result<(), AppError> {
    let r = bench_rotor(&BenchRotorOptions {
        t_end: a.t_end,
        accuracy: a.accuracy,
        repeats: a.repeats,
        out: a.out,
        viscosity: a.viscosity,
    })?;
    let mut out = StdoutWriter::new();
    out.line(&format!("{}\n", r.reference))?;
    out.text(&r.table)?;
    for f in r.files {
        out.line(&format!("wrote {}", f.display()))?;
    }
    out.finish()
}

fn run_bench_backend(
    backend: &str,
    sizes: Vec<usize>,
    accuracy: f64,
    threads: usize,
    min_time: f64,
    max_reps: usize,
    json: Option<String>,
) -> Result<(), AppError> {
    let target: BenchTarget = backend
        .parse()
        .map_err(|r| AppError::input("--backend", r))?;
    if sizes.is_empty() || sizes.contains(&0) {
        return Err(AppError::input("--sizes", "batch sizes must be at least 1"));
    }
    let accuracy = crate::app::accuracy(accuracy)?;
    let options = BenchOptions {
        sizes,
        accuracy,
        cpu_threads: threads.max(1),
        target,
        min_time_s: min_time,
        max_reps,
        // BEARING_SWEEP_GPU_PRECISION=f32 benchmarks the f32 kernel.
        gpu: crate::backend::GpuOptions::from_env()?,
        ..BenchOptions::default()
    };
    let (report, md) = bench_backend(&options)?;
    print_text(&format!("{md}\n"))?;
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        std::fs::write(&path, text).map_err(|source| AppError::Io { path, source })?;
    }
    Ok(())
}
