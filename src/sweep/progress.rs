//! Progress of a sweep: one set of shared counters ([`ProgressCounters`], the single source
//! of truth that the service's status and events read too) and an optional indicatif bar
//! on standard error that shows the same counts (rate, time left; hidden when standard
//! error is not a terminal).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
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

    /// Seconds since this run's variants started, variants this run finished (resumed
    /// ones excluded) and variants left.
    pub fn run_so_far(&self) -> (f64, u64, u64) {
        let done = self.done.load(Ordering::Relaxed);
        let total = self.total.load(Ordering::Relaxed);
        let ran = done.saturating_sub(self.resumed.load(Ordering::Relaxed));
        let elapsed = self
            .started
            .lock()
            .ok()
            .and_then(|s| s.map(|t| t.elapsed().as_secs_f64()))
            .unwrap_or(0.0);
        (elapsed, ran, total.saturating_sub(done))
    }

    /// Current counts, rate and time left.
    pub fn snapshot(&self) -> ProgressSnapshot {
        self.snapshot_plus(0, 0)
    }

    /// The snapshot as it will read once one more variant (`ok` or not) is recorded: for a
    /// report made between a variant's commit and its [`ProgressCounters::record`].
    pub fn snapshot_after(&self, ok: bool) -> ProgressSnapshot {
        self.snapshot_plus(1, u64::from(!ok))
    }

    fn snapshot_plus(&self, more_done: u64, more_failed: u64) -> ProgressSnapshot {
        let done = self.done.load(Ordering::Relaxed) + more_done;
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
            failed: self.failed.load(Ordering::Relaxed) + more_failed,
            total,
            variants_per_s: rate,
            eta_s: (rate > 0.0).then(|| total.saturating_sub(done) as f64 / rate),
        }
    }
}

/// Seconds of a run before the bar shows a rate and a time left: earlier, a rate from the
/// first variant or none (`0/s`) says nothing.
pub const RATE_AFTER_S: f64 = 2.0;

/// The bar's rate: blank for the first [`RATE_AFTER_S`] seconds and before any variant of
/// this run finished, then variants per second to 3 significant digits (per minute below
/// 0.1/s).
pub fn rate_text(elapsed_s: f64, ran: u64) -> String {
    // NaN elapsed reads as "too early".
    if elapsed_s.is_nan() || elapsed_s < RATE_AFTER_S || ran == 0 {
        return String::new();
    }
    let per_s = ran as f64 / elapsed_s;
    if per_s < 0.1 {
        format!("{}/min", sig3(per_s * 60.0))
    } else {
        format!("{}/s", sig3(per_s))
    }
}

/// The bar's time left at the run's rate, in whole seconds, minutes or hours (blank while
/// [`rate_text`] is).
pub fn left_text(elapsed_s: f64, ran: u64, left: u64) -> String {
    // NaN elapsed reads as "too early".
    if elapsed_s.is_nan() || elapsed_s < RATE_AFTER_S || ran == 0 {
        return String::new();
    }
    let s = (left as f64 * elapsed_s / ran as f64).round();
    let t = if s < 60.0 {
        format!("{s:.0} s")
    } else if s < 3600.0 {
        format!("{:.0} min {:.0} s", (s / 60.0).floor(), s % 60.0)
    } else {
        format!(
            "{:.0} h {:.0} min",
            (s / 3600.0).floor(),
            ((s % 3600.0) / 60.0).floor()
        )
    };
    format!("{t} left")
}

/// `x > 0` to 3 significant digits, without an exponent in the usual range.
fn sig3(x: f64) -> String {
    if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 10.0 {
        format!("{x:.1}")
    } else if x >= 1.0 {
        format!("{x:.2}")
    } else {
        format!("{x:.3}")
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
            let (c_rate, c_left) = (counters.clone(), counters.clone());
            bar.set_style(
                ProgressStyle::with_template("[{bar:30}] {pos}/{len} variants  {rate}  {left}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .with_key(
                        "rate",
                        move |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                            let (elapsed, ran, _) = c_rate.run_so_far();
                            let _ = w.write_str(&rate_text(elapsed, ran));
                        },
                    )
                    .with_key(
                        "left",
                        move |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                            let (elapsed, ran, left) = c_left.run_so_far();
                            let _ = w.write_str(&left_text(elapsed, ran, left));
                        },
                    )
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
    fn the_bar_shows_no_rate_for_two_seconds_then_three_digits() {
        // Issue 23 item 6: no `0/s` at the start, no 4-decimal rates.
        assert_eq!(rate_text(0.5, 0), "");
        assert_eq!(rate_text(1.9, 7), "", "a rate before 2 s");
        assert_eq!(rate_text(5.0, 0), "", "no variant finished yet");
        assert_eq!(left_text(1.0, 3, 10), "");
        for (elapsed, ran, want) in [
            (2.0, 1, "0.500/s"),
            (3.0, 10, "3.33/s"),
            (2.5, 100, "40.0/s"),
            (4.0, 123_457, "30864/s"),
            (60.0, 3, "3.00/min"),
        ] {
            assert_eq!(rate_text(elapsed, ran), want, "{ran} in {elapsed} s");
        }
        assert_eq!(left_text(10.0, 5, 4), "8 s left");
        assert_eq!(left_text(10.0, 1, 50), "8 min 20 s left");
        assert_eq!(left_text(100.0, 1, 100), "2 h 46 min left");
    }

    #[test]
    fn counters_count_resumed_and_failed_variants() {
        let c = ProgressCounters::shared();
        c.begin(10, 3, 1);
        c.record(true);
        c.record(false);
        let ahead = c.snapshot_after(false);
        assert_eq!((ahead.done, ahead.failed), (6, 3), "{ahead:?}");
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
