//! The job store: the small [`Store`] trait the service runs on (sweeps, their committed
//! variant lines, their figures) and the [`StoreSink`] that lets the shared runner commit
//! into it. The embedded SQLite implementation is in [`super::sqlite`]; PostgreSQL can be
//! plugged in behind the same trait.

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::sweep::job::ParsedSweep;
use crate::sweep::sink::{Committed, VariantSink};
use crate::sweep::{SweepError, SweepKind};

/// A store failure.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The database failed (I/O, corruption, lock): the backend's message.
    #[error("store: {0}")]
    Backend(String),
    /// The store cannot be reached now (database down or restarting, disk full, busy):
    /// retrying later may succeed (HTTP 503 with `Retry-After`).
    #[error("store unavailable: {0}")]
    Unavailable(String),
    /// `insert_sweep_limited` found `open` sweeps queued or running, at the `limit`.
    #[error("{open} sweeps are queued or running, the limit is {limit}")]
    QueueFull {
        /// Sweeps queued or running.
        open: u64,
        /// The limit.
        limit: u64,
    },
    /// The sweep does not exist (deleted meanwhile).
    #[error("sweep {0} not found")]
    NotFound(String),
    /// Stored variants belong to another run identity (spec, settings, shard).
    #[error("sweep {id}: stored variants were written by another run ({reason})")]
    Mismatch {
        /// Sweep id.
        id: String,
        /// What differs.
        reason: String,
    },
}

/// Life cycle of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum SweepStatus {
    /// Waiting for a scheduler slot.
    Queued,
    /// Its variants are being computed.
    Running,
    /// Every variant finished (some may have a failure status).
    Done,
    /// The job itself failed (setup error, store error, panic): see the message.
    Failed,
    /// Cancelled by a request; finished variants stay readable.
    Cancelled,
}

impl SweepStatus {
    /// The name stored and shown.
    pub fn name(self) -> &'static str {
        match self {
            SweepStatus::Queued => "queued",
            SweepStatus::Running => "running",
            SweepStatus::Done => "done",
            SweepStatus::Failed => "failed",
            SweepStatus::Cancelled => "cancelled",
        }
    }

    /// Parses a stored name.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "queued" => SweepStatus::Queued,
            "running" => SweepStatus::Running,
            "done" => SweepStatus::Done,
            "failed" => SweepStatus::Failed,
            "cancelled" => SweepStatus::Cancelled,
            _ => return None,
        })
    }

    /// No more changes will come (done, failed, cancelled).
    pub fn is_final(self) -> bool {
        matches!(
            self,
            SweepStatus::Done | SweepStatus::Failed | SweepStatus::Cancelled
        )
    }
}

/// A sweep as submitted.
#[derive(Clone, Debug, PartialEq)]
pub struct NewSweep {
    /// Opaque id.
    pub id: String,
    /// The spec's `name` (or empty).
    pub name: String,
    /// The spec document exactly as posted (parsed JSON).
    pub spec: Value,
    /// Its kind.
    pub kind: SweepKind,
    /// Its canonical form (`SweepSpec::canonical`: base inlined), or the posted document
    /// for a friction map: what a store that queues work for other processes keeps.
    pub canonical: Value,
    /// Run options (backend, accuracy, full_model) as JSON.
    pub options: Value,
    /// Variants in the sweep.
    pub total: u64,
    /// Submission time, seconds since the Unix epoch.
    pub created_unix_s: f64,
}

impl NewSweep {
    /// A submission of `doc`, parsed once as `parsed` (`total` variants), under `id` with
    /// `options`, now.
    pub fn submitted(
        id: String,
        doc: Value,
        parsed: &ParsedSweep,
        total: u64,
        options: Value,
    ) -> Self {
        let canonical = match parsed {
            ParsedSweep::Runner(spec) => spec.canonical.clone(),
            ParsedSweep::FrictionMap(_) => doc.clone(),
        };
        NewSweep {
            id,
            name: parsed.name(),
            spec: doc,
            kind: parsed.kind(),
            canonical,
            options,
            total,
            created_unix_s: super::scheduler::now_unix_s(),
        }
    }
}

