//! `bearing-sweep eval`: film loads of a list of bearing states, streamed: the `states`
//! array is parsed element by element, evaluated in chunks of [`EVAL_CHUNK`] states and
//! each chunk's loads written as they are done, so memory is bounded by the chunk, not
//! by the input (issue 13 item 9). The output bytes are those of the whole document
//! pretty-printed at once.

use std::fmt;
use std::io::Write;

use serde::de::{DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::{json, Map, Value};

use super::AppError;
use crate::backend::{
    auto_cpu_below, choose_backend_for_film, BackendKind, LoadEvaluator, LoadRequest, LoadResult,
};
use crate::bearing::{Accuracy, BearingParams, BearingState};
use crate::json::{deserialize_at, join_path, StrictSeed};

/// States per evaluator call while streaming: large enough that the backend's per-call
/// cost vanishes (a GPU round trip is ~0.1 ms, the CPU backend ~1-3 µs per state), small
/// enough that a chunk's states, results and output text stay a few tens of MB.
pub const EVAL_CHUNK: usize = 1 << 16;

/// Options of `eval` beyond the input document.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalOptions {
    /// Backend to run on.
    pub backend: BackendKind,
    /// Requested relative accuracy of the load vector.
    pub accuracy: f64,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            backend: BackendKind::Cpu,
            accuracy: Accuracy::default().rtol(),
        }
    }
}

/// Runs `eval` on a whole input document; returns the output document and notices for
/// stderr (the command line streams with [`eval_stream`]).
pub fn eval_json(input: &str, options: EvalOptions) -> Result<(Value, Vec<String>), AppError> {
    eval_json_pooled(input, options, None)
}

/// [`eval_json`] taking its evaluator from `pool` and giving it back (the service's entry
/// point): a GPU backend costs a device and a compiled pipeline, so a long-running process
/// creates one per backend choice and accuracy, not one per request. A reused evaluator
/// answers as a new one would (its warm-start fields are forgotten).
pub fn eval_json_pooled(
    input: &str,
    options: EvalOptions,
    pool: Option<&EvaluatorPool>,
) -> Result<(Value, Vec<String>), AppError> {
    let mut bytes = Vec::new();
    let notices = eval_stream_in(input.as_bytes(), &mut bytes, options, pool)?;
    let out = serde_json::from_slice(&bytes)
        .map_err(|e| AppError::input("$", format!("internal: output not JSON: {e}")))?;
    Ok((out, notices))
}

/// Idle evaluators of a long-running process, by backend request, call size class and
/// accuracy. At most [`EvaluatorPool::PER_KEY`] are kept per key.
#[derive(Default)]
pub struct EvaluatorPool {
    idle: std::sync::Mutex<std::collections::HashMap<PoolKey, Vec<LoadEvaluator>>>,
    created: std::sync::atomic::AtomicU64,
}

/// (requested backend, below the CPU/GPU crossover, accuracy bits): what decides the
/// backend [`choose_backend`] creates.
type PoolKey = (BackendKind, bool, u64);

impl EvaluatorPool {
    /// Idle evaluators kept per key: as many as concurrent evaluation rounds are usual.
    pub const PER_KEY: usize = 4;

