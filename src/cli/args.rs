//! The command's arguments (clap): one struct per subcommand, each flag with its unit and
//! default in its help text. Parsed by `main.rs`, run by [`super::run`].

use crate::backend::BackendKind;
use crate::sweep::runner::{BatchSize, Shard};
use clap::{Args, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "bearing-sweep",
    version,
    about = "Rigid rotors in hydrodynamic journal bearings, batched on CPU and GPU"
)]
pub struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
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
pub(crate) enum BenchCommand {
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
pub(crate) struct BenchServeArgs {
    /// A running service; default: one started in this process on 127.0.0.1.
    #[arg(long)]
    pub(crate) server: Option<String>,
    /// Concurrent clients, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,8,64,256")]
    pub(crate) clients: Vec<usize>,
    /// States per request, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,64")]
    pub(crate) states: Vec<usize>,
    /// Seconds per row.
    #[arg(long, default_value_t = 10.0)]
    pub(crate) duration: f64,
    /// Coalescing window of the in-process server, ms.
    #[arg(long, default_value_t = 2.0)]
    pub(crate) window_ms: f64,
    /// A sweep spec to time over HTTP against `run`.
    #[arg(long)]
    pub(crate) sweep: Option<std::path::PathBuf>,
    /// Timings of the sweep each way (the fastest counts).
    #[arg(long, default_value_t = 3)]
    pub(crate) sweep_repeats: usize,
}

#[derive(Args)]
pub(crate) struct EvalArgs {
    /// Input JSON file, `-` for standard input.
    pub(crate) file: String,
    /// Backend: cpu, gpu or auto (a hardware GPU for 64 states or more, else the CPU).
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    /// Relative accuracy of the load vector (1e-3, 1e-6, 1e-9 or 1e-12; rounded tighter).
    #[arg(long, default_value = "1e-6")]
    pub(crate) accuracy: f64,
}

#[derive(Args)]
pub(crate) struct FiniteArgs {
    /// Write `finite-error-map.svg` and `finite-error-map.md` into this folder.
    #[arg(long)]
    pub(crate) map: Option<std::path::PathBuf>,
    /// Map cells per unit of B/D and of ε for the figure (the table uses the stored map's
    /// nodes).
    #[arg(long, default_value_t = 20)]
    pub(crate) map_resolution: usize,
    /// Run the finite-film benchmark (CPU; add --gpu for the WGSL kernel).
    #[arg(long)]
    pub(crate) bench: bool,
    /// Include the GPU kernel in the benchmark.
    #[arg(long)]
    pub(crate) gpu: bool,
    /// States per benchmark call.
    #[arg(long, default_value_t = 64)]
    pub(crate) states: usize,
    /// Timed calls per grid.
    #[arg(long, default_value_t = 3)]
    pub(crate) reps: usize,
    /// Simulated time of the rotor-scene cost benchmark, s (the paper's run is 0.5 s).
    #[arg(long, default_value_t = 0.1)]
    pub(crate) rotor_t_end: f64,
    /// Cavitation model of the benchmark: `reynolds` (Swift-Stieber, the standard tables)
    /// or `jfo` (JFO against Swift-Stieber at equal grid, CPU and with --gpu the kernels;
    /// BENCHMARKS.md "Issue 27").
    #[arg(long, default_value = "reynolds", value_parser = ["reynolds", "jfo"])]
    pub(crate) cavitation: String,
}

#[derive(Args)]
pub(crate) struct RunArgs {
    /// Scene file or sweep spec (JSON).
    pub(crate) file: String,
    /// Output root folder.
    #[arg(long, default_value = "out")]
    pub(crate) out: std::path::PathBuf,
    /// Backend for the film loads: cpu, gpu or auto (a hardware GPU when a stage carries
    /// 64 bearing states or more, e.g. a sweep, else the CPU).
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    /// Relative accuracy of the film loads (1e-3, 1e-6, 1e-9 or 1e-12).
    #[arg(long, default_value = "1e-6")]
    pub(crate) accuracy: f64,
    /// Sweeps: run only shard K of N (variant i belongs to shard i mod N).
    #[arg(long)]
    pub(crate) shard: Option<Shard>,
    /// Sweeps: variants per lockstep batch, or `auto`.
    #[arg(long, default_value = "auto")]
    pub(crate) batch_size: BatchSize,
    /// Sweeps: no progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Turn every model reduction off (docs/cli.md "Model reductions"), exact ones included.
    #[arg(long)]
    pub(crate) full_model: bool,
    /// Memory budget (e.g. 8G, 512M; default 2G): specs and scenes estimated above it
    /// are refused before running (docs/cli.md "Limits").
    #[arg(long)]
    pub(crate) max_memory: Option<String>,
}

#[cfg(feature = "service")]
#[derive(Args)]
pub(crate) struct ServeArgs {
    /// Address and port to listen on (port 0: any free port, printed at start).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub(crate) bind: std::net::SocketAddr,
    /// Folder of the job store (SQLite database).
    #[arg(long, default_value = "bearing-sweep-data")]
    pub(crate) data: std::path::PathBuf,
    /// Keep sweeps in PostgreSQL (postgres://user[:password]@host:port/database) and let
    /// `worker` processes run them, instead of the SQLite store in --data.
    #[arg(long)]
    pub(crate) database: Option<String>,
    /// Bearer token required on /api (else BEARING_SWEEP_TOKEN; required off loopback).
    #[arg(long)]
    pub(crate) token: Option<String>,
    /// Sweeps running at once.
    #[arg(long, default_value_t = 1)]
    pub(crate) max_running: usize,
    /// Largest request body, bytes (413 beyond).
    #[arg(long, default_value_t = 4 << 20)]
    pub(crate) max_body_bytes: usize,
    /// Most variants per sweep (422 beyond).
    #[arg(long, default_value_t = 1_000_000)]
    pub(crate) max_variants: u64,
    /// Most sweeps queued or running (429 beyond).
    #[arg(long, default_value_t = 64)]
    pub(crate) max_queued: u64,
    /// Coalescing window of /api/eval, ms.
    #[arg(long, default_value_t = 2.0)]
    pub(crate) eval_window_ms: f64,
    /// Backend of /api/eval: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    pub(crate) eval_backend: BackendKind,
    /// Largest estimated memory of one request (e.g. 256M, 1G; 422 naming the field
    /// beyond; docs/service-limits.md).
    #[arg(long, default_value = "256M")]
    pub(crate) max_request_memory: String,
    /// Most eval states and coefficient speeds in flight across requests (503 with
    /// Retry-After beyond).
    #[arg(long, default_value_t = 1 << 16)]
    pub(crate) max_states_in_flight: u64,
    /// Seconds a client has to send a request's header, from its first byte.
    #[arg(long, default_value_t = 10.0)]
    pub(crate) header_timeout_s: f64,
    /// Most connections open at once from one client address.
    #[arg(long, default_value_t = 512)]
    pub(crate) max_connections_per_client: usize,
}

#[cfg(feature = "service")]
#[derive(Args)]
pub(crate) struct SubmitArgs {
    /// Sweep spec (JSON), `-` for standard input.
    pub(crate) spec: String,
    /// Service URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub(crate) server: String,
    /// Bearer token (else BEARING_SWEEP_TOKEN).
    #[arg(long)]
    pub(crate) token: Option<String>,
    /// Wait for the end with a progress bar, then print where the result is.
    #[arg(long)]
    pub(crate) wait: bool,
    /// Backend for the film loads: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    /// Relative accuracy of the film loads.
    #[arg(long, default_value = "1e-6")]
    pub(crate) accuracy: f64,
    /// Turn every model reduction off.
    #[arg(long)]
    pub(crate) full_model: bool,
}

#[derive(Args)]
pub(crate) struct CoefficientsArgs {
    /// Input JSON file, `-` for standard input.
    pub(crate) file: String,
    /// Output: `json`, `ross-csv` (speed, kxx, kxy, kyx, kyy, cxx, cxy, cyx, cyy) or
    /// `ross-toml` (a file ROSS 2.x's `BearingElement.load` reads, with load, ε and geometry;
    /// `ross3-toml` for ROSS 3.x).
    #[arg(long, default_value = "json")]
    pub(crate) format: String,
    /// Backend: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    /// Relative accuracy of the film loads (the coefficients are differences of loads).
    #[arg(long, default_value = "1e-12")]
    pub(crate) accuracy: f64,
}

#[derive(Args)]
pub(crate) struct StabilityArgs {
    /// Scene file (as `run` reads it).
    pub(crate) file: String,
    /// Speeds of the Campbell diagram and threshold scan, rad/s, comma-separated
    /// (default: 41 speeds from 0.1x to 10x the scene's spin).
    #[arg(long, value_delimiter = ',')]
    pub(crate) speeds: Vec<f64>,
    /// Output root folder (stability.json, campbell.svg, damping.svg in OUT/<stem>/).
    #[arg(long, default_value = "out")]
    pub(crate) out: std::path::PathBuf,
    /// Backend: cpu, gpu or auto.
    #[arg(long, default_value = "auto")]
    pub(crate) backend: BackendKind,
    /// Relative accuracy of the film loads.
    #[arg(long, default_value = "1e-12")]
    pub(crate) accuracy: f64,
}

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// Merged result file.
    pub(crate) out: String,
    /// Shard result files.
    #[arg(required = true)]
    pub(crate) shards: Vec<String>,
}