/// A stored sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepRow {
    /// Opaque id.
    pub id: String,
    /// Submission order (FIFO key).
    pub seq: i64,
    /// The spec's `name`.
    pub name: String,
    /// Status.
    pub status: SweepStatus,
    /// The spec as posted (`Null` in summary rows: [`Store::list_sweeps`],
    /// [`Store::sweep_summary`]).
    pub spec: Value,
    /// Run options.
    pub options: Value,
    /// Variants in the sweep.
    pub total: u64,
    /// Committed variants.
    pub done: u64,
    /// Committed variants whose status is not `ok`.
    pub failed: u64,
    /// Variants computed and committed over the sweep's life, resumes included: equals
    /// `done` unless a finished variant was computed twice (the durability check).
    pub computed: u64,
    /// Why it failed (status `failed`), or a note.
    pub message: Option<String>,
    /// The result's `run` section once done (timings, simulator).
    pub run: Option<Value>,
    /// The run identity given to `open_stream` (format, spec hash, settings, count);
    /// `None` in summary rows.
    pub header: Option<Value>,
    /// Submission time, s since the Unix epoch.
    pub created_unix_s: f64,
    /// Start of the latest run, s since the Unix epoch.
    pub started_unix_s: Option<f64>,
    /// End, s since the Unix epoch.
    pub finished_unix_s: Option<f64>,
}

/// A change to a stored sweep (fields left `None` stay).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepUpdate {
    /// New status.
    pub status: Option<SweepStatus>,
    /// New message (`Some(None)` clears it).
    pub message: Option<Option<String>>,
    /// The result's `run` section.
    pub run: Option<Value>,
    /// A whole result document, as the text served (friction maps, which have no
    /// variant lines): pretty JSON and a newline, as `run` writes result.json.
    pub result_doc: Option<String>,
    /// Start time, s since the Unix epoch.
    pub started_unix_s: Option<f64>,
    /// End time, s since the Unix epoch.
    pub finished_unix_s: Option<f64>,
    /// Finished variants, set at once (a friction map computes every point in one step
    /// and stores no variant lines; its progress then reads `total / total`).
    pub done: Option<u64>,
}

/// Where the service keeps sweeps. Every method is blocking (call it from a blocking
/// thread); an implementation is shared between threads.
///
/// Durability contract: once `commit_variant` returns, the line survives a crash of the
/// process; `open_stream` of the same identity returns it again.
pub trait Store: Send + Sync + 'static {
    /// Stores a new sweep with status `queued` and returns it (a summary row).
    fn insert_sweep(&self, new: &NewSweep) -> Result<SweepRow, StoreError>;
    /// [`Store::insert_sweep`] unless `max_open` sweeps are queued or running already
    /// ([`StoreError::QueueFull`]): counted and inserted in one transaction, so
    /// simultaneous submissions never pass the limit.
    fn insert_sweep_limited(&self, new: &NewSweep, max_open: u64) -> Result<SweepRow, StoreError>;
    /// Every sweep, oldest first, as summary rows (no spec, header or result document:
    /// listing costs the same whatever was stored).
    fn list_sweeps(&self) -> Result<Vec<SweepRow>, StoreError>;
    /// Sweeps queued now (`/metrics`). Default: counts [`Store::list_sweeps`]; the stores
    /// count with one query.
    fn count_queued(&self) -> Result<u64, StoreError> {
        Ok(self
            .list_sweeps()?
            .iter()
            .filter(|s| s.status == SweepStatus::Queued)
            .count() as u64)
    }
    /// One sweep, whole (spec and header too; what a run needs).
    fn sweep(&self, id: &str) -> Result<Option<SweepRow>, StoreError>;
    /// One sweep as a summary row (status, counts, times, `run` section).
    fn sweep_summary(&self, id: &str) -> Result<Option<SweepRow>, StoreError>;
    /// The stored result document's text (friction maps), if any.
    fn result_doc_text(&self, id: &str) -> Result<Option<String>, StoreError>;
    /// The oldest queued sweep this server runs itself, whole (`None`: none).
    fn next_queued(&self) -> Result<Option<SweepRow>, StoreError> {
        for s in self.list_sweeps()? {
            if s.status != SweepStatus::Queued {
                continue;
            }
            if let Some(full) = self.sweep(&s.id)? {
                if full.status == SweepStatus::Queued && !self.runs_elsewhere(&full) {
                    return Ok(Some(full));
                }
            }
        }
        Ok(None)
    }
    /// Changes a sweep.
    fn update_sweep(&self, id: &str, change: &SweepUpdate) -> Result<(), StoreError>;
    /// Removes a sweep, its variants and figures; false when there was none.
    fn delete_sweep(&self, id: &str) -> Result<bool, StoreError>;
    /// Opens the variant stream of a sweep for the run identified by `header`: stores the
    /// header the first time; refuses another; returns the committed variants.
    fn open_stream(&self, id: &str, header: &Value) -> Result<Committed, StoreError>;
    /// Commits one finished variant line (and counts it as computed) durably.
    fn commit_variant(
        &self,
        id: &str,
        variant: u64,
        ok: bool,
        line: &str,
    ) -> Result<(), StoreError>;
    /// Committed variant lines in id order, from the `offset`-th, at most `limit`.
    fn variant_lines(
        &self,
        id: &str,
        offset: u64,
        limit: u64,
    ) -> Result<Vec<(u64, String)>, StoreError>;
    /// Stores a figure (SVG text) under `name`.
    fn put_plot(&self, id: &str, name: &str, svg: &str) -> Result<(), StoreError>;
    /// A stored figure.
    fn plot(&self, id: &str, name: &str) -> Result<Option<String>, StoreError>;
    /// Names of the stored figures.
    fn plot_names(&self, id: &str) -> Result<Vec<String>, StoreError>;
    /// Whether other processes run this sweep (PostgreSQL: `worker` processes claim its
    /// batches), so the scheduler leaves it alone. Default: no.
    fn runs_elsewhere(&self, row: &SweepRow) -> bool {
        let _ = row;
        false
    }
}

