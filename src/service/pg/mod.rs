//! The sweep service on PostgreSQL: versioned migrations, a work queue of variant
//! batches claimed under heartbeated leases (`FOR UPDATE SKIP LOCKED`), results stored
//! exactly once with the lease's completion, the `worker` process loop, and the
//! service's store on the same tables (`serve --database`).

mod command;
mod error;
mod migrations;
mod monitor;
mod queue;
mod result;
mod store;
mod submit;
mod worker;

pub use command::{worker_command, WorkerCommandOptions};
pub use error::PgError;
pub use migrations::{migrate, Migration, MIGRATIONS};
pub use monitor::{monitor, run_section, spawn_monitor};
pub use queue::{
    BatchStats, Completion, Lease, LeaseState, PgQueue, QueueRow, QueuedSweep, SweepJob,
    SweepOptions, VariantRow, DEFAULT_BATCH_VARIANTS, RESULTS_LOCK_CLASS,
};
pub use result::result_document;
pub use store::{PgStore, RETRY_FOR};
pub use submit::{new_sweep_id, parse_queued, submit_spec};
pub use worker::{
    build_simulator, default_worker_id, resolve_backend, run_variants, run_worker, WorkerOptions,
    WorkerSummary,
};
