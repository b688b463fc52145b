//! Scene files: the rotor, its bearings, the initial state, the model and the integrator
//! (serde, unknown fields rejected), validation naming the JSON path, and loading.

use serde::{Deserialize, Serialize};

use crate::bearing::{
    Arcs, BearingParams, ClearanceConvention, FilmModel, FiniteSettings, Grooves, Lubricant,
    ThermalSettings,
};
use crate::integrate::Method;

/// Rigid-rotor mass properties. The body frame has its origin at the centre of mass `G`
/// and its `z` axis parallel to the shaft axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotorSpec {
    /// Mass, kg (paper: 1.0).
    pub mass: f64,
    /// Principal moments of inertia about `G`, kg·m² (paper: `[0.01, 0.01, 0.3]`); the
    /// third is about the principal axis nearest the shaft axis.
    pub inertia: [f64; 3],
    /// Static unbalance: position of `G` relative to the shaft axis, in the body `x, y`
    /// plane, m (paper: `[0.001, 0]`). Default `[0, 0]`.
    #[serde(default)]
    pub static_unbalance: [f64; 2],
    /// Couple unbalance: the principal axes are the body axes turned by `[bx, by]` rad,
    /// about body `x` then about the resulting `y` (`I_body = Rx Ry diag(I) Ryᵀ Rxᵀ`).
    /// Default `[0, 0]`.
    #[serde(default)]
    pub couple_unbalance: [f64; 2],
}

/// One bearing: geometry, lubricant and where it sits along the shaft. The housing is
/// fixed and the bore coaxial with the global `z` axis; the bearing frame's origin is at
/// its first end face (mid-plane − length/2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingSpec {
    /// Journal radius `r0`, m.
    pub radius: f64,
    /// Bearing length `B`, m.
    pub length: f64,
    /// Radial clearance `δ`, m.
    pub clearance: f64,
    /// Lubricant dynamic viscosity `μ`, Pa·s. Required unless `lubricant` is given
    /// (exactly one of the two).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub viscosity: Option<f64>,
    /// Relative clearance in the friction law: `"paper"` (default) or `"vogelpohl"`.
    #[serde(default)]
    pub clearance_convention: ClearanceConvention,
    /// Film model: `"short"` (default), `"finite"` or `"auto"` (docs/finite-film.md).
    #[serde(default)]
    pub model: FilmModel,
    /// Finite-film grid, tolerance and `auto` threshold; every field defaults.
    #[serde(default)]
    pub finite: FiniteSettings,
    /// Axial coordinate of the bearing's mid-plane along the shaft from `G`, m (paper:
    /// +0.2 and −0.1).
    pub axial_position: f64,
    /// Axial oil-supply grooves (docs/grooves.md); default none. Needs `"model":
    /// "finite"`.
    #[serde(default, skip_serializing_if = "Grooves::is_empty")]
    pub grooves: Grooves,
    /// Lands of a partial-arc bearing (docs/grooves.md); default none (360°).
    #[serde(default, skip_serializing_if = "Arcs::is_empty")]
    pub arcs: Arcs,
    /// Lubricant (`"ISO VG 46"` or an object, docs/thermal.md) instead of `viscosity`;
    /// needs `supply_temperature`. In a scene the film runs at the supply temperature's
    /// viscosity (docs/thermal.md "Rotor scenes").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lubricant: Option<Lubricant>,
    /// Oil supply temperature, °C (with `lubricant` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supply_temperature: Option<f64>,
    /// Thermal settings (docs/thermal.md); every field defaults.
    #[serde(default)]
    pub thermal: ThermalSettings,
}

impl BearingSpec {
    /// The film model's parameters, the viscosity resolved from the lubricant at the
    /// supply temperature where one is given (NaN, refused by validation, when the
    /// lubricant fields are inconsistent: [`BearingSpec::lubricant_error`] says why).
    pub fn params(&self) -> BearingParams {
        let mut p = self.raw_params();
        if p.resolve_lubricant().is_err() {
            p.viscosity = f64::NAN;
        }
        p
    }

