//! Rotor sweeps: the rotor integrator ([`crate::rotor::simulate_batch_streaming`], here its cancellable form, lockstep batches
//! whose every stage is one film-load call) behind the runner's [`BatchSimulator`], and
//! the scene validator that checks every variant before anything runs.

use serde_json::{json, Value};

use super::reduce::{BearingSignals, ReductionOptions, Signals};
use super::runner::{BatchSimulator, Outcome, Reduced, VariantJob};
use super::stream::{streams, RunReducer};
use crate::backend::{BackendInfo, CpuBackend, EvalStats, LoadEvaluator};
use crate::bearing::Accuracy;
use crate::budget::MemoryBudget;
use crate::rotor::reductions::{evaluator_report, ReductionSpec};
use std::sync::atomic::AtomicBool;

use crate::rotor::{simulate_batch_observed, simulate_batch_streaming_cancellable};
use crate::rotor::{Scene, SimResult};

/// Variants per batch for `--batch-size auto` on the CPU: enough variants for every
/// thread's lockstep sub-batch, few enough that the running variants' sampled series
/// (at most [`crate::budget::MemoryBudget::sample_cap`] samples each, decimated beyond) leave
/// each a cap of thousands of samples (2^14 under the default 2 GiB budget).
pub const AUTO_BATCH_CPU: usize = 256;
/// ... on a GPU: thousands of states per dispatch amortise its launch cost.
pub const AUTO_BATCH_GPU: usize = 4096;

/// Checks one variant's scene within the default memory budget: `Err((JSON path,
/// reason))`.
pub fn validate_scene(v: &Value) -> Result<(), (String, String)> {
    validate_scene_within(v, MemoryBudget::default())
}

/// [`validate_scene`] within the memory budget `budget`.
pub fn validate_scene_within(v: &Value, budget: MemoryBudget) -> Result<(), (String, String)> {
    let scene: Scene = crate::json::deserialize_at(v)?;
    if scene.compare_ideal {
        return Err((
            "compare_ideal".into(),
            "not used in sweeps (one variant is one simulation): sweep an axis {\"path\": \"model\", \"values\": [\"bearing\", \"ideal\"]} instead".into(),
        ));
    }
    scene
        .validate_within(budget)
        .map_err(|e| (e.path, e.reason))
}

/// The status name of a simulation (`"ok"` when it reached `t_end`).
pub fn status_name(r: &SimResult) -> String {
    if r.status.is_finished() {
        return "ok".into();
    }
    serde_json::to_value(&r.status)
        .ok()
        .and_then(|v| v.get("kind").and_then(Value::as_str).map(str::to_string))
        .unwrap_or_else(|| "failed".into())
}

/// The runner's signals from a simulation's samples.
pub fn signals_of(r: &SimResult, scene: &Scene) -> Signals {
    let s = &r.samples;
    Signals {
        t: s.t.clone(),
        spin: s.spin.clone(),
        x_g: s.x_g.clone(),
        y_g: s.y_g.clone(),
        bearings: s
            .bearings
            .iter()
            .zip(&scene.bearings)
            .map(|(b, spec)| BearingSignals {
                clearance_m: spec.clearance,
                xi: b.xi.clone(),
                yi: b.yi.clone(),
                xj: b.xj.clone(),
                yj: b.yj.clone(),
                h_min: b.h_min.clone(),
                eccentricity_max: b.eccentricity_max.clone(),
                friction_coefficient: b.friction_coefficient.clone(),
                mz: b.mz.clone(),
                wx: b.wx.clone(),
                wy: b.wy.clone(),
            })
            .collect(),
    }
}

/// The outcome of a simulation reduced as it ran.
pub fn outcome_reduced(
    r: &SimResult,
    scene: &Scene,
    reducer: &RunReducer,
    opts: &ReductionOptions,
) -> Outcome {
    let (reductions, series) = reducer.finish(opts);
    Outcome {
        signals: None,
        reduced: Some(Reduced {
            reductions,
            series,
            peak_stored_samples: reducer.peak_stored_samples(),
        }),
        ..outcome_of(r, scene)
    }
}

