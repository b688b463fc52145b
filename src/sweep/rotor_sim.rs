//! Rotor sweeps: the rotor integrator ([`crate::rotor::simulate_batch`], lockstep batches
//! whose every stage is one film-load call) behind the runner's [`BatchSimulator`], and
//! the scene validator that checks every variant before anything runs.

use serde_json::{json, Value};

use super::reduce::{BearingSignals, Signals};
use super::runner::{BatchSimulator, Job, Outcome};
use crate::backend::{BackendInfo, LoadEvaluator};
use crate::rotor::{simulate_batch, Scene, SimResult};

/// Variants per batch for `--batch-size auto` on the CPU: enough states per film call to
/// fill the cores (2 bearings × 256 variants per stage), few enough that the batch's
/// sampled series (about 1 MB per variant at the default 1e-4 s samples over 0.5 s) stay
/// in memory comfortably.
pub const AUTO_BATCH_CPU: usize = 256;
/// ... on a GPU: thousands of states per dispatch amortise its launch cost.
pub const AUTO_BATCH_GPU: usize = 4096;

/// Checks one variant's scene: `Err((JSON path, reason))`.
pub fn validate_scene(v: &Value) -> Result<(), (String, String)> {
    let scene: Scene = serde_json::from_value(v.clone()).map_err(|e| {
        let msg = e.to_string();
        (
            locate_unknown_field(v, &msg).unwrap_or_else(|| "$".into()),
            msg,
        )
    })?;
    if scene.compare_ideal {
        return Err((
            "compare_ideal".into(),
            "not used in sweeps (one variant is one simulation): sweep an axis {\"path\": \"model\", \"values\": [\"bearing\", \"ideal\"]} instead".into(),
        ));
    }
    scene.validate().map_err(|e| (e.path, e.reason))
}

/// The JSON path of the object holding the field named in serde's "unknown field `x`"
/// message (serde does not say where it is).
fn locate_unknown_field(v: &Value, msg: &str) -> Option<String> {
    let name = msg.strip_prefix("unknown field `")?.split('`').next()?;
    fn find(v: &Value, name: &str, at: String) -> Option<String> {
        match v {
            Value::Object(o) => {
                if o.contains_key(name) {
                    return Some(if at.is_empty() {
                        name.to_string()
                    } else {
                        format!("{at}.{name}")
                    });
                }
                o.iter().find_map(|(k, c)| {
                    find(
                        c,
                        name,
                        if at.is_empty() {
                            k.clone()
                        } else {
                            format!("{at}.{k}")
                        },
                    )
                })
            }
            Value::Array(a) => a
                .iter()
                .enumerate()
                .find_map(|(i, c)| find(c, name, format!("{at}[{i}]"))),
            _ => None,
        }
    }
    find(v, name, String::new())
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

/// The outcome the runner streams for one simulation.
pub fn outcome_of(r: &SimResult, scene: &Scene) -> Outcome {
    let status = status_name(r);
    Outcome {
        message: (status != "ok").then(|| r.status.to_string()),
        status,
        signals: Some(signals_of(r, scene)),
        // Deterministic counters only (wall times go to the run section, not here).
        extra: Some(json!({
            "method": r.method.name(),
            "model": r.model,
            "steps": r.stats.steps,
            "rejected": r.stats.rejected,
            "rhs_evaluations": r.stats.rhs_evaluations,
            "load_evaluations": r.stats.load_evaluations,
        })),
    }
}

/// The rotor integrator as a batch simulator.
pub struct RotorSimulator {
    evaluator: LoadEvaluator,
    info: BackendInfo,
}

impl RotorSimulator {
    /// Simulates on `evaluator`'s backend.
    pub fn new(evaluator: LoadEvaluator) -> Self {
        let info = evaluator.info();
        RotorSimulator { evaluator, info }
    }

    /// The settings that change results, recorded in the result and checked on resume
    /// and merge: backend kind and precision, film accuracy.
    pub fn settings(&self, accuracy_rtol: f64) -> Value {
        json!({"simulator": "rotor", "backend": self.info.name, "precision": self.info.precision,
               "film_accuracy": accuracy_rtol})
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
        serde_json::to_value(&self.info).unwrap_or(Value::Null)
    }

    fn run_batch(&mut self, jobs: &[Job], done: &mut dyn FnMut(usize, Outcome)) {
        let mut scenes = Vec::with_capacity(jobs.len());
        let mut index = Vec::with_capacity(jobs.len());
        for (k, job) in jobs.iter().enumerate() {
            match serde_json::from_value::<Scene>(job.scene.clone()) {
                Ok(s) => {
                    scenes.push(s);
                    index.push(k);
                }
                Err(e) => done(k, Outcome::failed("invalid_scene", e.to_string())),
            }
        }
        let results = simulate_batch(&scenes, &mut self.evaluator, &mut |i, r| {
            done(index[i], outcome_of(r, &scenes[i]));
        });
        // The runner has what it needs; free the batch's series at once.
        drop(results);
    }

    fn take_notices(&mut self) -> Vec<String> {
        self.evaluator.take_notices()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_fields_are_located() {
        let v = json!({"rotor": {"mass": 1.0}, "bearings": [{"radius": 1.0}, {"clerance": 2.0}]});
        assert_eq!(
            locate_unknown_field(&v, "unknown field `clerance`, expected one of ..."),
            Some("bearings[1].clerance".into())
        );
        assert_eq!(locate_unknown_field(&v, "missing field `x`"), None);
    }
}
