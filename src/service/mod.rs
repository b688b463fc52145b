//! The sweep service (`bearing-sweep serve`): an axum HTTP API over a job store, a FIFO
//! scheduler running sweeps through the same runner as `run`, and coalesced film-load
//! evaluation.

mod bodies;
mod command;
pub mod csv;
mod error;
mod eval;
pub mod limits;
mod listen;
mod metrics;
#[cfg(feature = "postgres")]
pub mod pg;
mod routes;
mod scheduler;
mod sqlite;
mod store;
mod sweeps;
pub mod web;

pub use command::serve_command;
pub use error::{ApiError, ErrorBody, ErrorDetail};
pub use eval::{Coalescer, EvalCounters};
pub use routes::{rfc3339, router, ApiDoc};
pub use scheduler::{LiveSweep, Scheduler, SweepEvent};
pub use sqlite::SqliteStore;
pub use store::{NewSweep, Store, StoreError, StoreSink, SweepRow, SweepStatus, SweepUpdate};
pub use sweeps::{options_from_query, parse_options, parse_sweep_doc, ParsedSweep};

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crate::backend::BackendKind;

/// Settings of `serve`.
#[derive(Clone, Debug)]
pub struct ServiceConfig {
    /// Address to listen on (default 127.0.0.1:8080; port 0 picks a free one).
    pub bind: SocketAddr,
    /// Folder of the store (default `bearing-sweep-data/`).
    pub data: PathBuf,
    /// Bearer token required on `/api` (none: open; required off loopback).
    pub token: Option<String>,
    /// Sweeps running at once (default 1).
    pub max_running: usize,
    /// Largest request body, bytes (default 4 MiB).
    pub max_body_bytes: usize,
    /// Most variants per sweep (default 1,000,000).
    pub max_variants: u64,
    /// Most sweeps queued or running (default 64).
    pub max_queued: u64,
    /// Coalescing window of `/api/eval` (default 2 ms).
    pub eval_window: Duration,
    /// Backend of `/api/eval` (default cpu).
    pub eval_backend: BackendKind,
    /// `postgres://…`: keep sweeps in PostgreSQL and leave them to `worker` processes
    /// (docs/api.md "Workers and PostgreSQL"); default none: the embedded SQLite store.
    pub database: Option<String>,
    /// Largest estimated memory of one request (eval states, coefficient speeds and the
    /// parsed body), bytes (default 256 MiB; 422 naming the field beyond).
    pub max_request_bytes: u64,
    /// Most eval states and coefficient speeds in flight across all requests (default
    /// 65,536; 503 with `Retry-After` while they are in use).
    pub max_states_in_flight: u64,
    /// Time a client has to send a request's header, from its first byte (default
    /// 10 s; the connection is closed after it).
    pub header_timeout: Duration,
    /// Most connections open at once from one client address (default 512; more are
    /// closed at once).
    pub max_connections_per_client: usize,
    /// Memory budget of one sweep (default 2 GiB, as `run`'s): specs estimated above it
    /// are refused with 422 naming the field; rotor samples are capped by it.
    pub max_memory: crate::budget::MemoryBudget,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        ServiceConfig {
            bind: SocketAddr::from(([127, 0, 0, 1], 8080)),
            data: PathBuf::from("bearing-sweep-data"),
            token: None,
            max_running: 1,
            max_body_bytes: 4 << 20,
            max_variants: 1_000_000,
            max_queued: 64,
            eval_window: Duration::from_millis(2),
            eval_backend: BackendKind::Cpu,
            database: None,
            max_request_bytes: 256 << 20,
            max_states_in_flight: 1 << 16,
            header_timeout: Duration::from_secs(10),
            max_connections_per_client: 512,
            max_memory: crate::budget::MemoryBudget::default(),
        }
    }
}

/// Why the service cannot start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// A setting is refused (e.g. a public bind without a token).
    #[error("{0}")]
    Config(String),
    /// The store could not be opened.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Another `serve` holds the store folder.
    #[error("{0}")]
    Busy(String),
    /// Binding or serving failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// Underlying error.
        source: std::io::Error,
    },
}

/// What the handlers share.
#[derive(Clone)]
pub struct AppState {
    /// Settings.
    pub config: Arc<ServiceConfig>,
    /// The store.
    pub store: Arc<dyn Store>,
    /// The scheduler.
    pub scheduler: Arc<Scheduler>,
    /// The eval coalescer.
    pub coalescer: Coalescer,
    /// Request latencies.
    pub latency: Arc<metrics::LatencyHistogram>,
    /// The work and memory budget of requests.
    pub limits: Arc<limits::Limits>,
    /// Becomes true when the server shuts down (ends event streams).
    pub shutdown: tokio::sync::watch::Receiver<bool>,
}

