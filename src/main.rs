//! The `bearing-sweep` command line: argument parsing only; the work is in the library.

use std::process::ExitCode;

use bearing_sweep::app::{
    coefficients_json_with, stability_scene_file, CoefficientFormat, CoefficientOptions,
    StabilityOptions,
};
use bearing_sweep::app::{
    eval_file, is_sweep_spec, merge_command, print_text, read_input, run_command, run_scene_file,
    AppError, EvalOptions, SceneRunOptions, StdoutWriter, SweepRunOptions,
};
#[cfg(feature = "service")]
use bearing_sweep::app::{submit_command, SubmitOptions};
use bearing_sweep::backend::BackendKind;
use bearing_sweep::bench::backend::{BenchOptions, BenchTarget};
use bearing_sweep::bench::{
    bench_all, bench_backend, bench_loads, bench_loads_markdown, bench_rotor, bench_rotor_batch,
    BenchAllOptions, BenchLoadsOptions, BenchRotorOptions,
};
#[cfg(feature = "postgres")]
use bearing_sweep::service::pg::{worker_command, WorkerCommandOptions};
#[cfg(feature = "service")]
use bearing_sweep::service::serve_command;
use bearing_sweep::sweep::runner::{BatchSize, Shard};
use clap::{Args, Parser, Subcommand};

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
    Eval(EvalArgs),
    /// Simulate a scene file (writes OUT/<file stem>/result.json and SVG figures 7-10), or
    /// run a sweep spec (a file with `base` or `kind`; writes OUT/<spec stem>/result.json,
    /// streaming variants to result.jsonl, resumable; see docs/cli.md "Sweeps").
    Run(RunArgs),
    /// Merge sweep shard results into the result of the unsharded run.
    Merge(MergeArgs),
    #[cfg(feature = "service")]
    /// Run the sweep service: HTTP API, job store, scheduler (docs/api.md "Service").
    Serve(ServeArgs),
    #[cfg(feature = "service")]
    /// Submit a sweep spec to a running service; prints its id.
    Submit(SubmitArgs),
    /// Linearised bearing coefficients: `{"bearing", "speed" (or "speeds"), "load"}` or
    /// `{"bearing", "state"}` -> equilibrium and 4x4 stiffness and damping (with tilt) and
    /// their error estimates; `--format ross-csv` for ROSS BearingElement rows.
    Coefficients(CoefficientsArgs),
    /// Linear stability of a scene: modes at its speed, threshold speed, Campbell diagram
    /// and damping over `--speeds` (JSON on stdout; files in OUT/<scene stem>/).
    Stability(StabilityArgs),
    /// Finite-length film (docs/finite-film.md): the short-vs-finite model-error map
    /// (`--map DIR`: SVG + Markdown table) and its benchmark (`--bench`, Markdown on stdout).
    Finite(FiniteArgs),
    #[cfg(feature = "postgres")]
    /// Pull sweep work batches from a PostgreSQL queue (`serve --database`) and run them
    /// until stopped (docs/api.md "Workers and PostgreSQL").
    Worker(WorkerArgs),
    /// Benchmarks (Markdown report on stdout).
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    #[cfg(feature = "postgres")]
    /// PostgreSQL queue: variants/s with 1, 2, 4 worker processes against `run`, claim and
    /// commit overhead per batch, and a claim storm (docs/api.md "Workers and PostgreSQL").
    Queue(BenchQueueArgs),
    /// Every work-precision benchmark (loads on CPU and GPU, backend vs batch size, rotor
    /// integrators, stiff variant, lockstep batches) into one folder with an index.md:
    /// ~20-30 s quick, ~2 min with --full on 2 cores.
    All(BenchAllArgs),
    /// Film loads: evaluations/s against error, graded rule at each accuracy level vs the
    /// brute-force baseline, one thread and parallel.
    Loads(BenchLoadsArgs),
    /// Backend throughput and latency against batch size, CPU and GPU.
    Backend(BenchBackendArgs),
    /// Work-precision of the integrators on the paper example (BENCHMARKS.md): prints a
    /// markdown table, writes log-log SVG diagrams to --out.
    Rotor(BenchRotorArgs),
    #[cfg(feature = "service")]
    /// Load generator for the service: concurrent eval clients (states/s, p50/p99) beside
    /// one `eval` call, and one sweep over HTTP against `run`.
    Serve(BenchServeArgs),
}

