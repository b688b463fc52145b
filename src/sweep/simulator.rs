//! The simulator for a parsed sweep spec, as `run` and the service both build it: the
//! synthetic stand-in, or the rotor integrator on the chosen film backend with the spec's
//! model reductions, plus the settings recorded in the result and checked on resume.

use serde_json::{json, Value};

use super::expand::SceneValidator;
use super::rotor_sim::{validate_scene, validate_scene_within, RotorSimulator};
use super::runner::BatchSimulator;
use super::synthetic::{self, SyntheticSimulator};
use super::{SweepError, SweepKind, SweepOptions, SweepSpec};
use crate::backend::{
    choose_sweep_backend, create_backend, BackendError, BackendKind, EvaluatorOptions,
    LoadEvaluator,
};
use crate::bearing::Accuracy;
use crate::budget::MemoryBudget;
use crate::rotor::simplifications::{evaluator_options, SimplificationSpec};

/// Why no simulator could be built.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A variant's scene is invalid (checked before a backend starts).
    #[error(transparent)]
    Sweep(#[from] SweepError),
    /// The film backend could not be created.
    #[error(transparent)]
    Backend(#[from] BackendError),
}

/// A simulator ready for the runner.
pub struct PreparedSimulator {
    /// The simulator.
    pub sim: Box<dyn BatchSimulator>,
    /// Its scene validator (every variant is checked with it).
    pub validator: Box<SceneValidator>,
    /// Settings that change results (recorded in the result and the stream header).
    pub settings: Value,
}

/// The scene validator of a sweep kind within the memory budget `budget`: every variant of
/// a spec is checked with it (one place, so `run`, the service and the workers agree on
/// what a valid variant is).
pub fn scene_validator_within(kind: SweepKind, budget: MemoryBudget) -> Box<SceneValidator> {
    match kind {
        SweepKind::Synthetic => Box::new(move |v| synthetic::validate_within(v, budget)),
        SweepKind::Rotor | SweepKind::Stability => {
            Box::new(move |v| validate_scene_within(v, budget))
        }
        SweepKind::FrictionMap => Box::new(no_scenes),
    }
}

/// [`scene_validator_within`] the default memory budget (2 GiB).
pub fn scene_validator(kind: SweepKind) -> &'static SceneValidator {
    match kind {
        SweepKind::Synthetic => &synthetic::validate,
        SweepKind::Rotor | SweepKind::Stability => &validate_scene,
        SweepKind::FrictionMap => &no_scenes,
    }
}

/// The validator of a kind without scenes: every variant is refused.
fn no_scenes(_: &Value) -> Result<(), (String, String)> {
    Err((
        "kind".into(),
        "a friction map has no scenes to simulate".into(),
    ))
}

