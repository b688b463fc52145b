//! `POST /api/eval` with coalescing: requests that arrive within a short window are
//! grouped by bearing and accuracy, their states concatenated into one `eval` input, run
//! as one backend call ([`crate::app::eval_json`], the library function behind `eval`),
//! and the loads split back so each caller gets exactly its own. A merged call that
//! fails (one caller's bad state) is retried per request, so every error names the
//! caller's own JSON path.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{Map, Value};
use tokio::sync::{mpsc, oneshot};

use super::error::ApiError;
use crate::app::{eval_json_pooled, EvalOptions, EvaluatorPool};
use crate::backend::BackendKind;

/// Queued requests before new ones wait (back-pressure on the HTTP handlers).
const QUEUE: usize = 4096;
/// Window over which `/metrics` reports eval states per second, s.
const RATE_WINDOW_S: f64 = 10.0;

/// One caller's request.
struct Pending {
    /// The body, parsed.
    doc: Value,
    /// The body as sent (for a lone call, so errors match `eval`'s exactly).
    text: String,
    accuracy: f64,
    reply: oneshot::Sender<Result<Value, ApiError>>,
}

/// Counters of the coalescer.
#[derive(Debug, Default)]
pub struct EvalCounters {
    /// `eval_json` calls made (one backend call each).
    pub backend_calls: AtomicU64,
    /// HTTP eval requests answered.
    pub requests: AtomicU64,
    /// States evaluated.
    pub states: AtomicU64,
    rate: Mutex<RateWindow>,
}

#[derive(Debug)]
struct RateWindow {
    start: Instant,
    states: u64,
    last_rate: f64,
}

impl Default for RateWindow {
    fn default() -> Self {
        RateWindow {
            start: Instant::now(),
            states: 0,
            last_rate: 0.0,
        }
    }
}

impl EvalCounters {
    fn add_states(&self, n: u64) {
        self.states.fetch_add(n, Ordering::Relaxed);
        if let Ok(mut w) = self.rate.lock() {
            w.states += n;
        }
    }

    /// States per second over the last full window (about 10 s).
    pub fn states_per_s(&self) -> f64 {
        let Ok(mut w) = self.rate.lock() else {
            return 0.0;
        };
        let el = w.start.elapsed().as_secs_f64();
        if el >= RATE_WINDOW_S {
            w.last_rate = w.states as f64 / el;
            w.states = 0;
            w.start = Instant::now();
        }
        w.last_rate
    }
}

/// The coalescer: a queue and a task that drains it in windows.
#[derive(Clone)]
pub struct Coalescer {
    tx: mpsc::Sender<Pending>,
    /// Counters (backend calls, requests, states).
    pub counters: Arc<EvalCounters>,
    /// The evaluators (backends) reused across calls.
    pub pool: Arc<EvaluatorPool>,
}

impl Coalescer {
    /// Starts the coalescing task: requests arriving within `window` of the first one of a
    /// round go into the same backend call(s) on `backend`.
    pub fn start(window: Duration, backend: BackendKind) -> Self {
        let (tx, rx) = mpsc::channel(QUEUE);
        let counters = Arc::new(EvalCounters::default());
        let pool = Arc::new(EvaluatorPool::default());
        tokio::spawn(run(rx, window, backend, counters.clone(), pool.clone()));
        Coalescer { tx, counters, pool }
    }

    /// Evaluates one request body (the `eval` input: its text and `doc`, the text
    /// parsed) with `accuracy`; the answer is `eval`'s output for these states.
    pub async fn eval(&self, text: String, doc: Value, accuracy: f64) -> Result<Value, ApiError> {
        let (reply, rx) = oneshot::channel();
        self.tx
            .send(Pending {
                doc,
                text,
                accuracy,
                reply,
            })
            .await
            .map_err(|_| ApiError::internal("the eval queue is closed (shutting down)"))?;
        let out = rx
            .await
            .map_err(|_| ApiError::internal("the eval worker stopped"))?;
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        out
    }
}

async fn run(
    mut rx: mpsc::Receiver<Pending>,
    window: Duration,
    backend: BackendKind,
    counters: Arc<EvalCounters>,
    pool: Arc<EvaluatorPool>,
) {
    while let Some(first) = rx.recv().await {
        let mut round = vec![first];
        let deadline = tokio::time::Instant::now() + window;
        while let Ok(Some(p)) = tokio::time::timeout_at(deadline, rx.recv()).await {
            round.push(p);
        }
        let ctx = Ctx {
            backend,
            counters: counters.clone(),
            pool: pool.clone(),
        };
        // The backend call is blocking; the next round gathers meanwhile.
        tokio::task::spawn_blocking(move || answer_round(round, &ctx));
    }
}

