//! The sweeps' `stability` analysis (`"kind": "stability"`): per variant, the linear modes
//! at the scene's speed and the threshold speed, with no time integration, behind the
//! runner's [`BatchSimulator`]. Every Newton iteration of every variant of a batch is one
//! evaluator call.

use serde_json::{json, Value};

use super::runner::{BatchSimulator, Outcome, VariantJob};
use crate::backend::{BackendInfo, LoadEvaluator};
use crate::rotor::Scene;
use crate::stability::{analyse_points, geometric_grid, thresholds, RotorDescription};

/// Speeds of each variant's threshold scan: geometric from `SCAN_LOW ×` to `SCAN_HIGH ×`
/// the scene's spin, then regula falsi to [`crate::stability::THRESHOLD_RTOL`].
pub const SCAN_POINTS: usize = 16;
/// Lowest scanned speed over the scene's spin.
pub const SCAN_LOW: f64 = 0.1;
/// Highest scanned speed over the scene's spin.
pub const SCAN_HIGH: f64 = 10.0;

/// Variants per batch for `--batch-size auto`: a few thousand states per evaluator call
/// on the CPU (49 states per bearing per call), more on a GPU.
pub const AUTO_BATCH_CPU: usize = 256;
/// ... on a GPU.
pub const AUTO_BATCH_GPU: usize = 2048;

/// Linear stability as a batch simulator.
pub struct StabilitySimulator {
    evaluator: LoadEvaluator,
    info: BackendInfo,
}

impl StabilitySimulator {
    /// Analyses on `evaluator`'s backend.
    pub fn new(evaluator: LoadEvaluator) -> Self {
        let info = evaluator.info();
        StabilitySimulator { evaluator, info }
    }

    /// The settings that change results (recorded in the result, checked on resume).
    pub fn settings(&self, accuracy_rtol: f64) -> Value {
        json!({"simulator": "stability", "backend": self.info.name, "precision": self.info.precision,
               "film_accuracy": accuracy_rtol,
               "scan": {"points": SCAN_POINTS, "low_over_spin": SCAN_LOW, "high_over_spin": SCAN_HIGH,
                        "bracket_rtol": crate::stability::THRESHOLD_RTOL}})
    }
}

/// The shape of a stability variant's `reductions` with every field present (numbers 0,
/// one bearing): what a plot's `y` of a `"kind": "stability"` spec is checked against
/// before running (`crate::sweep::plots`). `tests/examples.rs` checks it against the
/// reductions a run of `sweeps/stability-map.json` writes.
pub fn reductions_schema() -> Value {
    json!({
        "speed_rad_s": 0.0,
        "stable": false,
        "sigma_max_1_s": 0.0,
        "least_damped": {"sigma_1_s": 0.0, "frequency_rad_s": 0.0, "whirl_ratio": 0.0,
                         "damping_ratio": 0.0, "log_dec": 0.0, "direction": "forward"},
        "log_dec_min": 0.0,
        "log_dec_min_whirl_ratio": 0.0,
        "threshold_speed_rad_s": 0.0,
        "threshold_over_speed": 0.0,
        "threshold_whirl_ratio": 0.0,
        "threshold_note": "",
        "eccentricity_ratio": [0.0],
    })
}

/// The least log-dec among the oscillating modes and that mode.
fn least_log_dec(modes: &[crate::stability::Mode]) -> Option<&crate::stability::Mode> {
    modes.iter().filter(|m| m.log_dec.is_some()).min_by(|a, b| {
        a.log_dec
            .unwrap_or(0.0)
            .total_cmp(&b.log_dec.unwrap_or(0.0))
    })
}

impl BatchSimulator for StabilitySimulator {
    fn auto_batch_size(&self) -> usize {
        if self.info.name == "cpu" {
            AUTO_BATCH_CPU
        } else {
            AUTO_BATCH_GPU
        }
    }

    fn info(&self) -> Value {
        let mut v = serde_json::to_value(&self.info).unwrap_or(Value::Null);
        v["evaluator"] = serde_json::to_value(self.evaluator.stats()).unwrap_or(Value::Null);
        v
    }

    fn run_batch(&mut self, jobs: &[VariantJob], done: &mut dyn FnMut(usize, Outcome)) {
        let mut rotors = Vec::new();
        let mut index = Vec::new();
        for (k, job) in jobs.iter().enumerate() {
            let scene = match serde_json::from_value::<Scene>(job.scene.clone()) {
                Ok(s) => s,
                Err(e) => {
                    done(k, Outcome::failed("invalid_scene", e.to_string()));
                    continue;
                }
            };
            if scene.initial.spin == 0.0 {
                done(
                    k,
                    Outcome::failed(
                        "invalid_scene",
                        "initial.spin: 0 (no film load without spin; nothing to linearise)".into(),
                    ),
                );
                continue;
            }
            match RotorDescription::from_scene(&scene) {
                Ok(r) => {
                    rotors.push(r);
                    index.push(k);
                }
                Err(e) => done(k, Outcome::failed(e.code(), e.to_string())),
            }
        }
        if rotors.is_empty() {
            return;
        }
        let points: Vec<(&RotorDescription, f64)> = rotors.iter().map(|r| (r, r.spin)).collect();
        let here = analyse_points(&mut self.evaluator, &points);
        let refs: Vec<&RotorDescription> = rotors.iter().collect();
        let grids: Vec<Vec<f64>> = rotors
            .iter()
            .map(|r| {
                let w = r.spin.abs();
                geometric_grid(SCAN_LOW * w, SCAN_HIGH * w, SCAN_POINTS)
            })
            .collect();
        let th = thresholds(&mut self.evaluator, &refs, &grids);
        for (((k, r), a), t) in index.into_iter().zip(&rotors).zip(here).zip(th) {
            let a = match a {
                Ok(a) => a,
                Err(e) => {
                    done(k, Outcome::failed(e.code(), e.to_string()));
                    continue;
                }
            };
            let least = a.modes.first();
            let ld = least_log_dec(&a.modes);
            let reductions = json!({
                "speed_rad_s": r.spin,
                "stable": a.max_growth() < 0.0,
                "sigma_max_1_s": a.max_growth(),
                "least_damped": least.map(|m| json!({
                    "sigma_1_s": m.sigma_1_s, "frequency_rad_s": m.frequency_rad_s,
                    "whirl_ratio": m.whirl_ratio, "damping_ratio": m.damping_ratio,
                    "log_dec": m.log_dec, "direction": m.direction})),
                "log_dec_min": ld.and_then(|m| m.log_dec),
                "log_dec_min_whirl_ratio": ld.map(|m| m.whirl_ratio),
                "threshold_speed_rad_s": t.speed_rad_s,
                "threshold_over_speed": t.speed_rad_s.map(|s| s / r.spin.abs()),
                "threshold_whirl_ratio": t.whirl_ratio,
                "threshold_note": (!t.note.is_empty()).then_some(t.note.clone()),
                "eccentricity_ratio": a.linear.bearings.iter().map(|b| b.eccentricity_ratio).collect::<Vec<_>>(),
            });
            done(
                k,
                Outcome {
                    status: "ok".into(),
                    message: None,
                    signals: None,
                    extra: Some(json!({
                        "reductions": reductions,
                        "frame": a.linear.frame,
                        "newton_iterations": a.linear.newton_iterations,
                        "threshold_iterations": t.iterations,
                        "notes": r.notes,
                    })),
                    reduced: None,
                },
            );
        }
    }

    fn take_notices(&mut self) -> Vec<String> {
        self.evaluator.take_notices()
    }
}
