//! The scheduler: runs queued sweeps in submission order, `max_running` at a time, each on
//! a blocking thread through the same runner as `run` (with the store as its sink). A
//! panic inside a job marks that sweep failed; the server keeps serving. Draining (on
//! SIGTERM) cancels the running variants, leaves their sweeps queued (finished variants
//! are already committed) and waits for the threads.

use std::collections::HashMap;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde_json::{json, Value};
use tokio::sync::{broadcast, Notify};

use super::error::ApiError;
use super::store::{NewSweep, Store, StoreSink, SweepRow, SweepStatus, SweepUpdate};
use super::sweeps::{check_submission, new_sweep_id, parse_options, parse_sweep_doc, ParsedSweep};
use crate::sweep::friction_map::friction_map;
use crate::sweep::job::Figures;
use crate::sweep::progress::{Progress, ProgressCounters, ProgressSnapshot};
use crate::sweep::runner::{run_variants, RunnerOptions};
use crate::sweep::simulator::prepare_simulator;
use crate::sweep::sink::VariantSink;
use crate::sweep::SweepOptions;

/// Events buffered per sweep for slow SSE readers (older ones are skipped).
const EVENT_BUFFER: usize = 1024;
/// Longest wait of the scheduler loop between looks at the queue (a missed wake-up costs
/// at most this).
const POLL: Duration = Duration::from_millis(500);
/// First wait before writing a sweep's final status again after the store refused it
/// (disk full, database unreachable); doubles up to [`FINAL_RETRY_MAX`].
const FINAL_RETRY_START: Duration = Duration::from_millis(200);
/// Longest wait between two attempts at a final status.
const FINAL_RETRY_MAX: Duration = Duration::from_secs(5);
/// Most parsed specs kept in memory (one evicted is parsed again when next needed).
const SPEC_CACHE: usize = 256;
/// Most JSON text (canonical form) of the parsed specs kept in memory, bytes: 64 bodies
/// at the default `serve --max-body-bytes` of 4 MiB would be 256 MiB of text and a few
/// times that parsed, so the cache is bounded by size too; a spec larger than this alone is
/// not kept (parsed at each use, as before the cache).
const SPEC_CACHE_BYTES: usize = 16 << 20;
/// Size charged for a friction map's fixed fields, bytes (its loads and speeds are
/// charged 8 bytes each on top).
const FRICTION_MAP_SPEC_BYTES: usize = 1024;

/// Parsed specs by sweep id, bounded by count and by the size of their JSON text.
struct SpecCache {
    entries: HashMap<String, (Arc<ParsedSweep>, usize)>,
    bytes: usize,
    max_entries: usize,
    max_bytes: usize,
}

impl SpecCache {
    fn new(max_entries: usize, max_bytes: usize) -> Self {
        SpecCache {
            entries: HashMap::new(),
            bytes: 0,
            max_entries,
            max_bytes,
        }
    }

    fn get(&self, id: &str) -> Option<Arc<ParsedSweep>> {
        self.entries.get(id).map(|(p, _)| p.clone())
    }

    fn insert(&mut self, id: &str, parsed: Arc<ParsedSweep>) {
        self.remove(id);
        let weight = spec_weight(&parsed);
        if weight > self.max_bytes || self.max_entries == 0 {
            return;
        }
        while self.entries.len() >= self.max_entries || self.bytes + weight > self.max_bytes {
            // Any one goes: it is parsed again at its next use.
            let Some(k) = self.entries.keys().next().cloned() else {
                break;
            };
            self.remove(&k);
        }
        self.bytes += weight;
        self.entries.insert(id.to_string(), (parsed, weight));
    }

    fn remove(&mut self, id: &str) {
        if let Some((_, w)) = self.entries.remove(id) {
            self.bytes -= w;
        }
    }
}

/// The size a parsed spec is charged in the cache: its canonical JSON text, bytes.
fn spec_weight(p: &ParsedSweep) -> usize {
    match p {
        ParsedSweep::Runner(s) => serde_json::to_string(&s.canonical).map_or(0, |t| t.len()),
        ParsedSweep::FrictionMap(f) => FRICTION_MAP_SPEC_BYTES + 8 * (f.load.len() + f.speed.len()),
    }
}

