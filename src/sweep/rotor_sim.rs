//! Rotor sweeps: the rotor integrator ([`crate::rotor::simulate_batch_streaming`], here its cancellable form, lockstep batches
//! whose every stage is one film-load call) behind the runner's [`BatchSimulator`], and
//! the scene validator that checks every variant before anything runs.

use serde_json::{json, Value};

use super::reduce::{BearingSignals, FilmSignals, ReductionOptions, Signals};
use super::runner::{BatchSimulator, Outcome, Reduced, VariantJob};
use super::stream::RunReducer;
use crate::backend::{
    BackendInfo, CpuBackend, DispatchStats, Dispatcher, EvalStats, LoadEvaluator,
};
use crate::bearing::{Accuracy, FilmModel};
use crate::budget::MemoryBudget;
use crate::rotor::simplifications::{evaluator_report, SimplificationSpec};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

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
                film: b
                    .film
                    .as_ref()
                    .map(|f| FilmSignals {
                        friction_torque_nm: f.friction_torque_nm.clone(),
                        power_loss_w: f.power_loss_w.clone(),
                        side_flow_m3_per_s: f.side_flow_m3_per_s.clone(),
                        inlet_flow_m3_per_s: f.inlet_flow_m3_per_s.clone(),
                    })
                    .unwrap_or_default(),
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
/// The batch is split into sub-batches (dealt round-robin, identical variants kept
/// together so that their film states are integrated once), each advancing in lockstep
/// on one evaluator: the parallelism is across variants. On the CPU there is one
/// sub-batch per thread of rayon's pool, each with a single-threaded CPU evaluator (a film
/// call carries only a few hundred states, too few to spread over threads). On a GPU the
/// sub-batches have a fixed size ([`GPU_GROUP_VARIANTS`]) and the threads take them in
/// turn; every thread's evaluator holds a handle on one [`Dispatcher`], which merges the
/// stage requests that wait while a dispatch is in flight into the next one: the device
/// evaluates one merged request while the other threads advance their integrators.
/// Results do not depend on the split or the thread count (each variant has its own
/// step-size control, every state's loads are computed alone, and a GPU sub-batch's calls,
/// hence their small-batch CPU routing, do not depend on the thread count). Sweeps with
/// finite-film or `auto` bearings on a GPU keep one lockstep batch on one evaluator:
/// their finite-film calls are not merged, and large ones fill the device by themselves.
pub struct RotorSimulator {
    evaluator: LoadEvaluator,
    info: BackendInfo,
    workers: Vec<LoadEvaluator>,
    /// The GPU backend behind its merge queue (GPU backends only).
    dispatcher: Option<Arc<Dispatcher>>,
    /// Host-side counters of the GPU sub-batches ([`RotorSimulator::gpu_report`]).
    gpu_host: GpuHostCounters,
    full_model: bool,
    /// The spec's reductions: each variant is reduced as it runs and keeps only what they
    /// need ([`super::stream`]); unset, the samples are stored and the runner reduces them.
    reductions: Option<ReductionOptions>,
    /// The memory budget the batch's sample caps come from (default 2 GiB).
    max_memory: MemoryBudget,
}