/// Refuses a non-loopback bind without a token.
pub fn check_config(config: &ServiceConfig) -> Result<(), ServeError> {
    if !config.bind.ip().is_loopback() && config.token.as_deref().is_none_or(str::is_empty) {
        return Err(ServeError::Config(format!(
            "refusing to listen on {} without a token: anyone who can reach it could run work on this machine. Pass --token T (or set BEARING_SWEEP_TOKEN), or bind 127.0.0.1",
            config.bind
        )));
    }
    if config.max_request_bytes == 0 || config.max_states_in_flight == 0 {
        return Err(ServeError::Config(
            "--max-request-memory and --max-states-in-flight must be positive".into(),
        ));
    }
    if config.max_connections_per_client == 0 {
        return Err(ServeError::Config(
            "--max-connections-per-client must be at least 1".into(),
        ));
    }
    if config.max_running == 0 {
        return Err(ServeError::Config(
            "--max-running must be at least 1".into(),
        ));
    }
    Ok(())
}

/// A running service (inside a tokio runtime): the state and the task handles.
pub struct Running {
    /// The shared state (for tests that drive the router in process).
    pub state: AppState,
    /// Set to true to stop event streams.
    pub shutdown: tokio::sync::watch::Sender<bool>,
}

/// Builds the state over `store` and starts the scheduler and the coalescer (must be
/// called inside a tokio runtime).
pub fn start(config: ServiceConfig, store: Arc<dyn Store>) -> Result<Running, ServeError> {
    check_config(&config)?;
    let scheduler = Scheduler::new(store.clone(), config.max_running, config.max_memory)?;
    tokio::spawn(scheduler.clone().run());
    let coalescer = Coalescer::start(config.eval_window, config.eval_backend);
    let (tx, rx) = tokio::sync::watch::channel(false);
    let limits = Arc::new(limits::Limits::new(&config));
    Ok(Running {
        state: AppState {
            limits,
            config: Arc::new(config),
            store,
            scheduler,
            coalescer,
            latency: Arc::new(metrics::LatencyHistogram::default()),
            shutdown: rx,
        },
        shutdown: tx,
    })
}

/// Runs `serve` until SIGTERM or Ctrl-C: opens the SQLite store in `config.data`, binds,
/// prints `listening on http://ADDR` on stderr, serves; on the signal stops accepting,
/// ends event streams, checkpoints the running sweeps back into the queue and returns.
pub fn serve_blocking(
    config: ServiceConfig,
    notice: &mut dyn FnMut(String),
) -> Result<(), ServeError> {
    check_config(&config)?;
    // Request logs on stderr when RUST_LOG asks (e.g. RUST_LOG=tower_http=debug); silent
    // otherwise. A second initialisation (tests) is ignored.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .try_init();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|source| ServeError::Io {
            what: "starting the runtime".into(),
            source,
        })?;
    runtime.block_on(async move {
        let database = config.database.clone();
        // One server per store folder: held until this function returns.
        let _lock = match &database {
            Some(_) => None,
            None => Some(listen::DataLock::acquire(&config.data)?),
        };
        let store: Arc<dyn Store> = match &database {
            #[cfg(feature = "postgres")]
            Some(url) => Arc::new(pg::PgStore::open(url)?),
            #[cfg(not(feature = "postgres"))]
            Some(_) => {
                return Err(ServeError::Config(
                    "--database: this binary was built without the `postgres` feature".into(),
                ))
            }
            None => Arc::new(SqliteStore::open(&config.data)?),
        };
        let data = config.data.clone();
        let bind = config.bind;
        let running = start(config, store)?;
        #[cfg(feature = "postgres")]
        if let Some(url) = &database {
            pg::spawn_monitor(
                url,
                running.state.scheduler.clone(),
                running.shutdown.subscribe(),
            )
            .map_err(|e| ServeError::Config(e.to_string()))?;
        }
        let listener = tokio::net::TcpListener::bind(bind)
            .await
            .map_err(|source| ServeError::Io {
                what: format!("binding {bind}"),
                source,
            })?;
        let addr = listener.local_addr().map_err(|source| ServeError::Io {
            what: "reading the bound address".into(),
            source,
        })?;
        notice(format!(
            "listening on http://{addr} (data in {}; API description at /api/openapi.json)",
            data.display()
        ));
        let app = router(running.state.clone());
        let stop = running.shutdown;
        let scheduler = running.state.scheduler.clone();
        let draining = scheduler.clone();
        let conf = running.state.config.clone();
        listen::serve(
            listener,
            app,
            listen::ConnLimits {
                header_timeout: conf.header_timeout,
                per_client: conf.max_connections_per_client,
            },
            async move {
                shutdown_signal().await;
                draining.stop_taking();
                // End the long-lived event streams so the graceful shutdown completes.
                let _ = stop.send(true);
            },
        )
        .await;
        notice("shutting down: checkpointing running sweeps".into());
        scheduler.drain().await;
        notice("stopped".into());
        Ok(())
    })
}

/// SIGTERM or Ctrl-C.
async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