/// Lines fetched per store call when reading a whole sweep back.
const PAGE: u64 = 1000;

/// The runner's sink for one sweep in a [`Store`]; calls `on_commit(id, ok)` after each
/// committed variant (for live events).
pub struct StoreSink {
    store: Arc<dyn Store>,
    id: String,
    on_commit: Box<dyn FnMut(u64, bool) + Send>,
}

impl StoreSink {
    /// The sink of sweep `id`.
    pub fn new(
        store: Arc<dyn Store>,
        id: &str,
        on_commit: Box<dyn FnMut(u64, bool) + Send>,
    ) -> Self {
        StoreSink {
            store,
            id: id.to_string(),
            on_commit,
        }
    }
}

fn sweep_error(e: StoreError) -> SweepError {
    SweepError::Output(e.to_string())
}

impl VariantSink for StoreSink {
    fn open(&mut self, header: &Value) -> Result<Committed, SweepError> {
        self.store
            .open_stream(&self.id, header)
            .map_err(sweep_error)
    }

    fn commit(&mut self, id: u64, ok: bool, line: &str) -> Result<(), SweepError> {
        self.store
            .commit_variant(&self.id, id, ok, line)
            .map_err(sweep_error)?;
        (self.on_commit)(id, ok);
        Ok(())
    }

    fn for_each_line(
        &mut self,
        f: &mut dyn FnMut(u64, &str) -> Result<(), SweepError>,
    ) -> Result<(), SweepError> {
        for_each_variant_line(self.store.as_ref(), &self.id, f, sweep_error)
    }
}

/// Calls `f` on every committed variant line of sweep `id`, in id order, fetching
/// [`PAGE`] lines per store call (so at most one page is held); stops at `f`'s first
/// error, and maps the store's own errors with `store_error`.
pub fn for_each_variant_line<E>(
    store: &dyn Store,
    id: &str,
    f: &mut dyn FnMut(u64, &str) -> Result<(), E>,
    store_error: impl Fn(StoreError) -> E,
) -> Result<(), E> {
    let mut offset = 0;
    loop {
        let page = store
            .variant_lines(id, offset, PAGE)
            .map_err(&store_error)?;
        for (variant, line) in &page {
            f(*variant, line)?;
        }
        if (page.len() as u64) < PAGE {
            return Ok(());
        }
        offset += PAGE;
    }
}