    /// Evaluators created so far (each a backend: a GPU device and pipeline on a GPU).
    pub fn created(&self) -> u64 {
        self.created.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn take(&self, key: &PoolKey) -> Option<LoadEvaluator> {
        self.idle.lock().ok()?.get_mut(key)?.pop()
    }

    fn put(&self, key: PoolKey, mut ev: LoadEvaluator) {
        // An evaluator that fell back (a failed device) is not kept: the next request
        // gets a new backend.
        if !ev.take_notices().is_empty() {
            return;
        }
        ev.forget_fields();
        if let Ok(mut idle) = self.idle.lock() {
            let list = idle.entry(key).or_default();
            if list.len() < Self::PER_KEY {
                list.push(ev);
            }
        }
    }
}

/// Streams `eval`: reads the input document from `input`, writes the output document
/// (pretty JSON and a newline) to `out` chunk by chunk; returns notices for stderr. On an
/// input error after the first chunk the output stops short (the error is returned).
pub fn eval_stream<R: std::io::Read, W: Write>(
    input: R,
    out: &mut W,
    options: EvalOptions,
) -> Result<Vec<String>, AppError> {
    eval_stream_in(input, out, options, None)
}

fn eval_stream_in<R: std::io::Read, W: Write>(
    input: R,
    out: &mut W,
    options: EvalOptions,
    pool: Option<&EvaluatorPool>,
) -> Result<Vec<String>, AppError> {
    let accuracy = Accuracy::new(options.accuracy).ok_or_else(|| {
        AppError::input(
            "--accuracy",
            crate::sweep::options::refusal(crate::json::num(options.accuracy)),
        )
    })?;
    let mut run = Run {
        out,
        backend: options.backend,
        evaluator: None,
        pool,
        pool_key: None,
        accuracy,
        bearing: None,
        pending: Vec::new(),
        results: Vec::new(),
        written: 0,
        tail: None,
        error: None,
        notices: Vec::new(),
    };
    let reader = std::io::BufReader::with_capacity(1 << 16, input);
    let mut de = serde_json::Deserializer::from_reader(reader);
    let parsed = Document(&mut run)
        .deserialize(&mut de)
        .and_then(|()| de.end());
    if let Some(e) = run.error.take() {
        return Err(e);
    }
    parsed.map_err(|e| {
        let e = crate::json::split_error(e);
        AppError::input(e.path, e.reason)
    })?;
    if run.bearing.is_none() {
        return Err(AppError::input("bearing", "missing"));
    }
    run.finish()?;
    let mut notices = std::mem::take(&mut run.notices);
    if let (Some(pool), Some(key), Some(ev)) = (pool, run.pool_key, run.evaluator.take()) {
        // Its notices (fallbacks) stay with it: `put` drops an evaluator that has any.
        pool.put(key, ev);
    } else if let Some(e) = run.evaluator.as_mut() {
        notices.extend(e.take_notices());
    }
    Ok(notices)
}

/// Streams `eval` of the file at `path` (`-`: standard input) to `out`.
pub fn eval_file<W: Write>(
    path: &str,
    out: &mut W,
    options: EvalOptions,
) -> Result<Vec<String>, AppError> {
    let io = |source| AppError::Io {
        path: path.to_string(),
        source,
    };
    if path == "-" {
        eval_stream(std::io::stdin().lock(), out, options)
    } else {
        eval_stream(std::fs::File::open(path).map_err(io)?, out, options)
    }
}

/// State of one streamed evaluation.
struct Run<'w, W: Write> {
    out: &'w mut W,
    /// The requested backend kind (`auto` resolves at the first chunk, knowing its size).
    backend: BackendKind,
    /// Created with the header, once the first chunk's size is known.
    evaluator: Option<LoadEvaluator>,
    /// Where the evaluator comes from and goes back to, if anywhere.
    pool: Option<&'w EvaluatorPool>,
    /// The pool key of the evaluator in use.
    pool_key: Option<PoolKey>,
    accuracy: Accuracy,
    bearing: Option<BearingParams>,
    /// States parsed and not yet evaluated (at most a chunk once the bearing is known).
    pending: Vec<LoadRequest>,
    results: Vec<LoadResult>,
    /// Loads written so far (the next state's index).
    written: usize,
    /// The output document after the loads, once the header is written.
    tail: Option<String>,
    /// An error raised inside the parser's callbacks (I/O, bearing), reported as is.
    error: Option<AppError>,
    notices: Vec<String>,
}

/// Placeholder for the loads in the pretty-printed header.
const LOADS_MARK: &str = "\"loads\": []";