#[cfg(feature = "service")]
#[derive(Args)]
struct BenchServeArgs {
    /// A running service; default: one started in this process on 127.0.0.1.
    #[arg(long)]
    server: Option<String>,
    /// Concurrent clients, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,8,64,256")]
    clients: Vec<usize>,
    /// States per request, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,64")]
    states: Vec<usize>,
    /// Seconds per row.
    #[arg(long, default_value_t = 10.0)]
    duration: f64,
    /// Coalescing window of the in-process server, ms.
    #[arg(long, default_value_t = 2.0)]
    window_ms: f64,
    /// A sweep spec to time over HTTP against `run`.
    #[arg(long)]
    sweep: Option<std::path::PathBuf>,
    /// Timings of the sweep each way (the fastest counts).
    #[arg(long, default_value_t = 3)]
    sweep_repeats: usize,
}

#[derive(Args)]
struct EvalArgs {
    /// Input JSON file, `-` for standard input.
    file: String,
    /// Backend: cpu, gpu or auto (a hardware GPU for 64 states or more, else the CPU).
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    /// Relative accuracy of the load vector (1e-3, 1e-6, 1e-9 or 1e-12; rounded tighter).
    #[arg(long, default_value = "1e-6")]
    accuracy: f64,
}

#[derive(Args)]
struct FiniteArgs {
    /// Write `finite-error-map.svg` and `finite-error-map.md` into this folder.
    #[arg(long)]
    map: Option<std::path::PathBuf>,
    /// Map cells per unit of B/D and of ε for the figure (the table uses the stored map's
    /// nodes).
    #[arg(long, default_value_t = 20)]
    map_resolution: usize,
    /// Run the finite-film benchmark (CPU; add --gpu for the WGSL kernel).
    #[arg(long)]
    bench: bool,
    /// Include the GPU kernel in the benchmark.
    #[arg(long)]
    gpu: bool,
    /// States per benchmark call.
    #[arg(long, default_value_t = 64)]
    states: usize,
    /// Timed calls per grid.
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// Simulated time of the rotor-scene cost benchmark, s (the paper's run is 0.5 s).
    #[arg(long, default_value_t = 0.1)]
    rotor_t_end: f64,
}

#[derive(Args)]
struct RunArgs {
    /// Scene file or sweep spec (JSON).
    file: String,
    /// Output root folder.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Backend for the film loads: cpu, gpu or auto (a hardware GPU when a stage carries
    /// 64 bearing states or more, e.g. a sweep, else the CPU).
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    /// Relative accuracy of the film loads (1e-3, 1e-6, 1e-9 or 1e-12).
    #[arg(long, default_value = "1e-6")]
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
    /// Turn every model reduction off (docs/cli.md "Model reductions"), exact ones included.
    #[arg(long)]
    full_model: bool,
    /// Memory budget (e.g. 8G, 512M; default 2G): specs and scenes estimated above it
    /// are refused before running (docs/cli.md "Limits").
    #[arg(long)]
    max_memory: Option<String>,
}

#[cfg(feature = "service")]
#[derive(Args)]
struct ServeArgs {
    /// Address and port to listen on (port 0: any free port, printed at start).
    #[arg(long, default_value = "127.0.0.1:8080")]
    bind: std::net::SocketAddr,
    /// Folder of the job store (SQLite database).
    #[arg(long, default_value = "bearing-sweep-data")]
    data: std::path::PathBuf,
    /// Keep sweeps in PostgreSQL (postgres://user[:password]@host:port/database) and let
    /// `worker` processes run them, instead of the SQLite store in --data.
    #[arg(long)]
    database: Option<String>,
    /// Bearer token required on /api (else BEARING_SWEEP_TOKEN; required off loopback).
    #[arg(long)]
    token: Option<String>,
    /// Sweeps running at once.
    #[arg(long, default_value_t = 1)]
    max_running: usize,
    /// Largest request body, bytes (413 beyond).
    #[arg(long, default_value_t = 4 << 20)]
    max_body_bytes: usize,
    /// Most variants per sweep (422 beyond).
    #[arg(long, default_value_t = 1_000_000)]
    max_variants: u64,
    /// Most sweeps queued or running (429 beyond).
    #[arg(long, default_value_t = 64)]
    max_queued: u64,
    /// Coalescing window of /api/eval, ms.
    #[arg(long, default_value_t = 2.0)]
    eval_window_ms: f64,
    /// Backend of /api/eval: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    eval_backend: BackendKind,
    /// Largest estimated memory of one request (e.g. 256M, 1G; 422 naming the field
    /// beyond; docs/service-limits.md).
    #[arg(long, default_value = "256M")]
    max_request_memory: String,
    /// Most eval states and coefficient speeds in flight across requests (503 with
    /// Retry-After beyond).
    #[arg(long, default_value_t = 1 << 16)]
    max_states_in_flight: u64,
    /// Seconds a client has to send a request's header, from its first byte.
    #[arg(long, default_value_t = 10.0)]
    header_timeout_s: f64,
    /// Most connections open at once from one client address.
    #[arg(long, default_value_t = 512)]
    max_connections_per_client: usize,
}