/// A live event of one sweep.
#[derive(Clone, Debug, PartialEq)]
pub enum SweepEvent {
    /// A variant was committed.
    Variant {
        /// Variant id.
        id: u64,
        /// Its status is `ok`.
        ok: bool,
        /// Progress after it.
        progress: ProgressSnapshot,
    },
    /// The sweep's status changed (`done`, `failed`, `cancelled` end the stream).
    Status(SweepStatus),
    /// The sweep was deleted (ends the stream).
    Deleted,
}

/// The in-memory side of a sweep: cancel flag, progress counters, event channel.
pub struct LiveSweep {
    /// Set by a cancel request or a drain.
    pub cancel: Arc<AtomicBool>,
    /// Set when the cancel is a drain (the sweep goes back to the queue, not cancelled).
    pub draining: AtomicBool,
    /// The runner's counters (one source of truth for status and events).
    pub progress: Arc<ProgressCounters>,
    /// Live events.
    pub events: broadcast::Sender<SweepEvent>,
}

impl LiveSweep {
    fn new() -> Arc<Self> {
        Arc::new(LiveSweep {
            cancel: Arc::new(AtomicBool::new(false)),
            draining: AtomicBool::new(false),
            progress: ProgressCounters::shared(),
            events: broadcast::channel(EVENT_BUFFER).0,
        })
    }
}

/// Counters for `/metrics`.
#[derive(Debug, Default)]
pub struct SchedulerCounters {
    /// Variants committed since start.
    pub variants_done: AtomicU64,
    /// ... of which not ok.
    pub variants_failed: AtomicU64,
    /// Sweeps running now.
    pub running: AtomicU64,
}

/// The scheduler, shared by the routes.
pub struct Scheduler {
    store: Arc<dyn Store>,
    max_running: usize,
    jobs: Mutex<HashMap<String, Arc<LiveSweep>>>,
    wake: Notify,
    draining: AtomicBool,
    threads: Mutex<Vec<tokio::task::JoinHandle<()>>>,
    /// Parsed specs by sweep id: a spec is parsed once in this process (at submission, or
    /// at its first use after a restart), not again on every run or GET of its result.
    specs: Mutex<SpecCache>,
    /// Memory budget each sweep is parsed and run within (`ServiceConfig::max_memory`).
    max_memory: crate::budget::MemoryBudget,
    /// Metrics counters.
    pub counters: SchedulerCounters,
}

/// Seconds since the Unix epoch.
pub fn now_unix_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

impl Scheduler {
    /// A scheduler over `store`; sweeps left `running` by a killed server go back to the
    /// queue (their committed variants are kept and not computed again).
    pub fn new(
        store: Arc<dyn Store>,
        max_running: usize,
        max_memory: crate::budget::MemoryBudget,
    ) -> Result<Arc<Self>, super::store::StoreError> {
        for s in store.list_sweeps()? {
            if s.status == SweepStatus::Running {
                store.update_sweep(
                    &s.id,
                    &SweepUpdate {
                        status: Some(SweepStatus::Queued),
                        ..Default::default()
                    },
                )?;
            }
        }
        Ok(Arc::new(Scheduler {
            store,
            max_running: max_running.max(1),
            jobs: Mutex::new(HashMap::new()),
            wake: Notify::new(),
            draining: AtomicBool::new(false),
            threads: Mutex::new(Vec::new()),
            specs: Mutex::new(SpecCache::new(SPEC_CACHE, SPEC_CACHE_BYTES)),
            max_memory,
            counters: SchedulerCounters::default(),
        }))
    }

    /// The job of sweep `id` (created on first use).
    pub fn job(&self, id: &str) -> Arc<LiveSweep> {
        let mut jobs = self.jobs.lock().unwrap_or_else(|e| e.into_inner());
        jobs.entry(id.to_string())
            .or_insert_with(LiveSweep::new)
            .clone()
    }

    /// Live progress of a running sweep (`None` when it is not running here).
    pub fn live_progress(&self, id: &str) -> Option<ProgressSnapshot> {
        let jobs = self.jobs.lock().unwrap_or_else(|e| e.into_inner());
        jobs.get(id)
            .filter(|j| j.progress.snapshot().total > 0)
            .map(|j| j.progress.snapshot())
    }

