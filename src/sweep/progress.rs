//! A one-line progress bar on standard error: variants done, rate, time left. Drawn only
//! when enabled and standard error is a terminal; silent otherwise (logs, CI, pipes).

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// Least time between redraws.
const REDRAW: Duration = Duration::from_millis(100);
/// Bar width in characters.
const WIDTH: usize = 30;

/// Progress of a run.
pub struct Progress {
    enabled: bool,
    total: u64,
    done: u64,
    skipped: u64,
    start: Instant,
    last: Option<Instant>,
}

impl Progress {
    /// A bar over `total` variants of which `skipped` were already done (resume).
    pub fn new(want: bool, total: u64, skipped: u64) -> Self {
        Progress {
            enabled: want && std::io::stderr().is_terminal(),
            total,
            done: skipped,
            skipped,
            start: Instant::now(),
            last: None,
        }
    }

    /// One more variant finished.
    pub fn inc(&mut self) {
        self.done += 1;
        if self.enabled && self.last.is_none_or(|l| l.elapsed() >= REDRAW) {
            self.draw();
        }
    }

    fn draw(&mut self) {
        self.last = Some(Instant::now());
        let elapsed = self.start.elapsed().as_secs_f64();
        let ran = self.done - self.skipped;
        let rate = if elapsed > 0.0 {
            ran as f64 / elapsed
        } else {
            0.0
        };
        let left = self.total.saturating_sub(self.done);
        let eta = if rate > 0.0 {
            format_secs(left as f64 / rate)
        } else {
            "--:--".into()
        };
        let filled = (WIDTH as u64 * self.done)
            .checked_div(self.total)
            .map_or(WIDTH, |f| f as usize);
        let bar: String = "#".repeat(filled) + &"-".repeat(WIDTH - filled.min(WIDTH));
        let mut err = std::io::stderr().lock();
        let _ = write!(
            err,
            "\r[{bar}] {}/{} variants  {rate:.1}/s  {eta} left ",
            self.done, self.total
        );
        let _ = err.flush();
    }

    /// Final redraw and newline.
    pub fn finish(&mut self) {
        if self.enabled {
            self.draw();
            let _ = writeln!(std::io::stderr());
        }
    }
}

fn format_secs(s: f64) -> String {
    let s = s.round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{:02}:{:02}", s / 60, s % 60)
    }
}