#[cfg(feature = "postgres")]
#[derive(Args)]
pub(crate) struct WorkerArgs {
    /// The queue's database: postgres://user[:password]@host:port/database.
    #[arg(long)]
    pub(crate) database: String,
    /// Backend for the film loads: cpu, gpu or auto (workers claim only sweeps that allow it).
    #[arg(long, default_value = "cpu")]
    pub(crate) backend: BackendKind,
    /// Variants per claimed lockstep batch (default 256 on the CPU, 4096 on a GPU).
    #[arg(long)]
    pub(crate) batch: Option<usize>,
    /// Lease time to live without a heartbeat, s: a dead worker's batch runs elsewhere
    /// after this long.
    #[arg(long, default_value_t = 30.0)]
    pub(crate) lease_ttl: f64,
    /// Heartbeat period, s (default a third of --lease-ttl); cancel reaches the worker
    /// within one period.
    #[arg(long)]
    pub(crate) heartbeat: Option<f64>,
    /// Exit after this many seconds without work (default: run until SIGTERM/Ctrl-C).
    #[arg(long)]
    pub(crate) exit_when_idle: Option<f64>,
    /// Worker id in leases and results (default host/pid/nonce).
    #[arg(long)]
    pub(crate) id: Option<String>,
    /// Memory budget each claimed sweep is checked against and its rotor samples capped
    /// by, e.g. 512M, 8G (default 2G, as `run --max-memory`).
    #[arg(long)]
    pub(crate) max_memory: Option<String>,
}