    fn raw_params(&self) -> BearingParams {
        BearingParams {
            radius: self.radius,
            length: self.length,
            clearance: self.clearance,
            viscosity: self.viscosity.unwrap_or(f64::NAN),
            clearance_convention: self.clearance_convention,
            model: self.model,
            finite: self.finite,
            grooves: self.grooves,
            arcs: self.arcs,
            lubricant: self.lubricant,
            supply_temperature: self.supply_temperature,
            thermal: self.thermal,
        }
    }

    /// Why the lubricant fields cannot be used (`viscosity` and `lubricant` both or
    /// neither given, `supply_temperature` missing or out of range), if so.
    pub fn lubricant_error(&self) -> Option<String> {
        self.raw_params().resolve_lubricant().err()
    }
}

/// How the rotor is supported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// Hydrodynamic film at every bearing (MODEL.md sections 1-8).
    #[default]
    Bearing,
    /// Ideal revolute joints: the shaft axis pinned to the bore axis; only the rotation
    /// about it is free (friction from the joint reactions, MODEL.md section 5).
    Ideal,
}

/// The spin about the bore axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpinMode {
    /// Free: only the loads (friction torques) act about the axis. Default.
    #[default]
    Free,
    /// Held: a drive torque about the global `z` axis keeps the global `z` component of
    /// the angular velocity at its initial value (an exact constraint torque).
    Held,
}

/// Initial state. The rotor starts as a rigid rotation about its shaft axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Angular velocity about the global `z` axis, rad/s (paper: 100).
    pub spin: f64,
    /// Rotation angle of the body about `z` at `t = 0`, rad. Default 0.
    #[serde(default)]
    pub angle: f64,
    /// Position of the shaft axis (its point level with `G`) relative to the bore axis,
    /// m. Default `[0, 0]` (journals centred). Bearing model only.
    #[serde(default)]
    pub offset: [f64; 2],
    /// Velocity of that shaft-axis point, m/s. Default `[0, 0]`. Bearing model only.
    #[serde(default)]
    pub velocity: [f64; 2],
    /// Tilt of the shaft axis: rotations about global `x` then `y`, rad. Default
    /// `[0, 0]`. Bearing model only.
    #[serde(default)]
    pub tilt: [f64; 2],
}

/// Integrator settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `"dopri5"` (default), `"radau5"`, `"auto"` (dopri5 switching stiff variants to radau5), `"rk4"`, `"dop853"` (order 8, for tight tolerances) `"radau9"` (implicit, order 9, for stiff films at tight tolerances) or `"bdf"` (variable-order BDF 1-5, one right-hand side per Newton iteration: the fewest instructions at equal error on the film-bearing rotor sweeps; its global error is larger than radau5's at the same `rtol`).
    #[serde(default)]
    pub method: Method,
    /// Relative tolerance of the local error. Default 1e-6.
    #[serde(default = "default_tol")]
    pub rtol: f64,
    /// Absolute tolerance in units of each component's natural scale (positions: the
    /// smallest clearance; velocities: clearance × |spin|; quaternion: 1; angular
    /// velocity: |spin|; work: kinetic energy). Default 1e-6.
    #[serde(default = "default_tol")]
    pub atol: f64,
    /// Simulated time, s (paper: 0.5).
    pub t_end: f64,
    /// Interval of the uniform output samples, s. Default 1e-4.
    #[serde(default = "default_sample")]
    pub sample_interval: f64,
    /// Fixed step, s: the step of `rk4` (default there: `sample_interval`); for the
    /// adaptive methods it switches error control off. Default none.
    #[serde(default)]
    pub fixed_step: Option<f64>,
    /// Largest step, s. Default none.
    #[serde(default)]
    pub max_step: Option<f64>,
    /// Accepted steps before the run stops with `max_steps`. Default 1e6.
    #[serde(default = "default_max_steps")]
    pub max_steps: u64,
}

/// Default `rtol = atol`: chosen from the work-precision study in BENCHMARKS.md ("Rotor
/// integration"): dopri5 at 1e-6 puts G within ~1.5e-10 m of the reference on the paper
/// example (1e-6 of its 1e-4 m orbit) for 1/3 fewer load evaluations than 1e-7.
fn default_tol() -> f64 {
    1e-6
}
fn default_sample() -> f64 {
    1e-4
}
fn default_max_steps() -> u64 {
    1_000_000
}