impl<W: Write> Run<'_, W> {
    fn write(&mut self, text: &str) -> Result<(), AppError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(AppError::Stdout)
    }

    /// Writes the header (everything before the first load) once the bearing is known.
    fn header(&mut self) -> Result<(), AppError> {
        if self.tail.is_some() {
            return Ok(());
        }
        let Some(bearing) = self.bearing else {
            return Ok(());
        };
        // The first chunk is the whole input when it is under a chunk: `auto` picks the CPU
        // for calls below the GPU crossover (the finite film's is higher: its GPU call has
        // a floor of one state's chain of kernel steps).
        let finite = bearing.model != crate::bearing::FilmModel::Short;
        let key = (
            self.backend,
            self.pending.len() < auto_cpu_below(finite),
            self.accuracy.rtol().to_bits(),
        );
        let evaluator = match self.pool.and_then(|p| p.take(&key)) {
            Some(ev) => ev,
            None => {
                let (backend, notices) = choose_backend_for_film(
                    self.backend,
                    self.accuracy,
                    Some(self.pending.len()),
                    finite,
                )?;
                self.notices.extend(notices);
                if let Some(p) = self.pool {
                    p.created.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
                LoadEvaluator::new(backend)
            }
        };
        self.pool_key = Some(key);
        let evaluator = self.evaluator.insert(evaluator);
        let doc = json!({
            "loads": [],
            "rule": "closed-form loaded arcs, graded Gauss-Legendre panels in z",
            "accuracy": self.accuracy.rtol(),
            "nodes_per_panel": self.accuracy.settings().nodes,
            "backend": evaluator.info(),
            "backend_choice": evaluator.choice(),
            "clearance_convention": bearing.clearance_convention.name(),
            "film_model": bearing.model.name(),
            "friction_model": "paper (mz, friction_coefficient, power_loss: eqs. 10-11); film: \
                               shear stress over the film (full-film Couette shear over 360° \
                               plus the pressure-gradient term), side and inlet flows",
            "units": "SI (N, N·m, m, W)",
        });
        let text = serde_json::to_string_pretty(&doc).unwrap_or_default();
        let at = text.find(LOADS_MARK).unwrap_or(text.len());
        let head = format!("{}\"loads\": [", &text[..at]);
        self.tail = Some(text[(at + LOADS_MARK.len()).min(text.len())..].to_string());
        self.write(&head)
    }

    /// Evaluates and writes the pending states.
    fn flush(&mut self) -> Result<(), AppError> {
        let Some(bearing) = self.bearing else {
            return Ok(());
        };
        self.header()?;
        if self.pending.is_empty() {
            return Ok(());
        }
        let mut results = std::mem::take(&mut self.results);
        if let Some(e) = self.evaluator.as_mut() {
            e.evaluate(&[bearing], &self.pending, &mut results);
        }
        let mut text = String::with_capacity(results.len() * 400);
        for (r, req) in results.iter().zip(&self.pending) {
            let load = load_json(self.written, r, &bearing, &req.state);
            text.push_str(if self.written == 0 {
                "\n    "
            } else {
                ",\n    "
            });
            // Pretty-printed at depth 2 of the document: every inner line 4 spaces deeper
            // (JSON strings hold no raw newline, so this touches structure only).
            let pretty = serde_json::to_string_pretty(&load).unwrap_or_default();
            text.push_str(&pretty.replace('\n', "\n    "));
            self.written += 1;
        }
        self.results = results;
        self.pending.clear();
        self.write(&text)
    }

    /// Closes the loads array and writes the rest of the document.
    fn finish(&mut self) -> Result<(), AppError> {
        self.flush()?;
        self.header()?;
        let close = if self.written == 0 { "]" } else { "\n  ]" };
        let tail = self.tail.take().unwrap_or_default();
        self.write(&format!("{close}{tail}\n"))?;
        self.out.flush().map_err(AppError::Stdout)
    }
}

/// One output entry, as the whole-document `eval` always wrote it.
fn load_json(k: usize, r: &LoadResult, bearing: &BearingParams, state: &BearingState) -> Value {
    match r {
        Ok(l0) => {
            // With a lubricant: the effective-temperature balance (docs/thermal.md); the
            // loads are those at μ(T_eff).
            let mut l = *l0;
            let mut thermal = None;
            match crate::bearing::thermal::state_balance(bearing, state, l0) {
                None => {}
                Some(Ok((b, scaled))) => {
                    l = scaled;
                    thermal = Some(b);
                }
                Some(Err(e)) => {
                    return json!({
                        "status": "thermal_error",
                        "error": format!("states[{k}]: thermal balance: {e}"),
                        "wx": null, "wy": null, "mx": null, "my": null, "mz": null,
                        "friction_coefficient": null, "sommerfeld": null, "h_min": null, "power_loss": null,
                    })
                }
            }
            let l = &l;
            let mut m = match serde_json::to_value(l) {
                Ok(Value::Object(m)) => m,
                _ => Map::new(),
            };
            m.insert("status".into(), json!("ok"));
            // Finite-film states: the model used and the Richardson error estimate.
            if bearing.model != crate::bearing::FilmModel::Short {
                let used = crate::backend::effective_model(bearing, state);
                m.insert("film_model".into(), json!(used.name()));
                if used == crate::bearing::FilmModel::Finite {
                    // A relative estimate of the loads `l`, i.e. at μ(T_eff) with a
                    // lubricant: the coarse solve runs at that viscosity too.
                    let at = thermal.map_or(*bearing, |b| BearingParams {
                        viscosity: b.viscosity_pa_s,
                        ..*bearing
                    });
                    let est =
                        crate::bearing::finite::richardson_estimate(&at, state, &bearing.finite, l);
                    m.insert("finite_error_estimate".into(), json!(est));
                }
            }
            if let Some(b) = thermal {
                m.insert(
                    "thermal".into(),
                    crate::bearing::thermal::balance_json(&b, bearing),
                );
            }
            Value::Object(m)
        }
        Err(fault) => json!({
            "status": fault.code(),
            "error": format!("states[{k}]: {fault}"),
            "wx": null, "wy": null, "mx": null, "my": null, "mz": null,
            "friction_coefficient": null, "sommerfeld": null, "h_min": null, "power_loss": null,
            "friction_model": null, "film": null,
        }),
    }
}