impl RotorSimulator {
    /// Simulates on `evaluator`'s backend; a CPU backend gets one single-threaded CPU
    /// evaluator per thread of rayon's pool (`RAYON_NUM_THREADS`) at `accuracy`, a GPU
    /// backend one evaluator per thread on a shared [`Dispatcher`].
    pub fn new(evaluator: LoadEvaluator, accuracy: Accuracy) -> Self {
        let info = evaluator.info();
        let threads = rayon::current_num_threads().max(1);
        let options = evaluator.options();
        let (evaluator, workers, dispatcher) = if info.name == "cpu" {
            let workers = (0..threads)
                .map(|_| {
                    LoadEvaluator::with_options(
                        Box::new(CpuBackend::new(accuracy, Some(1))),
                        options,
                    )
                })
                .collect();
            (evaluator, workers, None)
        } else if info.name == "gpu" {
            let dispatcher = Dispatcher::new(evaluator.into_backend());
            let workers = (0..threads)
                .map(|_| LoadEvaluator::with_options(dispatcher.handle(), options))
                .collect();
            let whole = LoadEvaluator::with_options(dispatcher.handle(), options);
            (whole, workers, Some(dispatcher))
        } else {
            (evaluator, Vec::new(), None)
        };
        RotorSimulator {
            evaluator,
            info,
            workers,
            dispatcher,
            gpu_host: GpuHostCounters::default(),
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

    /// Reduce each variant with `opts` as it runs (memory then follows the window and
    /// the kept series, not `t_end`: [`super::stream`]); without this call the samples
    /// are stored and the runner reduces them.
    pub fn set_reductions(&mut self, opts: &ReductionOptions) {
        self.reductions = Some(opts.clone());
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
        if let Some(r) = self.gpu_report() {
            v["gpu_dispatch"] = json!(r);
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
                        s.reductions = SimplificationSpec::full();
                    }
                    scenes.push(s);
                    index.push(k);
                }
                Err(e) => done(k, Outcome::failed("invalid_scene", e.to_string())),
            }
        }
        // The whole batch is in flight at once (across threads): it shares the budget.
        let budget = self.max_memory;
        let cap = crate::rotor::sample_cap(&scenes, budget);
        let opts = self.reductions.as_ref();
        // On a GPU, finite-film (or `auto`) bearings keep the whole batch on one
        // evaluator (see the type's documentation).
        let whole = self.dispatcher.is_some()
            && scenes
                .iter()
                .any(|s| s.bearings.iter().any(|b| b.model != FilmModel::Short));
        if whole || self.workers.is_empty() {
            simulate_chunk(
                &scenes,
                &mut self.evaluator,
                opts,
                cancel,
                (cap, budget),
                &mut |i, o| done(index[i], o),
            );
            return;
        }
        let before = self.dispatcher.as_ref().map(|d| d.stats().request_wait_s);
        let started = std::time::Instant::now();
        let states_before = self.worker_states();
        let bearings: usize = scenes.iter().map(|s| s.bearings.len()).sum();
        let per_variant = bearings.max(1) as f64 / scenes.len().max(1) as f64;
        // On the CPU one sub-batch per thread; on a GPU sub-batches of a fixed size
        // whatever the thread count, taken by the threads from a shared counter.
        let groups = if self.dispatcher.is_some() {
            scenes.len().div_ceil(GPU_GROUP_VARIANTS)
        } else {
            self.workers.len()
        };
        let buckets = deal(scenes, &index, jobs, groups);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let (tx, rx) = std::sync::mpsc::channel::<(usize, Outcome)>();
        let thread_s: f64 = std::thread::scope(|scope| {
            let mut handles = Vec::new();
            for evaluator in self.workers.iter_mut().take(groups) {
                let tx = tx.clone();
                let (buckets, next) = (&buckets, &next);
                handles.push(scope.spawn(move || {
                    let t = std::time::Instant::now();
                    loop {
                        let g = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some((ids, chunk)) = buckets.get(g) else {
                            break;
                        };
                        if chunk.is_empty() {
                            continue;
                        }
                        // The receiver lives until every worker is done.
                        simulate_chunk(
                            chunk,
                            evaluator,
                            opts,
                            cancel,
                            (cap, budget),
                            &mut |i, o| {
                                let _ = tx.send((ids[i], o));
                            },
                        );
                    }
                    t.elapsed().as_secs_f64()
                }));
            }
            drop(tx);
            // Stream outcomes as workers finish variants.
            for (k, outcome) in rx {
                done(k, outcome);
            }
            handles.into_iter().map(|h| h.join().unwrap_or(0.0)).sum()
        });
        let states = self.worker_states() - states_before;
        if let (Some(d), Some(w0)) = (&self.dispatcher, before) {
            let h = &mut self.gpu_host;
            h.thread_s += thread_s;
            h.wait_s += d.stats().request_wait_s - w0;
            h.wall_s += started.elapsed().as_secs_f64();
            h.variant_stages += states as f64 / per_variant;
        }
    }

    fn take_notices(&mut self) -> Vec<String> {
        let mut n = self.evaluator.take_notices();
        for w in &mut self.workers {
            n.extend(w.take_notices());
        }
        n
    }
}

/// Variants per sub-batch on a GPU: a fixed size, so that every call a sub-batch makes
/// (and with it the evaluator's small-batch CPU routing, [`crate::backend::EvaluatorOptions::cpu_below`])
/// is the same whatever the thread count, which keeps results independent of it. 256
/// variants of the paper rotor make 512-state calls, merged over 16 threads into
/// dispatches of up to ~8 000 states; a 4 096-variant batch gives 16 sub-batches.
pub const GPU_GROUP_VARIANTS: usize = 256;