    /// Something was queued: look at the queue now.
    pub fn wake(&self) {
        self.wake.notify_one();
    }

    /// Requests cancellation of sweep `id` (running variants stop within a second).
    pub fn cancel(&self, id: &str) {
        self.job(id).cancel.store(true, Ordering::Relaxed);
    }

    /// Cancels sweep `id`, whose stored status is `status`: a running one stops within a
    /// second (its runner writes the final status); a queued one is cancelled in the store
    /// at once and its event streams are told. Returns the status to report now.
    /// Blocking (a store write).
    pub fn cancel_sweep(
        &self,
        id: &str,
        status: SweepStatus,
    ) -> Result<SweepStatus, super::store::StoreError> {
        self.cancel(id);
        if status != SweepStatus::Queued {
            return Ok(status);
        }
        // Not started: cancelled at once.
        self.store.update_sweep(
            id,
            &SweepUpdate {
                status: Some(SweepStatus::Cancelled),
                finished_unix_s: Some(now_unix_s()),
                ..Default::default()
            },
        )?;
        let _ = self
            .job(id)
            .events
            .send(SweepEvent::Status(SweepStatus::Cancelled));
        Ok(SweepStatus::Cancelled)
    }

    /// Submits the spec document `doc` with run `options` (`POST /api/sweeps`): checks it
    /// as [`check_submission`] does (within `max_variants` and this scheduler's memory
    /// budget), stores it as queued (counted and inserted in one transaction: 429 when
    /// `max_queued` sweeps are open), keeps its parsed spec and wakes the scheduler.
    /// Blocking (parsing, validation, a store write).
    pub fn submit(
        &self,
        doc: Value,
        options: &SweepOptions,
        max_variants: u64,
        max_queued: u64,
    ) -> Result<SweepRow, ApiError> {
        let (parsed, total) = check_submission(&doc, max_variants, self.max_memory)?;
        let options = serde_json::to_value(options).unwrap_or_default();
        let new = NewSweep::submitted(new_sweep_id(), doc, &parsed, total, options);
        let row = self.store.insert_sweep_limited(&new, max_queued)?;
        // Parsed once: the runs and the result route use this one.
        self.remember_spec(&row.id, Arc::new(parsed));
        self.wake();
        Ok(row)
    }

    /// Keeps the spec of sweep `id` as parsed at its submission.
    pub fn remember_spec(&self, id: &str, parsed: Arc<ParsedSweep>) {
        self.specs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(id, parsed);
    }

