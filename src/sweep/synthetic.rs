//! `kind: "synthetic"`: an analytic stand-in for the rotor simulation whose reductions
//! are known in closed form. It exercises the whole sweep pipeline (spec, expansion,
//! batching, streaming, resume, shards, merge) without dynamics, in tests and for users
//! trying the machinery. Not physics.
//!
//! Scene (SI units; every field optional with the default shown):
//! ```json
//! {"spin": 100.0, "duration": 0.5, "samples": 501, "g_radius": 0.001,
//!  "cost_ms": 0, "fail": false,
//!  "bearings": [{"clearance": 3e-4, "eccentricity": 0.3, "orbit": 5e-6,
//!                "whirl_ratio": 0.45, "whirl": 0.0, "load": 10.0,
//!                "friction_coefficient": 0.02, "radius": 0.02}]}
//! ```
//! Journal centre of bearing `k` at both end faces: `εδ + orbit·e^{iωt} + whirl·e^{i r ω t}`
//! (x + iy); `G = g_radius·e^{iωt}`; constant spin `ω`; `|W| = load` along x; `M_z = −f r0 W`;
//! `h_min = δ − |e|`. A variant whose journal reaches the wall stops there with status
//! `"film_breakdown"`; `"fail": true` gives status `"failed"` with no signals; `cost_ms`
//! sleeps that long per variant (to test interrupted runs).

use serde::Deserialize;
use serde_json::Value;

use super::reduce::{BearingSignals, Signals};
use super::runner::{BatchSimulator, Outcome, VariantJob};

fn d_spin() -> f64 {
    100.0
}
fn d_duration() -> f64 {
    0.5
}
fn d_samples() -> usize {
    501
}
fn d_g() -> f64 {
    1e-3
}
fn d_clearance() -> f64 {
    3e-4
}
fn d_ecc() -> f64 {
    0.3
}
fn d_orbit() -> f64 {
    5e-6
}
fn d_ratio() -> f64 {
    0.45
}
fn d_load() -> f64 {
    10.0
}
fn d_f() -> f64 {
    0.02
}
fn d_radius() -> f64 {
    0.02
}
fn d_bearings() -> Vec<SynthBearing> {
    vec![serde_json::from_value(Value::Object(Default::default())).expect("defaults")]
}

/// One synthetic bearing.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SynthBearing {
    /// Radial clearance, m.
    #[serde(default = "d_clearance")]
    pub clearance: f64,
    /// Static eccentricity ratio (along x).
    #[serde(default = "d_ecc")]
    pub eccentricity: f64,
    /// Synchronous orbit radius, m.
    #[serde(default = "d_orbit")]
    pub orbit: f64,
    /// Whirl frequency / spin.
    #[serde(default = "d_ratio")]
    pub whirl_ratio: f64,
    /// Whirl radius, m.
    #[serde(default)]
    pub whirl: f64,
    /// Film force magnitude, N.
    #[serde(default = "d_load")]
    pub load: f64,
    /// Friction coefficient.
    #[serde(default = "d_f")]
    pub friction_coefficient: f64,
    /// Journal radius, m.
    #[serde(default = "d_radius")]
    pub radius: f64,
}

/// A synthetic scene.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SynthScene {
    /// Spin, rad/s.
    #[serde(default = "d_spin")]
    pub spin: f64,
    /// Simulated time, s.
    #[serde(default = "d_duration")]
    pub duration: f64,
    /// Output samples (uniform).
    #[serde(default = "d_samples")]
    pub samples: usize,
    /// Radius of G's circle, m.
    #[serde(default = "d_g")]
    pub g_radius: f64,
    /// Milliseconds to sleep per variant.
    #[serde(default)]
    pub cost_ms: u64,
    /// Fail this variant.
    #[serde(default)]
    pub fail: bool,
    /// Bearings.
    #[serde(default = "d_bearings")]
    pub bearings: Vec<SynthBearing>,
}

/// Validates a synthetic scene within the default memory budget: `Err((json path,
/// reason))`.
pub fn validate(scene: &Value) -> Result<(), (String, String)> {
    validate_within(scene, crate::budget::MemoryBudget::default())
}

