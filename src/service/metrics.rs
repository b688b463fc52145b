//! `/metrics`: Prometheus text exposition (written by hand: a handful of gauges,
//! counters and one latency histogram).

use std::fmt::Write;
use std::sync::Mutex;
use std::time::Duration;

/// Upper bounds of the request-latency histogram buckets, s (1 ms to 10 s, roughly
/// ×2.5 apart, as Prometheus client defaults).
const BUCKETS_S: [f64; 11] = [
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 10.0,
];

/// Request latency histogram.
#[derive(Debug, Default)]
pub struct LatencyHistogram {
    inner: Mutex<Hist>,
}

#[derive(Debug, Default)]
struct Hist {
    counts: [u64; BUCKETS_S.len()],
    count: u64,
    sum_s: f64,
}

impl LatencyHistogram {
    /// Records one request's latency.
    pub fn observe(&self, d: Duration) {
        let s = d.as_secs_f64();
        if let Ok(mut h) = self.inner.lock() {
            for (k, b) in BUCKETS_S.iter().enumerate() {
                if s <= *b {
                    h.counts[k] += 1;
                }
            }
            h.count += 1;
            h.sum_s += s;
        }
    }

    fn render(&self, out: &mut String, name: &str, help: &str) {
        let Ok(h) = self.inner.lock() else { return };
        let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} histogram");
        for (k, b) in BUCKETS_S.iter().enumerate() {
            let _ = writeln!(out, "{name}_bucket{{le=\"{b}\"}} {}", h.counts[k]);
        }
        let _ = writeln!(out, "{name}_bucket{{le=\"+Inf\"}} {}", h.count);
        let _ = writeln!(out, "{name}_sum {}", h.sum_s);
        let _ = writeln!(out, "{name}_count {}", h.count);
    }
}

/// The values of one scrape.
pub struct Scrape {
    /// Sweeps queued.
    pub queued: u64,
    /// Sweeps running.
    pub running: u64,
    /// Variants committed since start.
    pub variants_done: u64,
    /// ... whose status is not ok.
    pub variants_failed: u64,
    /// Eval states per second (last ~10 s).
    pub eval_states_per_s: f64,
    /// Eval states since start.
    pub eval_states: u64,
    /// Eval backend calls since start (coalesced).
    pub eval_backend_calls: u64,
    /// Eval HTTP requests answered since start.
    pub eval_requests: u64,
}

fn metric(out: &mut String, name: &str, kind: &str, help: &str, value: impl std::fmt::Display) {
    let _ = writeln!(
        out,
        "# HELP {name} {help}\n# TYPE {name} {kind}\n{name} {value}"
    );
}

/// The exposition text.
pub fn render(s: &Scrape, latency: &LatencyHistogram) -> String {
    let mut out = String::new();
    metric(
        &mut out,
        "bearing_sweep_queue_length",
        "gauge",
        "Sweeps waiting to run.",
        s.queued,
    );
    metric(
        &mut out,
        "bearing_sweep_running",
        "gauge",
        "Sweeps running.",
        s.running,
    );
    metric(
        &mut out,
        "bearing_sweep_variants_done_total",
        "counter",
        "Variants committed since the server started.",
        s.variants_done,
    );
    metric(
        &mut out,
        "bearing_sweep_variants_failed_total",
        "counter",
        "Committed variants whose status is not ok, since start.",
        s.variants_failed,
    );
    metric(
        &mut out,
        "bearing_sweep_eval_states_per_second",
        "gauge",
        "Bearing states evaluated per second by /api/eval over the last ~10 s.",
        s.eval_states_per_s,
    );
    metric(
        &mut out,
        "bearing_sweep_eval_states_total",
        "counter",
        "Bearing states evaluated by /api/eval since start.",
        s.eval_states,
    );
    metric(
        &mut out,
        "bearing_sweep_eval_backend_calls_total",
        "counter",
        "Backend calls made for /api/eval (coalesced requests share one).",
        s.eval_backend_calls,
    );
    metric(
        &mut out,
        "bearing_sweep_eval_requests_total",
        "counter",
        "/api/eval requests answered since start.",
        s.eval_requests,
    );
    latency.render(
        &mut out,
        "bearing_sweep_http_request_duration_seconds",
        "HTTP request latency (to the response head).",
    );
    out
}