#[cfg(feature = "postgres")]
#[derive(Args)]
pub(crate) struct BenchQueueArgs {
    /// A scratch database (sweeps are added and deleted): postgres://user@host:port/db.
    #[arg(long)]
    pub(crate) database: String,
    /// Worker process counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4")]
    pub(crate) workers: Vec<usize>,
    /// Variants per claim of those workers.
    #[arg(long, default_value_t = 32)]
    pub(crate) batch: usize,
    /// Grid points per axis of the rotor sweep (n x n variants).
    #[arg(long, default_value_t = 16)]
    pub(crate) grid: usize,
    /// Batches of the claim-and-commit overhead row.
    #[arg(long, default_value_t = 500)]
    pub(crate) overhead_batches: usize,
    /// Concurrent claimers in the storm.
    #[arg(long, default_value_t = 64)]
    pub(crate) storm_workers: usize,
    /// Length of the storm, s.
    #[arg(long, default_value_t = 10.0)]
    pub(crate) storm_seconds: f64,
    /// Scratch folder for the `run` reference.
    #[arg(long, default_value = "out/bench-queue")]
    pub(crate) out: std::path::PathBuf,
}

#[derive(Args)]
pub(crate) struct BenchAllArgs {
    /// Output folder (index.md, loads/, backend/, rotor/).
    #[arg(long, default_value = "out/bench-all")]
    pub(crate) out: std::path::PathBuf,
    /// The settings of BENCHMARKS.md instead of the quick ones.
    #[arg(long)]
    pub(crate) full: bool,
}