/// Film-breakdown handling (MODEL.md section 6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmSpec {
    /// Minimum film thickness below which the short-bearing film is not trusted, m.
    /// Without `contact` the variant then ends with status `film_breakdown`. Default 1e-6.
    #[serde(default = "default_threshold")]
    pub threshold: f64,
    /// With a contact model the run continues through breakdowns (each is reported in
    /// `film_events`). Default none (stop).
    #[serde(default)]
    pub contact: Option<ContactSpec>,
}

/// Penalty contact below the film threshold: at each journal end face whose film
/// `h = δ − |e|` is thinner than the threshold, a radial force
/// `max(0, k (threshold − h) + c ė_r)` pushes the journal end centre back toward the bore
/// axis (`ė_r` the radial velocity), applied with the film's end-point forces (so its
/// torque about `G` is exact too). The film loads keep acting (finite while `|e| < δ`);
/// no contact friction. A journal that still reaches the wall ends with `through_wall`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Penalty stiffness `k`, N/m.
    pub stiffness: f64,
    /// Penalty damping `c`, N·s/m. Default 0.
    #[serde(default)]
    pub damping: f64,
}

fn default_threshold() -> f64 {
    1e-6
}

impl Default for FilmSpec {
    fn default() -> Self {
        FilmSpec {
            threshold: default_threshold(),
            contact: None,
        }
    }
}

/// One simulation: everything [`crate::rotor::simulate_batch`] needs for one variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Name used for output folders and legends. Default `"scene"`.
    #[serde(default = "default_name")]
    pub name: String,
    /// `"bearing"` (default) or `"ideal"`.
    #[serde(default)]
    pub model: ModelKind,
    /// When loading a file: also run this scene with ideal joints, named `<name>-ideal`.
    /// Default false.
    #[serde(default)]
    pub compare_ideal: bool,
    /// Mass properties.
    pub rotor: RotorSpec,
    /// The bearings (at least one).
    pub bearings: Vec<BearingSpec>,
    /// Gravity vector, m/s² (global frame; the axial component is carried by the axial
    /// constraint). Default `[0, 0, 0]` (the paper's example has none).
    #[serde(default)]
    pub gravity: [f64; 3],
    /// `"free"` (default) or `"held"`.
    #[serde(default)]
    pub spin: SpinMode,
    /// Initial state.
    pub initial: InitialSpec,
    /// Integrator.
    pub integrator: IntegratorSpec,
    /// Film-breakdown threshold.
    #[serde(default)]
    pub film: FilmSpec,
    /// Model reductions (docs/cli.md "Model reductions"). Default: the exact ones on, the
    /// approximations off.
    #[serde(default)]
    pub reductions: super::simplifications::SimplificationSpec,
}

fn default_name() -> String {
    "scene".into()
}

/// A scene that cannot be simulated: the JSON path and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{path}: {reason}")]
pub struct SceneError {
    /// JSON path, e.g. `bearings[1].clearance`.
    pub path: String,
    /// What is wrong.
    pub reason: String,
}

fn err(path: impl Into<String>, reason: impl Into<String>) -> SceneError {
    SceneError {
        path: path.into(),
        reason: reason.into(),
    }
}

fn positive(path: &str, v: f64) -> Result<(), SceneError> {
    if !v.is_finite() {
        Err(err(path, format!("must be finite ({v})")))
    } else if v <= 0.0 {
        Err(err(path, format!("must be positive ({v})")))
    } else {
        Ok(())
    }
}

fn finite(path: &str, vs: &[f64]) -> Result<(), SceneError> {
    match vs.iter().position(|v| !v.is_finite()) {
        Some(k) if vs.len() > 1 => Err(err(format!("{path}[{k}]"), "must be finite")),
        Some(_) => Err(err(path, "must be finite")),
        None => Ok(()),
    }
}