    /// The parsed spec of the sweep in `row` (a whole row: its spec document is parsed
    /// here only the first time this process needs it).
    pub fn spec_of(&self, row: &SweepRow) -> Result<Arc<ParsedSweep>, crate::sweep::SweepError> {
        if let Some(p) = self
            .specs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&row.id)
        {
            return Ok(p);
        }
        let parsed = Arc::new(parse_sweep_doc(&row.spec, self.max_memory)?);
        self.remember_spec(&row.id, parsed.clone());
        Ok(parsed)
    }

    /// Forgets the in-memory side of a deleted sweep (call it after the store deleted
    /// it): its run stops, and its event streams get [`SweepEvent::Deleted`] and end.
    pub fn forget(&self, id: &str) {
        self.specs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        let mut jobs = self.jobs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(j) = jobs.remove(id) {
            j.cancel.store(true, Ordering::Relaxed);
            let _ = j.events.send(SweepEvent::Deleted);
        }
    }

    /// Sweeps running now.
    pub fn running(&self) -> u64 {
        self.counters.running.load(Ordering::Relaxed)
    }

    /// The scheduling loop (until a drain).
    pub async fn run(self: Arc<Self>) {
        loop {
            if self.draining.load(Ordering::Relaxed) {
                return;
            }
            while (self.running() as usize) < self.max_running {
                let store = self.store.clone();
                let next = tokio::task::spawn_blocking(move || store.next_queued()).await;
                let Ok(Ok(Some(row))) = next else { break };
                if self.draining.load(Ordering::Relaxed) {
                    return;
                }
                self.start(row).await;
            }
            let _ = tokio::time::timeout(POLL, self.wake.notified()).await;
        }
    }

    async fn start(self: &Arc<Self>, row: SweepRow) {
        let store = self.store.clone();
        let id = row.id.clone();
        let marked = tokio::task::spawn_blocking(move || {
            store.update_sweep(
                &id,
                &SweepUpdate {
                    status: Some(SweepStatus::Running),
                    started_unix_s: Some(now_unix_s()),
                    ..Default::default()
                },
            )
        })
        .await;
        if !matches!(marked, Ok(Ok(()))) {
            return;
        }
        self.counters.running.fetch_add(1, Ordering::Relaxed);
        let job = self.job(&row.id);
        let _ = job.events.send(SweepEvent::Status(SweepStatus::Running));
        let me = self.clone();
        let handle = tokio::task::spawn_blocking(move || {
            let id = row.id.clone();
            let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| me.run_job(&row, &job)));
            let update = match outcome {
                Ok(u) => u,
                Err(panic) => {
                    let what = panic
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| panic.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "unknown panic".into());
                    SweepUpdate {
                        status: Some(SweepStatus::Failed),
                        message: Some(Some(format!("internal error (panic): {what}"))),
                        finished_unix_s: Some(now_unix_s()),
                        ..Default::default()
                    }
                }
            };
            let status = update.status;
            me.write_final(&id, &update);
            if let Some(s) = status {
                let _ = job.events.send(SweepEvent::Status(s));
                if s.is_final() {
                    // Nothing more will happen to it: readers see the stored status.
                    me.jobs
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .remove(&id);
                }
            }
            me.counters.running.fetch_sub(1, Ordering::Relaxed);
            me.wake();
        });
        let mut threads = self.threads.lock().unwrap_or_else(|e| e.into_inner());
        threads.retain(|h| !h.is_finished());
        threads.push(handle);
    }

    /// Writes a job's last update; a store that refuses it (disk full, database down) is
    /// retried with backoff until it takes it, the sweep is gone, or the server drains
    /// (then the sweep stays `running` in the store and the next start requeues it):
    /// a sweep is never left `running` by a server that goes on serving.
    fn write_final(&self, id: &str, update: &SweepUpdate) {
        let mut delay = FINAL_RETRY_START;
        let mut warned = false;
        loop {
            match self.store.update_sweep(id, update) {
                Ok(()) | Err(super::store::StoreError::NotFound(_)) => {
                    if warned {
                        tracing::warn!("sweep {id}: final status recorded");
                    }
                    return;
                }
                Err(e) => {
                    if !warned {
                        tracing::warn!("sweep {id}: cannot record its final status ({e}); retrying until the store takes it");
                        warned = true;
                    }
                    if self.draining.load(Ordering::Relaxed) {
                        return;
                    }
                    std::thread::sleep(delay);
                    delay = (delay * 2).min(FINAL_RETRY_MAX);
                }
            }
        }
    }

    /// Runs one sweep to its end on this (blocking) thread; returns the final update.
    fn run_job(&self, row: &SweepRow, job: &Arc<LiveSweep>) -> SweepUpdate {
        let failed = |message: String| SweepUpdate {
            status: Some(SweepStatus::Failed),
            message: Some(Some(message)),
            finished_unix_s: Some(now_unix_s()),
            ..Default::default()
        };
        let parsed = match self.spec_of(row) {
            Ok(p) => p,
            Err(e) => return failed(e.to_string()),
        };
        let choice = match parse_options(&row.options) {
            Ok(c) => SweepOptions {
                max_memory: self.max_memory,
                ..c
            },
            Err(e) => return failed(e.to_string()),
        };
        let spec = match &*parsed {
            ParsedSweep::FrictionMap(fm) => {
                let points = (fm.load.len() * fm.speed.len()) as u64;
                let (doc, plot) = friction_map(fm, choice.accuracy.level());
                if let Ok(svg) = plot.render() {
                    if let Err(e) = self.store.put_plot(&row.id, "friction-map", &svg) {
                        return failed(e.to_string());
                    }
                }
                // Stored as served: pretty, with a newline, as `run` writes result.json.
                let text = serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n";
                drop(doc);
                return SweepUpdate {
                    status: Some(SweepStatus::Done),
                    result_doc: Some(text),
                    finished_unix_s: Some(now_unix_s()),
                    done: Some(points),
                    ..Default::default()
                };
            }
            ParsedSweep::Runner(spec) => &**spec,
        };
        let mut notices = Vec::new();
        let mut prepared = match prepare_simulator(spec, &choice, &mut |n| notices.push(n)) {
            Ok(p) => p,
            Err(e) => return failed(e.to_string()),
        };
        let events = job.events.clone();
        let counters = job.progress.clone();
        let me_done = Arc::new(AtomicU64::new(0));
        let me_failed = Arc::new(AtomicU64::new(0));
        let (d, f) = (me_done.clone(), me_failed.clone());
        // The runner records progress after the commit returns; the event carries the
        // counts and rate including this variant.
        let mut sink = StoreSink::new(
            self.store.clone(),
            &row.id,
            Box::new(move |id, ok| {
                d.fetch_add(1, Ordering::Relaxed);
                if !ok {
                    f.fetch_add(1, Ordering::Relaxed);
                }
                let progress = counters.snapshot_after(ok);
                let _ = events.send(SweepEvent::Variant { id, ok, progress });
            }),
        );
        // Every variant, in the simulator's batches.
        let opts = RunnerOptions::default();
        let progress = Progress::silent(job.progress.clone());
        let report = run_variants(
            spec,
            &*prepared.validator,
            prepared.sim.as_mut(),
            &mut sink,
            &opts,
            &prepared.settings,
            &progress,
            &job.cancel,
            &mut |n| notices.push(n),
        );
        self.counters
            .variants_done
            .fetch_add(me_done.load(Ordering::Relaxed), Ordering::Relaxed);
        self.counters
            .variants_failed
            .fetch_add(me_failed.load(Ordering::Relaxed), Ordering::Relaxed);
        let report = match report {
            Ok(r) => r,
            Err(e) => return failed(e.to_string()),
        };
        if report.cancelled {
            if job.draining.load(Ordering::Relaxed) {
                // Back to the queue: the next start resumes it.
                return SweepUpdate {
                    status: Some(SweepStatus::Queued),
                    ..Default::default()
                };
            }
            return SweepUpdate {
                status: Some(SweepStatus::Cancelled),
                finished_unix_s: Some(now_unix_s()),
                ..Default::default()
            };
        }
        // Figures from the light part of the variants (no series), as `run` draws them.
        let mut figures = Figures::new(spec);
        if figures.wanted() {
            let read = sink.for_each_line(&mut |_, line| {
                figures.add_line(line);
                Ok(())
            });
            if let Err(e) = read {
                return failed(e.to_string());
            }
            for (name, svg) in figures.draw() {
                if let Ok(svg) = svg {
                    if let Err(e) = self.store.put_plot(&row.id, &name, &svg) {
                        return failed(e.to_string());
                    }
                }
            }
        }
        let mut run = report.run;
        if !notices.is_empty() {
            run["notices"] = json!(notices);
        }
        // The result document is rebuilt from the spec, the stored header and the lines on
        // each /result; only its `run` section is stored.
        SweepUpdate {
            status: Some(SweepStatus::Done),
            run: Some(run),
            finished_unix_s: Some(now_unix_s()),
            ..Default::default()
        }
    }

    /// Stops taking sweeps, cancels the running ones back into the queue and waits for
    /// their threads (finished variants are committed already).
    pub async fn drain(&self) {
        self.stop_taking();
        let handles: Vec<_> = {
            let mut t = self.threads.lock().unwrap_or_else(|e| e.into_inner());
            t.drain(..).collect()
        };
        for h in handles {
            let _ = h.await;
        }
    }

    /// The first half of [`Scheduler::drain`]: no new sweep starts, running ones are
    /// cancelled back into the queue (returns at once).
    pub fn stop_taking(&self) {
        self.draining.store(true, Ordering::Relaxed);
        self.wake.notify_waiters();
        {
            let jobs = self.jobs.lock().unwrap_or_else(|e| e.into_inner());
            for j in jobs.values() {
                j.draining.store(true, Ordering::Relaxed);
                j.cancel.store(true, Ordering::Relaxed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::store::{NewSweep, StoreError};
    use crate::service::SqliteStore;
    use crate::sweep::sink::Committed;
    use serde_json::Value;

    /// The SQLite store, except that opening the variants of sweep `boom` panics, and
    /// the first `.1` final statuses are refused as by a full disk.
    struct PanicStore(SqliteStore, std::sync::atomic::AtomicU32);

    impl Store for PanicStore {
        fn insert_sweep(&self, n: &NewSweep) -> Result<SweepRow, StoreError> {
            self.0.insert_sweep(n)
        }
        fn list_sweeps(&self) -> Result<Vec<SweepRow>, StoreError> {
            self.0.list_sweeps()
        }
        fn sweep(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
            self.0.sweep(id)
        }
        fn insert_sweep_limited(&self, n: &NewSweep, m: u64) -> Result<SweepRow, StoreError> {
            self.0.insert_sweep_limited(n, m)
        }
        fn sweep_summary(&self, id: &str) -> Result<Option<SweepRow>, StoreError> {
            self.0.sweep_summary(id)
        }
        fn result_doc_text(&self, id: &str) -> Result<Option<String>, StoreError> {
            self.0.result_doc_text(id)
        }
        fn update_sweep(&self, id: &str, c: &SweepUpdate) -> Result<(), StoreError> {
            let is_final = c.status.is_some_and(SweepStatus::is_final);
            if is_final
                && self
                    .1
                    .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                    .is_ok()
            {
                return Err(StoreError::Unavailable("database or disk is full".into()));
            }
            self.0.update_sweep(id, c)
        }
        fn delete_sweep(&self, id: &str) -> Result<bool, StoreError> {
            self.0.delete_sweep(id)
        }
        fn open_stream(&self, id: &str, h: &Value) -> Result<Committed, StoreError> {
            assert_ne!(id, "boom", "injected panic");
            self.0.open_stream(id, h)
        }
        fn commit_variant(&self, id: &str, v: u64, ok: bool, l: &str) -> Result<(), StoreError> {
            self.0.commit_variant(id, v, ok, l)
        }
        fn variant_lines(
            &self,
            id: &str,
            o: u64,
            l: u64,
        ) -> Result<Vec<(u64, String)>, StoreError> {
            self.0.variant_lines(id, o, l)
        }
        fn put_plot(&self, id: &str, n: &str, s: &str) -> Result<(), StoreError> {
            self.0.put_plot(id, n, s)
        }
        fn plot(&self, id: &str, n: &str) -> Result<Option<String>, StoreError> {
            self.0.plot(id, n)
        }
        fn plot_names(&self, id: &str) -> Result<Vec<String>, StoreError> {
            self.0.plot_names(id)
        }
    }

    #[test]
    fn the_spec_cache_stays_within_its_count_and_size() {
        let spec = |n: usize| {
            let values: Vec<f64> = (0..n).map(|k| k as f64).collect();
            let doc = json!({"kind": "synthetic", "base": {"spin": 1.0},
                             "axes": [{"path": "spin", "values": values}]});
            Arc::new(parse_sweep_doc(&doc, Default::default()).unwrap())
        };
        let w = spec_weight(&spec(10));
        let canonical = match &*spec(10) {
            ParsedSweep::Runner(s) => serde_json::to_string(&s.canonical).unwrap(),
            ParsedSweep::FrictionMap(_) => unreachable!(),
        };
        assert_eq!(w, canonical.len());
        // Room for three of these by size, five by count.
        let mut c = SpecCache::new(5, 3 * w + w / 2);
        for k in 0..10 {
            c.insert(&format!("s{k}"), spec(10));
            assert!(
                c.bytes <= 3 * w + w / 2 && c.entries.len() <= 3,
                "{k}: {}",
                c.bytes
            );
            assert!(c.get(&format!("s{k}")).is_some(), "the newest is kept");
        }
        let sum: usize = c.entries.values().map(|(_, w)| w).sum();
        assert_eq!(c.bytes, sum);
        // Inserting the same id again does not count it twice.
        c.insert("s9", spec(10));
        assert_eq!(c.bytes, c.entries.values().map(|(_, w)| w).sum::<usize>());
        // A spec larger than the whole budget is not kept.
        c.insert("big", spec(2000));
        assert!(c.get("big").is_none() && c.bytes <= 3 * w + w / 2);
        c.remove("s9");
        assert!(c.get("s9").is_none());
        assert_eq!(c.bytes, c.entries.values().map(|(_, w)| w).sum::<usize>());
        // By count.
        let mut c = SpecCache::new(2, usize::MAX);
        for k in 0..5 {
            c.insert(&format!("s{k}"), spec(3));
        }
        assert_eq!(c.entries.len(), 2);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_panicking_job_is_marked_failed_and_the_next_one_runs() {
        let dir = std::env::temp_dir().join(format!("bearing-sweep-sched-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store: Arc<dyn Store> = Arc::new(PanicStore(
            SqliteStore::open(&dir).unwrap(),
            std::sync::atomic::AtomicU32::new(0),
        ));
        let spec = json!({"kind": "synthetic", "base": {"spin": 100.0},
                          "axes": [{"path": "spin", "values": [50.0, 60.0, 70.0]}]});
        for id in ["boom", "fine"] {
            let parsed = parse_sweep_doc(&spec, Default::default()).unwrap();
            let mut new = NewSweep::submitted(id.into(), spec.clone(), &parsed, 3, json!({}));
            new.name = id.into();
            assert_eq!(parsed.count(), 3);
            store.insert_sweep(&new).unwrap();
        }
        let sched = Scheduler::new(store.clone(), 1, Default::default()).unwrap();
        tokio::spawn(sched.clone().run());
        let start = std::time::Instant::now();
        let status = |id: &str| store.sweep(id).unwrap().unwrap();
        while !status("fine").status.is_final() {
            assert!(start.elapsed() < Duration::from_secs(60), "no progress");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        let boom = status("boom");
        assert_eq!(boom.status, SweepStatus::Failed, "{boom:?}");
        let msg = boom.message.unwrap_or_default();
        assert!(
            msg.contains("panic") && msg.contains("injected panic"),
            "{msg}"
        );
        let fine = status("fine");
        assert_eq!((fine.status, fine.done), (SweepStatus::Done, 3), "{fine:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Issue 22 item 5: on a full disk the final status of a sweep could not be written
    /// and the sweep stayed `running` forever; it is now written once the store takes it.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_final_status_the_store_refuses_is_written_when_it_takes_it() {
        let dir =
            std::env::temp_dir().join(format!("bearing-sweep-sched-full-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store: Arc<dyn Store> = Arc::new(PanicStore(
            SqliteStore::open(&dir).unwrap(),
            std::sync::atomic::AtomicU32::new(3),
        ));
        let spec = json!({"kind": "synthetic", "base": {"spin": 100.0},
                          "axes": [{"path": "spin", "values": [50.0, 60.0]}]});
        let parsed = parse_sweep_doc(&spec, Default::default()).unwrap();
        let mut new = NewSweep::submitted("full".into(), spec, &parsed, 2, json!({}));
        new.name = "full".into();
        assert_eq!(parsed.count(), 2);
        store.insert_sweep(&new).unwrap();
        let sched = Scheduler::new(store.clone(), 1, Default::default()).unwrap();
        let events = sched.job("full").events.subscribe();
        tokio::spawn(sched.clone().run());
        let start = std::time::Instant::now();
        loop {
            let row = store.sweep_summary("full").unwrap().unwrap();
            if row.status.is_final() {
                assert_eq!((row.status, row.done), (SweepStatus::Done, 2), "{row:?}");
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "the sweep stayed {:?} (its final status was refused 3 times)",
                row.status
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        // The final event goes out once the status is stored.
        let mut events = events;
        let last = loop {
            match tokio::time::timeout(Duration::from_secs(10), events.recv()).await {
                Ok(Ok(SweepEvent::Variant { .. })) => continue,
                Ok(Ok(SweepEvent::Status(SweepStatus::Running))) => continue,
                other => break other,
            }
        };
        assert!(
            matches!(last, Ok(Ok(SweepEvent::Status(SweepStatus::Done)))),
            "last event {last:?}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