#[derive(Args)]
pub(crate) struct BenchLoadsArgs {
    /// Threads of the parallel runs (default: all cores).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Number of benchmark states.
    #[arg(long, default_value_t = 2000)]
    pub(crate) states: usize,
    /// Output folder for bench-loads.{json,md,svg}.
    #[arg(long, default_value = "out/bench")]
    pub(crate) out: std::path::PathBuf,
    /// Baseline grids n (n × n in θ × z), comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "32,64,128,256,512,1024,2048"
    )]
    pub(crate) grids: Vec<usize>,
    /// States per GPU call for the GPU rows (f64 and f32 kernels at each level); 0
    /// skips them. Without an adapter they are skipped with a note.
    #[arg(long, default_value_t = crate::bench::DEFAULT_GPU_BATCH)]
    pub(crate) gpu_batch: usize,
    /// Minimum wall time of one timing, s.
    #[arg(long, default_value_t = 0.5)]
    pub(crate) min_time: f64,
}

#[derive(Args)]
pub(crate) struct BenchBackendArgs {
    /// Backends: cpu, gpu or both.
    #[arg(long, default_value = "both")]
    pub(crate) backend: String,
    /// Batch sizes, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1,10,100,1000,10000,100000,1000000"
    )]
    pub(crate) sizes: Vec<usize>,
    /// Accuracy level of the rule.
    #[arg(long, default_value = "1e-6")]
    pub(crate) accuracy: f64,
    /// CPU backend threads.
    #[arg(long, default_value_t = 2)]
    pub(crate) threads: usize,
    /// Seconds to spend per measurement (repeats up to --max-reps).
    #[arg(long, default_value_t = 1.0)]
    pub(crate) min_time: f64,
    /// Most repetitions per measurement.
    #[arg(long, default_value_t = 50)]
    pub(crate) max_reps: usize,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    pub(crate) json: Option<String>,
}

#[derive(Args)]
pub(crate) struct BenchRotorArgs {
    /// Simulated time, s.
    #[arg(long, default_value_t = 0.5)]
    pub(crate) t_end: f64,
    /// Film-load accuracy level.
    #[arg(long, default_value = "1e-12")]
    pub(crate) accuracy: f64,
    /// Timing repeats per configuration (the fastest counts).
    #[arg(long, default_value_t = 3)]
    pub(crate) repeats: usize,
    /// Output folder for the diagrams.
    #[arg(long, default_value = "out/bench-rotor")]
    pub(crate) out: std::path::PathBuf,
    /// Instead of the work-precision study: lockstep batches of these sizes against
    /// one-by-one runs (comma-separated, e.g. 1,16,256).
    #[arg(long, value_delimiter = ',')]
    pub(crate) batch: Vec<usize>,
    /// CPU threads for --batch (default: all).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Replace both bearings' viscosity (Pa·s): the stiff variant of the study.
    #[arg(long)]
    pub(crate) viscosity: Option<f64>,
}