/// [`validate`] within the memory budget `budget`.
pub fn validate_within(
    scene: &Value,
    budget: crate::budget::MemoryBudget,
) -> Result<(), (String, String)> {
    let s: SynthScene = crate::json::deserialize_at(scene)?;
    let pos = |path: String, x: f64| {
        if x.is_finite() && x > 0.0 {
            Ok(())
        } else {
            Err((
                path,
                format!("must be positive and finite, got {}", crate::json::num(x)),
            ))
        }
    };
    pos("spin".into(), s.spin.abs())?;
    pos("duration".into(), s.duration)?;
    if s.samples < 2 {
        return Err((
            "samples".into(),
            format!("must be at least 2, got {}", s.samples),
        ));
    }
    // Numbers per sample: t, spin, x_g, y_g and ten per bearing.
    let numbers = 4.0 + 10.0 * s.bearings.len() as f64;
    budget
        .check(
            &format!(
                "{} samples x {} bearings in each of {} variants in flight",
                s.samples,
                s.bearings.len(),
                crate::budget::SYNTHETIC_IN_FLIGHT
            ),
            s.samples as f64
                * numbers
                * (crate::budget::BYTES_PER_SYNTHETIC_NUMBER * crate::budget::SYNTHETIC_IN_FLIGHT)
                    as f64,
        )
        .map_err(|r| ("samples".to_string(), r))?;
    for (k, b) in s.bearings.iter().enumerate() {
        pos(format!("bearings[{k}].clearance"), b.clearance)?;
        if !(0.0..1.0).contains(&b.eccentricity) {
            return Err((
                format!("bearings[{k}].eccentricity"),
                format!(
                    "must be in [0, 1), got {}",
                    crate::json::num(b.eccentricity)
                ),
            ));
        }
    }
    Ok(())
}

/// Signals of a synthetic scene, cut at the first sample where a journal reaches the wall.
pub fn signals(s: &SynthScene) -> (Signals, Option<(f64, usize)>) {
    let n = s.samples;
    let mut out = Signals::default();
    let mut bs: Vec<BearingSignals> = s
        .bearings
        .iter()
        .map(|b| BearingSignals {
            clearance_m: b.clearance,
            ..Default::default()
        })
        .collect();
    let mut breakdown = None;
    'time: for i in 0..n {
        let t = s.duration * i as f64 / (n - 1) as f64;
        let a = s.spin * t;
        for (k, b) in s.bearings.iter().enumerate() {
            let x = b.eccentricity * b.clearance
                + b.orbit * a.cos()
                + b.whirl * (b.whirl_ratio * a).cos();
            let y = b.orbit * a.sin() + b.whirl * (b.whirl_ratio * a).sin();
            if x.hypot(y) >= b.clearance {
                breakdown = Some((t, k));
                break 'time;
            }
        }
        out.t.push(t);
        out.spin.push(s.spin);
        out.x_g.push(s.g_radius * a.cos());
        out.y_g.push(s.g_radius * a.sin());
        for (b, sig) in s.bearings.iter().zip(bs.iter_mut()) {
            let x = b.eccentricity * b.clearance
                + b.orbit * a.cos()
                + b.whirl * (b.whirl_ratio * a).cos();
            let y = b.orbit * a.sin() + b.whirl * (b.whirl_ratio * a).sin();
            let e = x.hypot(y);
            sig.xi.push(x);
            sig.yi.push(y);
            sig.xj.push(x);
            sig.yj.push(y);
            sig.h_min.push(b.clearance - e);
            sig.eccentricity_max.push(e / b.clearance);
            sig.friction_coefficient.push(Some(b.friction_coefficient));
            sig.mz
                .push(-s.spin.signum() * b.friction_coefficient * b.radius * b.load);
            sig.wx.push(b.load);
            sig.wy.push(0.0);
        }
    }
    out.bearings = bs;
    (out, breakdown)
}

/// The synthetic batch "simulator".
#[derive(Default)]
pub struct SyntheticSimulator;

impl BatchSimulator for SyntheticSimulator {
    fn auto_batch_size(&self) -> usize {
        64
    }

    fn info(&self) -> Value {
        serde_json::json!({"simulator": "synthetic (analytic signals, no dynamics)"})
    }

    fn run_batch(&mut self, jobs: &[VariantJob], done: &mut dyn FnMut(usize, Outcome)) {
        self.run_batch_cancellable(jobs, &std::sync::atomic::AtomicBool::new(false), done)
    }

    fn run_batch_cancellable(
        &mut self,
        jobs: &[VariantJob],
        cancel: &std::sync::atomic::AtomicBool,
        done: &mut dyn FnMut(usize, Outcome),
    ) {
        for (k, job) in jobs.iter().enumerate() {
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                done(
                    k,
                    Outcome::failed("cancelled", "the run was cancelled".into()),
                );
                continue;
            }
            let scene: SynthScene = match serde_json::from_value(job.scene.clone()) {
                Ok(s) => s,
                Err(e) => {
                    done(k, Outcome::failed("invalid_scene", e.to_string()));
                    continue;
                }
            };
            if scene.cost_ms > 0 {
                std::thread::sleep(std::time::Duration::from_millis(scene.cost_ms));
            }
            if scene.fail {
                done(
                    k,
                    Outcome::failed("failed", "synthetic failure requested by the scene".into()),
                );
                continue;
            }
            let (sig, breakdown) = signals(&scene);
            let outcome = match breakdown {
                None => Outcome::ok(sig),
                Some((t, b)) => Outcome {
                    status: "film_breakdown".into(),
                    message: Some(format!(
                        "bearing {b}: journal reached the wall at t = {t} s"
                    )),
                    signals: Some(sig),
                    extra: None,
                    reduced: None,
                },
            };
            done(k, outcome);
        }
    }
}