/// An error at `path` from inside the parser (keeps the path through serde_json).
fn located<E: serde::de::Error>(path: &str, reason: &str) -> E {
    E::custom(format!(
        "{m}{path}{m}{reason}",
        m = crate::json::LOCATED_MARK
    ))
}

/// The top-level document: `{"bearing": {...}, "states": [...]}`, in either order.
struct Document<'r, 'w, W: Write>(&'r mut Run<'w, W>);

impl<'de, W: Write> DeserializeSeed<'de> for Document<'_, '_, W> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, W: Write> Visitor<'de> for Document<'_, '_, W> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an object {\"bearing\": {...}, \"states\": [...]}")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let run = self.0;
        let mut seen_states = false;
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "bearing" if run.bearing.is_some() => {
                    return Err(located(
                        "bearing",
                        "duplicate key (JSON objects must not repeat a key; which one was meant?)",
                    ))
                }
                "states" if seen_states => {
                    return Err(located(
                        "states",
                        "duplicate key (JSON objects must not repeat a key; which one was meant?)",
                    ))
                }
                "bearing" => {
                    let v = map.next_value_seed(StrictSeed {
                        key: "bearing",
                        index: None,
                    })?;
                    let b: BearingParams = deserialize_at(&v)
                        .map_err(|(at, r)| located(&join_path("bearing", &at), &r))?;
                    b.validate().map_err(|e| {
                        located(
                            &format!("bearing.{}", e.field),
                            &format!("{} (got {})", e.reason, crate::json::num(e.value)),
                        )
                    })?;
                    run.notices
                        .extend(super::warnings::bearing_warnings("bearing", &v));
                    run.bearing = Some(b);
                    if run.pending.len() >= EVAL_CHUNK || seen_states {
                        run.flush().map_err(|e| stop(run, e))?;
                    }
                }
                "states" => {
                    seen_states = true;
                    map.next_value_seed(States(run))?;
                }
                other => {
                    let hint = crate::json::did_you_mean(other, &["bearing", "states"])
                        .map_or(String::new(), |n| format!("; did you mean `{n}`?"));
                    return Err(located(
                        &crate::json::quote(other),
                        &format!("unknown field (expected `bearing` and `states`){hint}"),
                    ));
                }
            }
        }
        if !seen_states {
            return Err(located("states", "missing"));
        }
        Ok(())
    }
}

/// Keeps a callback error (I/O) to report as is; the parser only needs to stop.
fn stop<E: serde::de::Error, W: Write>(run: &mut Run<'_, W>, e: AppError) -> E {
    run.error = Some(e);
    E::custom("stopped")
}

/// The `states` array, element by element.
struct States<'r, 'w, W: Write>(&'r mut Run<'w, W>);

impl<'de, W: Write> DeserializeSeed<'de> for States<'_, '_, W> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, W: Write> Visitor<'de> for States<'_, '_, W> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of states")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let run = self.0;
        let mut k = run.written + run.pending.len();
        while let Some(v) = seq.next_element_seed(StrictSeed {
            key: "states",
            index: Some(k),
        })? {
            let state: BearingState = deserialize_at(&v)
                .map_err(|(at, r)| located(&join_path(&format!("states[{k}]"), &at), &r))?;
            run.pending.push(LoadRequest { bearing: 0, state });
            k += 1;
            if run.bearing.is_some() && run.pending.len() >= EVAL_CHUNK {
                run.flush().map_err(|e| stop(run, e))?;
            }
        }
        Ok(())
    }

    fn visit_map<A: MapAccess<'de>>(self, _map: A) -> Result<(), A::Error> {
        Err(located("states", "expected an array, got an object"))
    }
    fn visit_str<E: serde::de::Error>(self, _: &str) -> Result<(), E> {
        Err(located("states", "expected an array, got a string"))
    }
    fn visit_f64<E: serde::de::Error>(self, _: f64) -> Result<(), E> {
        Err(located("states", "expected an array, got a number"))
    }
    fn visit_u64<E: serde::de::Error>(self, _: u64) -> Result<(), E> {
        Err(located("states", "expected an array, got a number"))
    }
    fn visit_i64<E: serde::de::Error>(self, _: i64) -> Result<(), E> {
        Err(located("states", "expected an array, got a number"))
    }
    fn visit_bool<E: serde::de::Error>(self, _: bool) -> Result<(), E> {
        Err(located("states", "expected an array, got a boolean"))
    }
    fn visit_unit<E: serde::de::Error>(self) -> Result<(), E> {
        Err(located("states", "expected an array, got null"))
    }
}