/// Deals `scenes` (with their job indices `index` into `jobs`) into `t` sub-batches:
/// round-robin, so that neighbouring variants (often alike in cost, e.g. along the
/// fastest grid axis) go to different threads, except that a variant identical to an
/// earlier one joins that one's sub-batch (its film states are then integrated once).
fn deal(
    scenes: Vec<Scene>,
    index: &[usize],
    jobs: &[VariantJob],
    t: usize,
) -> Vec<(Vec<usize>, Vec<Scene>)> {
    let mut buckets: Vec<(Vec<usize>, Vec<Scene>)> = vec![(Vec::new(), Vec::new()); t];
    let mut seen: std::collections::HashMap<String, usize> = Default::default();
    let mut next = 0;
    for (k, scene) in scenes.into_iter().enumerate() {
        let key = jobs[index[k]].scene.to_string();
        let b = *seen.entry(key).or_insert_with(|| {
            next += 1;
            (next - 1) % t
        });
        buckets[b].0.push(index[k]);
        buckets[b].1.push(scene);
    }
    buckets
}

/// Host-side counters of the GPU sub-batches.
#[derive(Clone, Copy, Debug, Default)]
struct GpuHostCounters {
    /// Seconds the worker threads ran, summed over threads.
    thread_s: f64,
    /// Of which inside the dispatcher (waiting for loads or dispatching them).
    wait_s: f64,
    /// Wall seconds of the sub-batched batches.
    wall_s: f64,
    /// Variant-stages run (bearing states / bearings per variant).
    variant_stages: f64,
}

/// What the GPU path measured: the dispatcher's counters and the host's share
/// (`run.simulator.gpu_dispatch` in result.json; docs/cli.md "Backends").
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GpuReport {
    /// The dispatcher's counters.
    #[serde(flatten)]
    pub dispatch: DispatchStats,
    /// Mean states per dispatch.
    pub states_per_dispatch: f64,
    /// Fraction of the dispatcher's span with no dispatch in flight.
    pub device_idle_fraction: f64,
    /// Seconds of host work (worker-thread time outside the dispatcher), summed.
    pub host_s: f64,
    /// Variant-stages the worker threads ran.
    pub variant_stages: f64,
    /// Host microseconds per variant-stage (integrator, kinematics, samples, packing and
    /// finishing loads: everything but the dispatch), on one thread.
    pub host_us_per_variant_stage: f64,
    /// Wall seconds of the sub-batched batches.
    pub wall_s: f64,
}

impl RotorSimulator {
    /// What the GPU path measured so far; `None` on the CPU.
    pub fn gpu_report(&self) -> Option<GpuReport> {
        let d = self.dispatcher.as_ref()?.stats();
        let h = self.gpu_host;
        let host_s = (h.thread_s - h.wait_s).max(0.0);
        Some(GpuReport {
            dispatch: d,
            states_per_dispatch: d.states as f64 / d.dispatches.max(1) as f64,
            device_idle_fraction: d.device_idle_fraction(),
            host_s,
            variant_stages: h.variant_stages,
            host_us_per_variant_stage: if h.variant_stages > 0.0 {
                1e6 * host_s / h.variant_stages
            } else {
                0.0
            },
            wall_s: h.wall_s,
        })
    }

    /// States requested by the worker evaluators so far.
    fn worker_states(&self) -> u64 {
        self.workers.iter().map(|w| w.stats().states).sum()
    }
}

/// Simulates `scenes` on one evaluator, reporting `done(i, outcome)` as each ends: reduced
/// as they run under `opts` (a fraction window's tail decimated beyond `cap` samples),
/// else from their stored samples (at most `cap` each). Scenes are validated within `budget`, the run's memory budget
/// (`cap` comes from it).
fn simulate_chunk(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    opts: Option<&ReductionOptions>,
    cancel: &AtomicBool,
    (cap, budget): (usize, MemoryBudget),
    done: &mut dyn FnMut(usize, Outcome),
) {
    match opts {
        Some(opts) => simulate_batch_observed(
            scenes,
            evaluator,
            scenes
                .iter()
                .map(|s| RunReducer::new(s, opts, cap))
                .collect(),
            &mut |i, r, reducer| done(i, outcome_reduced(r, &scenes[i], reducer, opts)),
            Some(cancel),
            budget,
        ),
        None => {
            let results = simulate_batch_streaming_cancellable(
                scenes,
                evaluator,
                &mut |i, r| done(i, outcome_of(r, &scenes[i])),
                cancel,
                cap,
                budget,
            );
            // The runner has what it needs; free the batch's series at once.
            drop(results);
        }
    }
}