/// Builds the simulator for `spec` (a rotor spec's variants are all validated first: a
/// GPU start is slow). Backend notices (e.g. a fallback to the CPU) go to `notice`.
pub fn prepare_simulator(
    spec: &SweepSpec,
    choice: &SweepOptions,
    notice: &mut dyn FnMut(String),
) -> Result<PreparedSimulator, SetupError> {
    match spec.kind {
        SweepKind::FrictionMap => Err(SetupError::Sweep(SweepError::spec(
            "kind",
            "a friction map runs no simulator (`crate::sweep::friction_map`)",
        ))),
        SweepKind::Synthetic => Ok(PreparedSimulator {
            sim: Box::new(SyntheticSimulator),
            validator: scene_validator_within(spec.kind, choice.max_memory),
            settings: json!({"simulator": "synthetic"}),
        }),
        SweepKind::Stability => {
            let validator = scene_validator_within(spec.kind, choice.max_memory);
            super::Expansion::new(spec).validate_all(spec, &*validator)?;
            // The coefficients are differences of film loads: always the tightest level
            // (docs/cli.md "Coefficients and stability").
            let tight = Accuracy::new(1e-12).expect("a calibrated level");
            if choice.accuracy.level().rtol() != tight.rtol() {
                notice(format!(
                    "notice: stability sweeps evaluate the film at accuracy 1e-12 (not {:e})",
                    choice.accuracy.level().rtol()
                ));
            }
            let (backend, n) = create_backend(choice.backend, tight)?;
            if let Some(n) = n {
                notice(n);
            }
            let (ev, swap) = crate::stability::difference_evaluator(backend, tight);
            if let Some(n) = swap {
                notice(n);
            }
            let sim = crate::sweep::stability_sim::StabilitySimulator::new(ev);
            let settings = sim.settings(tight.rtol());
            Ok(PreparedSimulator {
                sim: Box::new(sim),
                validator,
                settings,
            })
        }
        SweepKind::Rotor => {
            let validator = scene_validator_within(spec.kind, choice.max_memory);
            super::Expansion::new(spec).validate_all(spec, &*validator)?;
            let threads = rayon::current_num_threads();
            let (backend, n) = if choice.backend == BackendKind::Auto && short_film_only(spec) {
                // `auto` from a calibration of the device and host (backend::Calibration).
                let bearings = spec
                    .base
                    .get("bearings")
                    .and_then(Value::as_array)
                    .map_or(1, Vec::len);
                let variants = super::Expansion::new(spec)
                    .count()
                    .min(super::rotor_sim::AUTO_BATCH_GPU as u64)
                    as usize;
                let (b, notices) = choose_sweep_backend(
                    BackendKind::Auto,
                    choice.accuracy.level(),
                    bearings,
                    variants,
                    threads,
                )?;
                (b, (!notices.is_empty()).then(|| notices.join("\n")))
            } else if choice.backend == BackendKind::Auto {
                // A sweep with the finite film (or `auto` films): the CPU, whatever the
                // adapter. Measured on an H200 against its host's 16 threads (BENCHMARKS.md
                // "Issue 20, session 41: finite-film rotor sweeps on the H200"): the kernel
                // now wins from ~1,000 states per call in the benchmark, but a rotor sweep's
                // stages carry easy states (the ladder stops on coarse grids) that the CPU
                // solves at 100,000-200,000 states/s while a GPU call costs at least one
                // state's chain of kernel steps: 1,024 variants took 4.4 s on the GPU
                // against 2.6 s, 4,096 variants 20.1 s against 12.7 s. With the workgroup
                // size per chunk (session 42) 1,024 variants take 2.74 s against 2.50 s:
                // still no win. `--backend gpu` still runs it there.
                let (b, notices) = crate::backend::chosen_cpu(
                    BackendKind::Auto,
                    choice.accuracy.level(),
                    FINITE_SWEEP_ON_CPU.into(),
                );
                (b, Some(notices.join("\n")))
            } else {
                create_backend(choice.backend, choice.accuracy.level())?
            };
            if let Some(n) = n {
                notice(n);
            }
            // Evaluator-level reductions from the base scene (one evaluator serves every
            // variant).
            let base: SimplificationSpec = spec
                .base
                .get("reductions")
                .and_then(|v| serde_json::from_value(v.clone()).ok())
                .unwrap_or_default();
            let eval_options = if choice.full_model {
                EvaluatorOptions::full()
            } else {
                evaluator_options([&base])
            };
            let mut sim = RotorSimulator::new(
                LoadEvaluator::with_options(backend, eval_options),
                choice.accuracy.level(),
            );
            sim.set_full_model(choice.full_model);
            sim.set_reductions(&spec.reductions);
            sim.set_max_memory(choice.max_memory);
            let settings = sim.settings(choice.accuracy.level().rtol());
            Ok(PreparedSimulator {
                sim: Box::new(sim),
                validator,
                settings,
            })
        }
    }
}

/// Reason of `auto`'s choice for a rotor sweep that uses the finite film.
const FINITE_SWEEP_ON_CPU: &str = "the sweep uses the finite film, whose rotor sweeps ran \
     slower on the GPU than on the CPU backend (use --backend gpu to run it there)";

/// Whether every variant of a rotor sweep uses the short film: no bearing of the base
/// scene names another model and no axis sets a bearing's `model` (or a whole bearing).
fn short_film_only(spec: &SweepSpec) -> bool {
    let base_short = spec
        .base
        .get("bearings")
        .and_then(Value::as_array)
        .is_none_or(|bs| {
            bs.iter().all(|b| {
                b.get("model")
                    .and_then(Value::as_str)
                    .is_none_or(|m| m == "short")
            })
        });
    base_short
        && spec.axes.iter().all(|a| {
            // An axis that sets a bearing's model, or a whole bearing or bearing list.
            let p = a.path.as_str();
            !(p.starts_with("bearings")
                && (p.ends_with("model") || p.ends_with(']') || p == "bearings"))
        })
}
