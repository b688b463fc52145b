//! Progress of a sweep: one set of shared counters ([`ProgressCounters`], the single source
//! of truth that the service's status and events read too) and an optional indicatif bar
//! on standard error that shows the same counts (rate, time left; hidden when standard
//! error is not a terminal).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;

/// Least time between bar redraws (indicatif's refresh rate, Hz).
const REDRAW_HZ: u8 = 10;

/// Counters of one run, shared between the runner, a bar and any reader (the service).
#[derive(Debug, Default)]
pub struct ProgressCounters {
    /// Variants in this run (this shard), resumed ones included.
    total: AtomicU64,
    /// Finished variants (resumed ones included).
    done: AtomicU64,
    /// Finished variants whose status is not `ok` (resumed ones included).
    failed: AtomicU64,
    /// Variants found finished at the start (resume).
    resumed: AtomicU64,
    /// When the variants of this run started (rate and ETA count from here).
    started: Mutex<Option<Instant>>,
}

/// A consistent-enough reading of [`ProgressCounters`] for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, utoipa::ToSchema)]
pub struct ProgressSnapshot {
    /// Finished variants (resumed ones included).
    pub done: u64,
    /// Finished variants whose status is not `ok`.
    pub failed: u64,
    /// Variants in the run.
    pub total: u64,
    /// Variants finished per second of this run (resumed ones excluded), 1/s.
    pub variants_per_s: f64,
    /// Estimated time left at that rate, s (`null` before the first variant finished).
    pub eta_s: Option<f64>,
}

impl ProgressCounters {
    /// Fresh counters behind an `Arc` (to share with readers).
    pub fn shared() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// The run starts: `total` variants, of which `resumed` (`resumed_failed` not ok) are
    /// already finished.
    pub fn begin(&self, total: u64, resumed: u64, resumed_failed: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(resumed, Ordering::Relaxed);
        self.failed.store(resumed_failed, Ordering::Relaxed);
        self.resumed.store(resumed, Ordering::Relaxed);
        if let Ok(mut s) = self.started.lock() {
            *s = Some(Instant::now());
        }
    }

    /// One more variant finished (`ok`: its status is `ok`).
    pub fn record(&self, ok: bool) {
        self.done.fetch_add(1, Ordering::Relaxed);
        if !ok {
            self.failed.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Current counts, rate and time left.
    pub fn snapshot(&self) -> ProgressSnapshot {
        let done = self.done.load(Ordering::Relaxed);
        let total = self.total.load(Ordering::Relaxed);
        let ran = done.saturating_sub(self.resumed.load(Ordering::Relaxed));
        let elapsed = self
            .started
            .lock()
            .ok()
            .and_then(|s| s.map(|t| t.elapsed().as_secs_f64()))
            .unwrap_or(0.0);
        let rate = if elapsed > 0.0 {
            ran as f64 / elapsed
        } else {
            0.0
        };
        ProgressSnapshot {
            done,
            failed: self.failed.load(Ordering::Relaxed),
            total,
            variants_per_s: rate,
            eta_s: (rate > 0.0).then(|| total.saturating_sub(done) as f64 / rate),
        }
    }
}

/// The runner's progress reporter: shared counters plus, on a terminal, a bar.
pub struct Progress {
    counters: Arc<ProgressCounters>,
    bar: Option<ProgressBar>,
}

impl Progress {
    /// Counters only (no bar): for services and tests.
    pub fn silent(counters: Arc<ProgressCounters>) -> Self {
        Progress {
            counters,
            bar: None,
        }
    }

    /// Counters and, when `want` and standard error is a terminal, an indicatif bar.
    pub fn new(want: bool, counters: Arc<ProgressCounters>) -> Self {
        let bar = (want && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::with_draw_target(
                Some(0),
                ProgressDrawTarget::stderr_with_hz(REDRAW_HZ),
            );
            bar.set_style(
                ProgressStyle::with_template(
                    "[{bar:30}] {pos}/{len} variants  {per_sec}  {eta} left",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("#>-"),
            );
            bar
        });
        Progress { counters, bar }
    }

    /// The shared counters.
    pub fn counters(&self) -> &Arc<ProgressCounters> {
        &self.counters
    }

    /// The run starts (see [`ProgressCounters::begin`]).
    pub fn begin(&self, total: u64, resumed: u64, resumed_failed: u64) {
        self.counters.begin(total, resumed, resumed_failed);
        if let Some(bar) = &self.bar {
            bar.set_length(total);
            bar.set_position(resumed);
            // Rate and ETA from this run's variants, not the resumed ones.
            bar.reset_eta();
            bar.enable_steady_tick(Duration::from_millis(1000 / REDRAW_HZ as u64));
        }
    }

    /// One more variant finished.
    pub fn record(&self, ok: bool) {
        self.counters.record(ok);
        if let Some(bar) = &self.bar {
            bar.set_position(self.counters.snapshot().done);
        }
    }

    /// Final redraw (the bar stays on screen).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_count_resumed_and_failed_variants() {
        let c = ProgressCounters::shared();
        c.begin(10, 3, 1);
        c.record(true);
        c.record(false);
        let s = c.snapshot();
        assert_eq!((s.done, s.failed, s.total), (5, 2, 10), "{s:?}");
        assert!(
            s.variants_per_s >= 0.0 && s.variants_per_s.is_finite(),
            "{s:?}"
        );
        // Two variants ran: the ETA, when known, is for the 5 left at that rate.
        if let Some(eta) = s.eta_s {
            let want = 5.0 / s.variants_per_s;
            assert!((eta - want).abs() <= 1e-9 * want, "eta {eta} vs {want}");
        }
    }
}