/// The outcome the runner streams for one simulation.
pub fn outcome_of(r: &SimResult, scene: &Scene) -> Outcome {
    let status = status_name(r);
    let mut extra = json!({
        "method": r.method.name(),
        "model": r.model,
        "steps": r.stats.steps,
        "rejected": r.stats.rejected,
        "rhs_evaluations": r.stats.rhs_evaluations,
        "load_evaluations": r.stats.load_evaluations,
        // Film breakdowns a contact model carried the run through (film.contact).
        "model_reductions": r.model_reductions,
        "film_events": r.film_events.iter().map(|e| json!({"t_s": e.time, "bearing": e.bearing, "h_min_m": e.h_min})).collect::<Vec<_>>(),
    });
    // Bearings with a lumped oil temperature (docs/thermal.md "Rotor scenes"): final and
    // highest temperature; absent otherwise, so records without a lubricant are unchanged.
    if !r.oil_temperature.is_empty() {
        extra["oil_temperature"] = json!(r.oil_temperature);
    }
    // Only when decimated (docs/cli.md "Limits"), so undecimated records are unchanged: the
    // reductions saw every `sample_stride`-th sample.
    if r.samples.sample_stride > 1 {
        extra["sample_stride"] = json!(r.samples.sample_stride);
        extra["kept_sample_interval_s"] =
            json!(r.samples.sample_stride as f64 * scene.integrator.sample_interval);
    }
    Outcome {
        message: (status != "ok").then(|| r.status.to_string()),
        status,
        signals: Some(signals_of(r, scene)),
        // Deterministic counters only (wall times go to the run section, not here).
        extra: Some(extra),
        reduced: None,
    }
}

/// The rotor integrator as a batch simulator.
///
/// On a GPU the whole batch advances in lockstep on one evaluator: every stage is one
/// dispatch carrying all active variants' bearings. On the CPU the batch is split into
/// one sub-batch per thread (dealt round-robin), each advancing in lockstep on its own
/// single-threaded CPU evaluator: a film call carries only a few hundred states, too few
/// to spread over threads, so the parallelism is across variants. Results do not depend
/// on the split (each variant has its own step-size control and every state's loads are
/// computed alone).
pub struct RotorSimulator {
    evaluator: LoadEvaluator,
    info: BackendInfo,
    workers: Vec<LoadEvaluator>,
    full_model: bool,
    /// The spec's reductions: with a window of fixed length each variant is reduced as it
    /// runs and keeps only what they need ([`super::stream`]).
    reductions: Option<ReductionOptions>,
    /// The memory budget the batch's sample caps come from (default 2 GiB).
    max_memory: MemoryBudget,
}

impl RotorSimulator {
    /// Simulates on `evaluator`'s backend; a CPU backend gets one single-threaded CPU
    /// evaluator per thread of rayon's pool (`RAYON_NUM_THREADS`) at `accuracy`.
    pub fn new(evaluator: LoadEvaluator, accuracy: Accuracy) -> Self {
        let info = evaluator.info();
        let workers = if info.name == "cpu" {
            (0..rayon::current_num_threads().max(1))
                .map(|_| {
                    LoadEvaluator::with_options(
                        Box::new(CpuBackend::new(accuracy, Some(1))),
                        evaluator.options(),
                    )
                })
                .collect()
        } else {
            Vec::new()
        };
        RotorSimulator {
            evaluator,
            info,
            workers,
            full_model: false,
            reductions: None,
            max_memory: MemoryBudget::default(),
        }
    }

    /// The memory budget the batch's sample caps come from (`run --max-memory`).
    pub fn set_max_memory(&mut self, budget: MemoryBudget) {
        self.max_memory = budget;
    }

    /// `--full-model`: every variant's scene gets every reduction off.
    pub fn set_full_model(&mut self, full: bool) {
        self.full_model = full;
    }

    /// Reduce each variant with `opts` as it runs where its window has a fixed length
    /// (memory then follows the window, not `t_end`); otherwise the samples are stored
    /// and the runner reduces them.
    pub fn set_reductions(&mut self, opts: &ReductionOptions) {
        self.reductions = streams(opts).then(|| opts.clone());
    }

    /// Evaluator counters summed over the evaluator and the per-thread workers.
    pub fn eval_stats(&self) -> EvalStats {
        let mut t = self.evaluator.stats();
        for w in &self.workers {
            let s = w.stats();
            t.calls += s.calls;
            t.states += s.states;
            t.cpu_recomputed += s.cpu_recomputed;
            t.deduplicated += s.deduplicated;
            t.integrated += s.integrated;
            t.small_batch_cpu_calls += s.small_batch_cpu_calls;
            t.small_batch_cpu_states += s.small_batch_cpu_states;
        }
        t
    }

    /// The settings that change results, recorded in the result and checked on resume
    /// and merge: backend kind and precision, film accuracy.
    pub fn settings(&self, accuracy_rtol: f64) -> Value {
        let mut v = json!({"simulator": "rotor", "backend": self.info.name, "precision": self.info.precision,
               "film_accuracy": accuracy_rtol});
        // Only when set, so results of earlier versions still resume and merge.
        if self.full_model {
            v["full_model"] = json!(true);
        }
        v
    }
}