#[cfg(feature = "service")]
#[derive(Args)]
struct SubmitArgs {
    /// Sweep spec (JSON), `-` for standard input.
    spec: String,
    /// Service URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    server: String,
    /// Bearer token (else BEARING_SWEEP_TOKEN).
    #[arg(long)]
    token: Option<String>,
    /// Wait for the end with a progress bar, then print where the result is.
    #[arg(long)]
    wait: bool,
    /// Backend for the film loads: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    /// Relative accuracy of the film loads.
    #[arg(long, default_value = "1e-6")]
    accuracy: f64,
    /// Turn every model reduction off.
    #[arg(long)]
    full_model: bool,
}

#[derive(Args)]
struct CoefficientsArgs {
    /// Input JSON file, `-` for standard input.
    file: String,
    /// Output: `json`, `ross-csv` (speed, kxx, kxy, kyx, kyy, cxx, cxy, cyx, cyy) or
    /// `ross-toml` (a file ROSS 2.x's `BearingElement.load` reads, with load, ε and geometry;
    /// `ross3-toml` for ROSS 3.x).
    #[arg(long, default_value = "json")]
    format: String,
    /// Backend: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    /// Relative accuracy of the film loads (the coefficients are differences of loads).
    #[arg(long, default_value = "1e-12")]
    accuracy: f64,
}

#[derive(Args)]
struct StabilityArgs {
    /// Scene file (as `run` reads it).
    file: String,
    /// Speeds of the Campbell diagram and threshold scan, rad/s, comma-separated
    /// (default: 41 speeds from 0.1x to 10x the scene's spin).
    #[arg(long, value_delimiter = ',')]
    speeds: Vec<f64>,
    /// Output root folder (stability.json, campbell.svg, damping.svg in OUT/<stem>/).
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Backend: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    backend: BackendKind,
    /// Relative accuracy of the film loads.
    #[arg(long, default_value = "1e-12")]
    accuracy: f64,
}

#[derive(Args)]
struct MergeArgs {
    /// Merged result file.
    out: String,
    /// Shard result files.
    #[arg(required = true)]
    shards: Vec<String>,
}

#[cfg(feature = "postgres")]
#[derive(Args)]
struct WorkerArgs {
    /// The queue's database: postgres://user[:password]@host:port/database.
    #[arg(long)]
    database: String,
    /// Backend for the film loads: cpu, gpu or auto (workers claim only sweeps that allow it).
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
    /// Variants per claimed lockstep batch (default 256 on the CPU, 4096 on a GPU).
    #[arg(long)]
    batch: Option<usize>,
    /// Lease time to live without a heartbeat, s: a dead worker's batch runs elsewhere
    /// after this long.
    #[arg(long, default_value_t = 30.0)]
    lease_ttl: f64,
    /// Heartbeat period, s (default a third of --lease-ttl); cancel reaches the worker
    /// within one period.
    #[arg(long)]
    heartbeat: Option<f64>,
    /// Exit after this many seconds without work (default: run until SIGTERM/Ctrl-C).
    #[arg(long)]
    exit_when_idle: Option<f64>,
    /// Worker id in leases and results (default host/pid/nonce).
    #[arg(long)]
    id: Option<String>,
}

#[cfg(feature = "postgres")]
#[derive(Args)]
struct BenchQueueArgs {
    /// A scratch database (sweeps are added and deleted): postgres://user@host:port/db.
    #[arg(long)]
    database: String,
    /// Worker process counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4")]
    workers: Vec<usize>,
    /// Variants per claim of those workers.
    #[arg(long, default_value_t = 32)]
    batch: usize,
    /// Grid points per axis of the rotor sweep (n x n variants).
    #[arg(long, default_value_t = 16)]
    grid: usize,
    /// Batches of the claim-and-commit overhead row.
    #[arg(long, default_value_t = 500)]
    overhead_batches: usize,
    /// Concurrent claimers in the storm.
    #[arg(long, default_value_t = 64)]
    storm_workers: usize,
    /// Length of the storm, s.
    #[arg(long, default_value_t = 10.0)]
    storm_seconds: f64,
    /// Scratch folder for the `run` reference.
    #[arg(long, default_value = "out/bench-queue")]
    out: std::path::PathBuf,
}

#[derive(Args)]
struct BenchAllArgs {
    /// Output folder (index.md, loads/, backend/, rotor/).
    #[arg(long, default_value = "out/bench-all")]
    out: std::path::PathBuf,
    /// The settings of BENCHMARKS.md instead of the quick ones.
    #[arg(long)]
    full: bool,
}