impl Scene {
    /// Checks every field within the default memory budget (2 GiB); the error names the
    /// JSON path (relative to the scene) and why.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.validate_within(crate::budget::MemoryBudget::default())
    }

    /// [`Scene::validate`] within the memory budget `budget`.
    pub fn validate_within(&self, budget: crate::budget::MemoryBudget) -> Result<(), SceneError> {
        let r = &self.rotor;
        positive("rotor.mass", r.mass)?;
        for (k, &i) in r.inertia.iter().enumerate() {
            positive(&format!("rotor.inertia[{k}]"), i)?;
        }
        // No triangle-inequality check: the paper's own rotor, diag(0.01, 0.01, 0.3),
        // violates it (no real body has those principal moments), and the equations of
        // motion do not need it.
        finite("rotor.static_unbalance", &r.static_unbalance)?;
        finite("rotor.couple_unbalance", &r.couple_unbalance)?;
        if self.bearings.is_empty() {
            return Err(err("bearings", "at least one bearing is needed"));
        }
        for (k, bs) in self.bearings.iter().enumerate() {
            if let Some(reason) = bs.lubricant_error() {
                return Err(err(format!("bearings[{k}]"), reason));
            }
            bs.params().validate().map_err(|e| {
                err(
                    format!("bearings[{k}].{}", e.field),
                    format!("{} ({})", e.reason, e.value),
                )
            })?;
            finite(
                &format!("bearings[{k}].axial_position"),
                &[bs.axial_position],
            )?;
        }
        if self.model == ModelKind::Ideal && self.bearings.len() >= 2 {
            let z0 = self.bearings[0].axial_position;
            if self.bearings.iter().all(|b| b.axial_position == z0) {
                return Err(err(
                    "bearings",
                    "ideal joints need bearings at two different axial positions",
                ));
            }
        }
        finite("gravity", &self.gravity)?;
        let i = &self.initial;
        finite("initial.spin", &[i.spin])?;
        finite("initial.angle", &[i.angle])?;
        finite("initial.offset", &i.offset)?;
        finite("initial.velocity", &i.velocity)?;
        finite("initial.tilt", &i.tilt)?;
        if self.model == ModelKind::Ideal {
            for (name, v) in [
                ("offset", i.offset),
                ("velocity", i.velocity),
                ("tilt", i.tilt),
            ] {
                if v != [0.0, 0.0] {
                    return Err(err(
                        format!("initial.{name}"),
                        "must be [0, 0] with ideal joints (the shaft axis is pinned)",
                    ));
                }
            }
        }
        let g = &self.integrator;
        positive("integrator.rtol", g.rtol)?;
        positive("integrator.atol", g.atol)?;
        positive("integrator.t_end", g.t_end)?;
        positive("integrator.sample_interval", g.sample_interval)?;
        if g.sample_interval > g.t_end {
            return Err(err("integrator.sample_interval", "must not exceed t_end"));
        }
        if g.t_end / g.sample_interval > 1e7 {
            return Err(err(
                "integrator.sample_interval",
                "more than 1e7 samples: choose a longer interval",
            ));
        }
        // Samples are decimated to fit the budget (docs/cli.md "Limits"): only a scene whose
        // samples cannot fit even at the floor cap is refused.
        budget
            .check(
                &format!(
                    "keeping {} samples x {} bearings",
                    crate::budget::MIN_SAMPLE_CAP,
                    self.bearings.len()
                ),
                self.sample_memory_bytes(crate::budget::MIN_SAMPLE_CAP),
            )
            .map_err(|r| err("bearings", r))?;
        if let Some(h) = g.fixed_step {
            positive("integrator.fixed_step", h)?;
        }
        if let Some(h) = g.max_step {
            positive("integrator.max_step", h)?;
        }
        if g.max_steps == 0 {
            return Err(err("integrator.max_steps", "must be at least 1"));
        }
        let th = self.film.threshold;
        if !(th.is_finite() && th >= 0.0) {
            return Err(err(
                "film.threshold",
                format!("must be finite and >= 0 ({th})"),
            ));
        }
        for (k, bs) in self.bearings.iter().enumerate() {
            if th >= bs.clearance {
                return Err(err(
                    "film.threshold",
                    format!(
                        "must be smaller than bearings[{k}].clearance ({})",
                        bs.clearance
                    ),
                ));
            }
        }
        if let Some(c) = &self.film.contact {
            positive("film.contact.stiffness", c.stiffness)?;
            if !(c.damping.is_finite() && c.damping >= 0.0) {
                return Err(err(
                    "film.contact.damping",
                    format!("must be finite and >= 0 ({})", c.damping),
                ));
            }
        }
        self.reductions
            .validate()
            .map_err(|(field, reason)| err(format!("reductions.{field}"), reason))?;
        // The initial journals must be inside their bores with a film above threshold.
        if self.model == ModelKind::Bearing {
            let model = super::model::RotorModel::new(self);
            let y0 = model.initial_state(self);
            for (k, (hmin, bs)) in model
                .initial_film(&y0)
                .iter()
                .zip(&self.bearings)
                .enumerate()
            {
                if *hmin <= th {
                    return Err(err(
                        "initial",
                        format!(
                            "the journal in bearings[{k}] starts with film {hmin:e} m, not above film.threshold {th:e} m (clearance {})",
                            bs.clearance
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

impl Scene {
    /// Estimated memory of this scene's kept samples with at most `cap` kept, bytes:
    /// kept samples × numbers per sample (t, x_g, y_g, spin, energy, work, ten per
    /// bearing) × measured bytes per number.
    pub fn sample_memory_bytes(&self, cap: usize) -> f64 {
        let g = &self.integrator;
        let samples = ((g.t_end / g.sample_interval).floor() + 1.0).min(cap as f64);
        let numbers = super::simulate::numbers_per_sample(self) as f64;
        samples * numbers * crate::budget::BYTES_PER_SAMPLED_NUMBER as f64
    }
}

/// Loads a scene file: one scene object, or `{"scenes": [...]}`. A scene with
/// `compare_ideal: true` yields two: itself (model `bearing`) and `<name>-ideal`.
/// Errors name the JSON path (`scenes[2].bearings[1].clearance: must be positive`).
/// Checked within the default memory budget (2 GiB).
pub fn load_scene(json: &str) -> Result<Vec<Scene>, SceneError> {
    load_scene_within(json, crate::budget::MemoryBudget::default())
}

/// [`load_scene`] within the memory budget `budget`.
pub fn load_scene_within(
    json: &str,
    budget: crate::budget::MemoryBudget,
) -> Result<Vec<Scene>, SceneError> {
    let doc = crate::json::parse_json(json).map_err(|e| err(e.path, e.reason))?;
    let (items, prefix): (Vec<&serde_json::Value>, bool) = match doc.get("scenes") {
        Some(serde_json::Value::Array(list)) if doc.as_object().is_some_and(|o| o.len() == 1) => {
            (list.iter().collect(), true)
        }
        Some(serde_json::Value::Array(_)) => {
            return Err(err("$", "a file with `scenes` holds nothing else"))
        }
        Some(_) => return Err(err("scenes", "expected an array of scenes")),
        None => (vec![&doc], false),
    };
    if items.is_empty() {
        return Err(err("scenes", "no scenes"));
    }
    let mut out = Vec::new();
    for (k, item) in items.into_iter().enumerate() {
        let path = |p: &str| {
            if prefix {
                format!("scenes[{k}].{p}")
            } else {
                p.to_string()
            }
        };
        let scene: Scene = crate::json::deserialize_at(item).map_err(|(at, reason)| {
            let base = if prefix {
                format!("scenes[{k}]")
            } else {
                "$".into()
            };
            err(crate::json::join_path(&base, &at), reason)
        })?;
        scene
            .validate_within(budget)
            .map_err(|e| err(path(&e.path), e.reason))?;
        if scene.compare_ideal {
            let mut ideal = scene.clone();
            ideal.model = ModelKind::Ideal;
            ideal.compare_ideal = false;
            ideal.name = format!("{}-ideal", scene.name);
            ideal.validate_within(budget).map_err(|e| {
                err(
                    path(&e.path),
                    format!("{} (in the ideal-joint comparison)", e.reason),
                )
            })?;
            let mut bearing = scene;
            bearing.compare_ideal = false;
            bearing.model = ModelKind::Bearing;
            out.push(bearing);
            out.push(ideal);
        } else {
            out.push(scene);
        }
    }
    Ok(out)
}