impl BatchSimulator for RotorSimulator {
    fn auto_batch_size(&self) -> usize {
        if self.info.name == "cpu" {
            AUTO_BATCH_CPU
        } else {
            AUTO_BATCH_GPU
        }
    }

    fn info(&self) -> Value {
        let mut v = serde_json::to_value(&self.info).unwrap_or(Value::Null);
        if !self.workers.is_empty() {
            v["variant_threads"] = json!(self.workers.len());
        }
        v["model_reductions"] = serde_json::to_value(evaluator_report(
            &self.evaluator.options(),
            &self.eval_stats(),
            self.info.name == "gpu",
            self.full_model,
        ))
        .unwrap_or(Value::Null);
        // Why this backend runs (not a setting: `auto` and an explicit request resolving
        // to the same backend give the same numbers; the resolved backend is in settings).
        if let Some(c) = self.evaluator.choice() {
            v["backend_choice"] = json!(c);
        }
        v
    }

    fn run_batch(&mut self, jobs: &[VariantJob], done: &mut dyn FnMut(usize, Outcome)) {
        self.run_batch_cancellable(jobs, &AtomicBool::new(false), done)
    }

    fn run_batch_cancellable(
        &mut self,
        jobs: &[VariantJob],
        cancel: &AtomicBool,
        done: &mut dyn FnMut(usize, Outcome),
    ) {
        let mut scenes = Vec::with_capacity(jobs.len());
        let mut index = Vec::with_capacity(jobs.len());
        for (k, job) in jobs.iter().enumerate() {
            match serde_json::from_value::<Scene>(job.scene.clone()) {
                Ok(mut s) => {
                    if self.full_model {
                        s.reductions = ReductionSpec::full();
                    }
                    scenes.push(s);
                    index.push(k);
                }
                Err(e) => done(k, Outcome::failed("invalid_scene", e.to_string())),
            }
        }
        // The whole batch is in flight at once (across threads): it shares the budget.
        let cap = crate::rotor::sample_cap(&scenes, self.max_memory);
        let opts = self.reductions.as_ref();
        if self.workers.len() <= 1 || scenes.len() <= 1 {
            let evaluator = self.workers.first_mut().unwrap_or(&mut self.evaluator);
            simulate_chunk(&scenes, evaluator, opts, cancel, cap, &mut |i, o| {
                done(index[i], o)
            });
            return;
        }
        // Round-robin over the threads: neighbouring variants (often alike in cost, e.g.
        // along the fastest grid axis) go to different threads.
        let t = self.workers.len();
        let mut buckets: Vec<(Vec<usize>, Vec<Scene>)> = vec![(Vec::new(), Vec::new()); t];
        for (k, scene) in scenes.into_iter().enumerate() {
            buckets[k % t].0.push(index[k]);
            buckets[k % t].1.push(scene);
        }
        let (tx, rx) = std::sync::mpsc::channel::<(usize, Outcome)>();
        std::thread::scope(|scope| {
            for (evaluator, (ids, chunk)) in self.workers.iter_mut().zip(&buckets) {
                if chunk.is_empty() {
                    continue;
                }
                let tx = tx.clone();
                scope.spawn(move || {
                    // The receiver lives until every worker is done.
                    simulate_chunk(chunk, evaluator, opts, cancel, cap, &mut |i, o| {
                        let _ = tx.send((ids[i], o));
                    });
                });
            }
            drop(tx);
            // Stream outcomes as workers finish variants.
            for (k, outcome) in rx {
                done(k, outcome);
            }
        });
    }

    fn take_notices(&mut self) -> Vec<String> {
        let mut n = self.evaluator.take_notices();
        for w in &mut self.workers {
            n.extend(w.take_notices());
        }
        n
    }
}

/// Simulates `scenes` on one evaluator, reporting `done(i, outcome)` as each ends: reduced
/// as they run under `opts` (a window of fixed length), else from their stored samples
/// (at most `cap` each).
fn simulate_chunk(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    opts: Option<&ReductionOptions>,
    cancel: &AtomicBool,
    cap: usize,
    done: &mut dyn FnMut(usize, Outcome),
) {
    match opts {
        Some(opts) => simulate_batch_observed(
            scenes,
            evaluator,
            scenes.iter().map(|s| RunReducer::new(s, opts)).collect(),
            &mut |i, r, reducer| done(i, outcome_reduced(r, &scenes[i], reducer, opts)),
            Some(cancel),
        ),
        None => {
            let results = simulate_batch_streaming_cancellable(
                scenes,
                evaluator,
                &mut |i, r| done(i, outcome_of(r, &scenes[i])),
                cancel,
                cap,
            );
            // The runner has what it needs; free the batch's series at once.
            drop(results);
        }
    }
}