#[derive(Args)]
struct BenchLoadsArgs {
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
    /// States per GPU call for the GPU rows (f64 and f32 kernels at each level); 0
    /// skips them. Without an adapter they are skipped with a note.
    #[arg(long, default_value_t = bearing_sweep::bench::DEFAULT_GPU_BATCH)]
    gpu_batch: usize,
    /// Minimum wall time of one timing, s.
    #[arg(long, default_value_t = 0.5)]
    min_time: f64,
}

#[derive(Args)]
struct BenchBackendArgs {
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
    #[arg(long, default_value = "1e-6")]
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
}

#[derive(Args)]
struct BenchRotorArgs {
    /// Simulated time, s.
    #[arg(long, default_value_t = 0.5)]
    t_end: f64,
    /// Film-load accuracy level.
    #[arg(long, default_value = "1e-12")]
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
}

fn main() -> ExitCode {
    // Before any thread: the Vulkan loader would print an XDG_RUNTIME_DIR error otherwise.
    bearing_sweep::backend::ensure_xdg_runtime_dir();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(a) => {
            let file = a.file.clone();
            eval(a).map_err(|e| name_file(&file, e))
        }
        Command::Run(a) => {
            let file = a.file.clone();
            run(a).map_err(|e| name_file(&file, e))
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
            let message = bearing_sweep::json::shorten(
                &e.to_string(),
                bearing_sweep::json::MAX_MESSAGE_CHARS,
            );
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
        let (md, files) = bearing_sweep::app::error_map_files(dir, a.map_resolution)?;
        for path in files {
            eprintln!("wrote {}", path.display());
        }
        println!("{md}");
    }
    if a.bench {
        println!(
            "{}",
            bearing_sweep::bench::finite::bench_finite(a.states.max(1), a.reps.max(1), a.gpu)
        );
        println!(
            "{}",
            bearing_sweep::bench::finite::bench_finite_rotor(a.rotor_t_end)
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

/// `run`: a sweep spec goes to the sweep runner, anything else is a scene file.
fn run(a: RunArgs) -> Result<(), AppError> {
    let max_memory = match &a.max_memory {
        Some(m) => bearing_sweep::budget::MemoryBudget::new(
            bearing_sweep::budget::parse_size(m).map_err(|r| AppError::input("--max-memory", r))?,
        ),
        None => bearing_sweep::budget::MemoryBudget::default(),
    };
    let text = read_input(&a.file)?;
    if is_sweep_spec(&text) {
        return run_sweep_file(a, &text, max_memory);
    }
    // Implausible values warn before the run (a mistyped unit can cost minutes).
    if let Ok(doc) = serde_json::from_str::<serde_json::Value>(&text) {
        for w in bearing_sweep::app::scene_file_warnings(&doc) {
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
            backend: a.backend,
            accuracy: a.accuracy,
            out: a.out,
            full_model: a.full_model,
            max_memory,
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
    max_memory: bearing_sweep::budget::MemoryBudget,
) -> Result<(), AppError> {
    let accuracy = bearing_sweep::sweep::RequestedAccuracy::new(a.accuracy)
        .map_err(|r| AppError::input("--accuracy", r))?;
    let opts = SweepRunOptions {
        out: a.out,
        quiet: a.quiet,
        runner: bearing_sweep::sweep::runner::RunnerOptions {
            shard: a.shard,
            batch: a.batch_size,
        },
        sweep: bearing_sweep::sweep::SweepOptions {
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
    let config = bearing_sweep::service::ServiceConfig {
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
        max_request_bytes: bearing_sweep::budget::parse_size(&a.max_request_memory)
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
    worker_command(&WorkerCommandOptions {
        database: a.database,
        backend: a.backend,
        batch: a.batch,
        lease_ttl_s: a.lease_ttl,
        heartbeat_s: a.heartbeat,
        exit_when_idle_s: a.exit_when_idle,
        id: a.id,
    })
    .map(print_lines)
}

#[cfg(feature = "service")]
/// `bench serve`: load generator for the service.
fn bench_serve_cmd(a: BenchServeArgs) -> Result<(), AppError> {
    let md = bearing_sweep::bench::bench_serve(&bearing_sweep::bench::LoadOptions {
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
    let md = bearing_sweep::bench::bench_queue(&bearing_sweep::bench::QueueBenchOptions {
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
    print_text(bearing_sweep::bench::ROTOR_BATCH_TABLE_HEADER)?;
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
    let accuracy = bearing_sweep::app::accuracy(accuracy)?;
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
    print_text(&format!("{md}\n"))?;
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        std::fs::write(&path, text).map_err(|source| AppError::Io { path, source })?;
    }
    Ok(())
}