/// The grouping key of a request: its bearing (canonical JSON) and accuracy, or `None`
/// when it is not of the shape `{"bearing": {...}, "states": [...]}` (answered alone).
fn group_key(p: &Pending) -> Option<String> {
    let o = p.doc.as_object()?;
    if o.len() != 2 || !o.get("states")?.is_array() {
        return None;
    }
    Some(format!("{}|{:e}", o.get("bearing")?, p.accuracy))
}

/// What a round's blocking task needs.
struct Ctx {
    backend: BackendKind,
    counters: Arc<EvalCounters>,
    pool: Arc<EvaluatorPool>,
}

fn answer_round(round: Vec<Pending>, ctx: &Ctx) {
    let mut groups: BTreeMap<String, Vec<Pending>> = BTreeMap::new();
    let mut alone = Vec::new();
    for p in round {
        match group_key(&p) {
            Some(k) => groups.entry(k).or_default().push(p),
            None => alone.push(p),
        }
    }
    for p in alone {
        answer_alone(p, ctx);
    }
    for (_, group) in groups {
        if group.len() == 1 {
            group.into_iter().for_each(|p| answer_alone(p, ctx));
            continue;
        }
        answer_group(group, ctx);
    }
}

fn call(text: &str, accuracy: f64, ctx: &Ctx) -> Result<Value, ApiError> {
    ctx.counters.backend_calls.fetch_add(1, Ordering::Relaxed);
    let options = EvalOptions {
        backend: ctx.backend,
        accuracy,
    };
    eval_json_pooled(text, options, Some(&ctx.pool))
        .map(|(v, _notices)| v)
        .map_err(ApiError::from)
}

fn answer_alone(p: Pending, ctx: &Ctx) {
    let out = call(&p.text, p.accuracy, ctx);
    if let Ok(v) = &out {
        ctx.counters
            .add_states(v["loads"].as_array().map_or(0, Vec::len) as u64);
    }
    let _ = p.reply.send(out);
}

/// One call for a group with one bearing: states concatenated, loads split back.
fn answer_group(group: Vec<Pending>, ctx: &Ctx) {
    let counts: Vec<usize> = group
        .iter()
        .map(|p| p.doc["states"].as_array().map_or(0, Vec::len))
        .collect();
    let mut states = Vec::with_capacity(counts.iter().sum());
    for p in &group {
        states.extend(p.doc["states"].as_array().into_iter().flatten().cloned());
    }
    let mut merged = Map::new();
    merged.insert("bearing".into(), group[0].doc["bearing"].clone());
    merged.insert("states".into(), Value::Array(states));
    let text = Value::Object(merged).to_string();
    let out = match call(&text, group[0].accuracy, ctx) {
        Ok(v) => v,
        Err(_) => {
            // Someone's input is bad: answer each alone so errors name their own paths.
            group.into_iter().for_each(|p| answer_alone(p, ctx));
            return;
        }
    };
    let loads = out["loads"].as_array().cloned().unwrap_or_default();
    if loads.len() != counts.iter().sum::<usize>() {
        for p in group {
            let _ = p.reply.send(Err(ApiError::internal(
                "internal: the backend answered a different number of states",
            )));
        }
        return;
    }
    ctx.counters.add_states(loads.len() as u64);
    let mut start = 0;
    for (p, n) in group.into_iter().zip(counts) {
        let mine: Vec<Value> = loads[start..start + n]
            .iter()
            .map(|l| reindex(l.clone(), start))
            .collect();
        let mut doc = out.clone();
        doc["loads"] = Value::Array(mine);
        start += n;
        let _ = p.reply.send(Ok(doc));
    }
}

/// A failed state's message names `states[k]` of the merged call: shift it back to the
/// caller's own index.
fn reindex(mut load: Value, offset: usize) -> Value {
    let Some(msg) = load.get("error").and_then(Value::as_str) else {
        return load;
    };
    let fixed = msg
        .strip_prefix("states[")
        .and_then(|rest| rest.split_once(']'))
        .and_then(|(k, tail)| {
            k.parse::<usize>()
                .ok()
                .map(|k| format!("states[{}]{tail}", k.saturating_sub(offset)))
        });
    if let Some(f) = fixed {
        load["error"] = Value::String(f);
    }
    load
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn reindex_shifts_the_state_index_of_an_error() {
        let l = json!({"status": "through_wall", "error": "states[17]: journal outside the bore"});
        assert_eq!(
            reindex(l, 15)["error"],
            json!("states[2]: journal outside the bore")
        );
        let ok = json!({"status": "ok", "wx": 1.0});
        assert_eq!(reindex(ok.clone(), 3), ok);
    }
}
