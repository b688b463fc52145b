//! Model simplifications, the user's "model reductions" (docs/cli.md "Model reductions";
//! the scene's `reductions` block and the `model_reductions` reports keep their JSON
//! names): what a scene may skip, the bound each one is held to, and the report of what
//! every run applied and declined. In Rust "reductions" are only the signal reductions of
//! a sweep (`sweep::reduce`).
//!
//! Exact reductions (on by default): identical kernel inputs integrated once per call and
//! tiny calls run on the CPU instead of a GPU round trip ([`crate::backend::EvaluatorOptions`]),
//! and the rule's one-slice path for aligned journals (always on, [`crate::bearing::FilmRule`]).
//! Approximations (off by default, each only under a bound):
//!
//! - **Squeeze drop** (the paper's high-speed simplification): the rate vector of eq. (5)
//!   at each end face is `r = ω ε + 2 (−Ẏ, Ẋ)`; dropping the squeeze part leaves
//!   `r_rot = ω ε`. The slice loads are Lipschitz in `r` (the integrand `sin(ψ − β)`
//!   vanishes at the loaded arc's ends, so moving the arc adds no boundary term) and
//!   homogeneous of degree one, so the relative load error is at most
//!   `C(ε) ρ` with `ρ` the squeeze rate over the smallest rotational rate along the bearing
//!   ([`squeeze_ratio`]). [`squeeze_error_estimate`] uses
//!   `C(ε) = SQUEEZE_GAIN / (1 − ε²)` (ε the larger end ratio), the gain measured on
//!   random states in `tests/model_reductions.rs` with a safety factor.
//! - **Near-aligned tilt**: checked and declined; see [`TILT_DECLINE_REASON`].
//! - **Constant friction coefficient**: checked and declined; see
//!   [`FRICTION_DECLINE_REASON`].

use serde::{Deserialize, Serialize};

use crate::backend::{EvalStats, EvaluatorOptions, DEFAULT_CPU_BELOW};
use crate::bearing::finite::ERROR_MAP_ECC;
use crate::bearing::{BearingParams, BearingState};

/// Gain of the squeeze-drop error estimate: the largest measured
/// `relative load error × (1 − ε²) / ρ` over random states (tests/model_reductions.rs:
/// 1.65 at the worst of 3900 aligned and tilted states on three geometries, ε up to 0.95,
/// ρ from 1e-4 to 0.3) rounded up with a safety factor of about 2.4.
pub const SQUEEZE_GAIN: f64 = 4.0;

/// Why near-aligned tilt is never applied.
pub const TILT_DECLINE_REASON: &str =
    "no tight bound: evaluating a tilted journal at its mid-plane \
values loses the tilting stiffness; the force error is second order in the tilt (the odd term \
∫ s(1−s)(s−½) ds vanishes) but the moment error is first order (∫ s²(1−s)(s−½) ds = 1/120 ≠ 0), \
amplified like 1/(1−ε²) near the wall (tests/model_reductions.rs measures both orders); \
a first-order bound on the moments would need the load gradient, which costs more than the \
full rule saves";

/// Why the constant friction coefficient is never applied.
pub const FRICTION_DECLINE_REASON: &str = "no work to save: the friction coefficient is a closed \
form of |W| and ω per state (eq. 11, ~20 flops of ~11 000 per state), so freezing it only adds \
error; the check reports how far the exact f moved after the settling window, i.e. the error a \
frozen f would have cost";

/// Squeeze drop settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SqueezeDropSpec {
    /// Drop the squeeze term where the estimate allows. Default false.
    #[serde(default)]
    pub enabled: bool,
    /// Bound on the estimated relative load error per evaluation. Default 1e-3.
    #[serde(default = "default_squeeze_bound")]
    pub bound: f64,
}

fn default_squeeze_bound() -> f64 {
    1e-3
}

impl Default for SqueezeDropSpec {
    fn default() -> Self {
        SqueezeDropSpec {
            enabled: false,
            bound: default_squeeze_bound(),
        }
    }
}

/// Near-aligned tilt check settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NearAlignedSpec {
    /// Ask for the reduction (it is declined; the check still runs and reports). Default
    /// false.
    #[serde(default)]
    pub enabled: bool,
    /// Tilt bound: `max(|ε_j − ε_i| / |ε_m|, |r_j − r_i| / |r_m|)` below which a journal
    /// counts as near-aligned. Default 1e-3.
    #[serde(default = "default_tilt_bound")]
    pub tilt_bound: f64,
}

fn default_tilt_bound() -> f64 {
    1e-3
}

impl Default for NearAlignedSpec {
    fn default() -> Self {
        NearAlignedSpec {
            enabled: false,
            tilt_bound: default_tilt_bound(),
        }
    }
}

/// Constant friction coefficient check settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantFrictionSpec {
    /// Ask for the reduction (it is declined; the check runs on held-spin scenes and
    /// reports). Default false.
    #[serde(default)]
    pub enabled: bool,
    /// Settling window from `t = 0`, s, after which f would be frozen. Default 0.05.
    #[serde(default = "default_settle")]
    pub settle_time: f64,
    /// Bound on the relative deviation of the exact f from the frozen one. Default 1e-2.
    #[serde(default = "default_friction_bound")]
    pub bound: f64,
}

fn default_settle() -> f64 {
    0.05
}
fn default_friction_bound() -> f64 {
    1e-2
}

impl Default for ConstantFrictionSpec {
    fn default() -> Self {
        ConstantFrictionSpec {
            enabled: false,
            settle_time: default_settle(),
            bound: default_friction_bound(),
        }
    }
}

/// The scene's `reductions` block.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
// The name serde's messages quote (`expected struct ReductionSpec`) stays as it was.
#[serde(deny_unknown_fields, expecting = "struct ReductionSpec")]
pub struct SimplificationSpec {
    /// Integrate identical kernel inputs once per evaluator call (exact). Default true.
    #[serde(default = "yes")]
    pub dedupe: bool,
    /// With a GPU backend, calls with fewer distinct states run on the CPU (exact).
    /// Default [`DEFAULT_CPU_BELOW`]; 0 turns it off.
    #[serde(default = "default_cpu_below")]
    pub small_batch_cpu_below: usize,
    /// Squeeze drop (approximation, off by default).
    #[serde(default)]
    pub squeeze_drop: SqueezeDropSpec,
    /// Near-aligned tilt (checked, declined).
    #[serde(default)]
    pub near_aligned: NearAlignedSpec,
    /// Constant friction coefficient (checked, declined).
    #[serde(default)]
    pub constant_friction: ConstantFrictionSpec,
}

fn yes() -> bool {
    true
}
fn default_cpu_below() -> usize {
    DEFAULT_CPU_BELOW
}

impl Default for SimplificationSpec {
    fn default() -> Self {
        SimplificationSpec {
            dedupe: true,
            small_batch_cpu_below: DEFAULT_CPU_BELOW,
            squeeze_drop: SqueezeDropSpec::default(),
            near_aligned: NearAlignedSpec::default(),
            constant_friction: ConstantFrictionSpec::default(),
        }
    }
}

impl SimplificationSpec {
    /// Everything off (`--full-model`).
    pub fn full() -> Self {
        SimplificationSpec {
            dedupe: false,
            small_batch_cpu_below: 0,
            squeeze_drop: SqueezeDropSpec {
                enabled: false,
                ..SqueezeDropSpec::default()
            },
            near_aligned: NearAlignedSpec {
                enabled: false,
                ..NearAlignedSpec::default()
            },
            constant_friction: ConstantFrictionSpec {
                enabled: false,
                ..ConstantFrictionSpec::default()
            },
        }
    }

    /// Whether every reduction is off.
    pub fn is_full(&self) -> bool {
        *self == Self::full()
    }

    /// Checks bounds; errors name the field under `reductions`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((name.to_string(), format!("must be a positive number ({v})")))
            }
        };
        pos("squeeze_drop.bound", self.squeeze_drop.bound)?;
        pos("near_aligned.tilt_bound", self.near_aligned.tilt_bound)?;
        pos("constant_friction.bound", self.constant_friction.bound)?;
        if !(self.constant_friction.settle_time.is_finite()
            && self.constant_friction.settle_time >= 0.0)
        {
            return Err((
                "constant_friction.settle_time".into(),
                format!(
                    "must be a non-negative number ({})",
                    self.constant_friction.settle_time
                ),
            ));
        }
        Ok(())
    }
}

/// Evaluator options for a set of scenes sharing one evaluator: dedupe only if every scene
/// allows it, the smallest crossover.
pub fn evaluator_options<'a>(
    specs: impl IntoIterator<Item = &'a SimplificationSpec>,
) -> EvaluatorOptions {
    let mut o = EvaluatorOptions::default();
    for s in specs {
        o.dedupe &= s.dedupe;
        o.cpu_below = o.cpu_below.min(s.small_batch_cpu_below);
    }
    o
}

/// `ρ = max_end |2 (−Ẏ, Ẋ)| / (|ω| min_z |ε(z)|)`: the squeeze rate against the smallest
/// rotational rate anywhere along the bearing (ε is linear in z, so its smallest modulus
/// is the distance from the origin to the segment `ε_i ε_j`; a conical whirl through the
/// bore axis has a point with no rotational rate, ρ infinite there). Also returns the larger
/// end eccentricity ratio.
pub fn squeeze_ratio(params: &BearingParams, s: &BearingState) -> (f64, f64) {
    let d = params.clearance;
    let ei = [s.xi / d, s.yi / d];
    let ej = [s.xj / d, s.yj / d];
    let eps = ei[0].hypot(ei[1]).max(ej[0].hypot(ej[1]));
    let sq = (2.0 / d) * s.vxi.hypot(s.vyi).max(s.vxj.hypot(s.vyj));
    if sq == 0.0 {
        return (0.0, eps);
    }
    // Distance from the origin to the segment.
    let e = [ej[0] - ei[0], ej[1] - ei[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = if len2 > 0.0 {
        (-(ei[0] * e[0] + ei[1] * e[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let min_e = (ei[0] + t * e[0]).hypot(ei[1] + t * e[1]);
    let rot = s.omega.abs() * min_e;
    let rho = if rot > 0.0 { sq / rot } else { f64::INFINITY };
    (rho, eps)
}

/// Estimated relative load error of dropping the squeeze term: `SQUEEZE_GAIN ρ / (1 − ε²)`.
pub fn squeeze_error_estimate(params: &BearingParams, s: &BearingState) -> f64 {
    let (rho, eps) = squeeze_ratio(params, s);
    if rho == 0.0 {
        return 0.0;
    }
    SQUEEZE_GAIN * rho / (1.0 - eps * eps).max(0.0)
}

/// The state with its squeeze term dropped (end velocities zero).
pub fn without_squeeze(s: &BearingState) -> BearingState {
    BearingState {
        vxi: 0.0,
        vyi: 0.0,
        vxj: 0.0,
        vyj: 0.0,
        ..*s
    }
}

/// Tilt measure `max(|ε_j − ε_i| / |ε_m|, |r_j − r_i| / |r_m|)` (ε, r the eccentricity
/// and rate vectors at the end faces, m the mid-plane means); 0 for an aligned journal.
pub fn tilt_measure(params: &BearingParams, s: &BearingState) -> f64 {
    let d = params.clearance;
    let w = s.omega;
    let ei = [s.xi / d, s.yi / d];
    let ej = [s.xj / d, s.yj / d];
    let ri = [w * ei[0] - 2.0 * s.vyi / d, w * ei[1] + 2.0 * s.vxi / d];
    let rj = [w * ej[0] - 2.0 * s.vyj / d, w * ej[1] + 2.0 * s.vxj / d];
    let rel = |a: [f64; 2], b: [f64; 2]| {
        let diff = (b[0] - a[0]).hypot(b[1] - a[1]);
        let mean = (0.5 * (a[0] + b[0])).hypot(0.5 * (a[1] + b[1]));
        if diff == 0.0 {
            0.0
        } else if mean > 0.0 {
            diff / mean
        } else {
            f64::INFINITY
        }
    };
    rel(ei, ej).max(rel(ri, rj))
}

/// Per-variant tallies, accumulated as the film is evaluated.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimplificationTally {
    /// Film states evaluated.
    pub states: u64,
    /// States evaluated without squeeze.
    pub squeeze_dropped: u64,
    /// Largest estimated error among them.
    pub squeeze_max_estimate: f64,
    /// States where the estimate exceeded the bound (full model used).
    pub squeeze_declined: u64,
    /// States without a squeeze term (nothing to drop).
    pub squeeze_absent: u64,
    /// States whose tilt measure was below the bound.
    pub near_aligned: u64,
    /// Largest tilt measure seen.
    pub tilt_max: f64,
    /// States evaluated with the short-bearing film (`"model": "short"`, or `"auto"`
    /// below its tolerance).
    pub short_states: u64,
    /// States evaluated with the finite-length film.
    pub finite_states: u64,
    /// Largest short-model load error from the model-error map over the short-model
    /// states (docs/finite-film.md), relative, and the attitude error there (deg).
    pub short_error_max: f64,
    /// Attitude error of the short model at that state, degrees.
    pub short_attitude_at_max: f64,
    /// `(B/D, ε)` of that state.
    pub short_error_at: (f64, f64),
    /// Whether that state lay outside the stored map (edge value used).
    pub short_error_extrapolated: bool,
    /// The largest end eccentricity ratio looked up so far per bearing aspect ratio, for
    /// skipping look-ups that cannot raise [`SimplificationTally::short_error_max`].
    short_seen: ShortSeen,
}

/// Capacity of [`ShortSeen`]: distinct `B/D` of a variant's bearings tracked (a variant
/// with more bearing geometries looks every further one up, as before).
const SHORT_SEEN_SLOTS: usize = 4;

/// The model-error map's load error strictly increases with `ε` up to the map's last
/// eccentricity at every positive `B/D` (every row of the map does;
/// `tests/rotor_tally_skip.rs` checks it): past it the map's edge value is used, so the
/// load error is flat there.
const MAP_LAST_ECC: f64 = ERROR_MAP_ECC[ERROR_MAP_ECC.len() - 1];

/// Eccentricity margin of the skip: a look-up is skipped only when its `ε` is this much
/// below the largest one seen. The map's smallest slope is 1.8e-3 per unit `ε` (the
/// `B/D = 0.1` row from `ε` 0 to 0.1), so the skipped state's load error is below the
/// seen one by at least 1.8e-12 × the aspect scale, far above the look-up's rounding
/// (~1e-15 of values below 10): the comparison `>=` of the full look-up could not have
/// taken it.
const SKIP_MARGIN: f64 = 1e-9;

/// Per aspect ratio `B/D` (its bits), the largest end eccentricity ratio whose short-model
/// error was looked up.
#[derive(Clone, Copy, Debug, Default)]
struct ShortSeen {
    len: usize,
    bd_bits: [u64; SHORT_SEEN_SLOTS],
    e_max: [f64; SHORT_SEEN_SLOTS],
    /// The last skip threshold [`ShortSeen::may_raise`] worked out: the bits of the
    /// bearing's `(length, radius, clearance)` it is for, and the squared end radius below
    /// which a state is skipped (`−∞`: never). Cleared whenever [`ShortSeen::seen`] records
    /// a look-up. A rotor's stage calls alternate few geometries (one, in the workloads of
    /// issue 28), so most states reuse it instead of working out `B/D` (a division), its
    /// slot and the threshold again (~60 of the tally's ~105 instructions a state on
    /// grid9, BENCHMARKS.md "Issue 28, ninth pass"). The same verdicts: the threshold is
    /// the same expression of the same inputs.
    threshold: Option<([u64; 3], f64)>,
}

/// Equal when the looked-up maxima are (the cached threshold is derived from them).
impl PartialEq for ShortSeen {
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && self.bd_bits == other.bd_bits && self.e_max == other.e_max
    }
}

impl ShortSeen {
    /// Whether a state with end centres `(xi, yi)`, `(xj, yj)` (m) in a bearing of aspect
    /// `bd` and clearance `c` (m) has a larger end eccentricity than `ε_lim − margin`,
    /// `ε_lim = min(largest seen, MAP_LAST_ECC)`: only then can its load error reach the
    /// largest so far (the map strictly increases in `ε` below `MAP_LAST_ECC` at a fixed
    /// positive `B/D`). Squared radii instead of `hypot`, with a relative margin of 1e-12
    /// that covers their rounding.
    #[inline(always)]
    fn may_raise(&mut self, params: &BearingParams, s: &BearingState) -> bool {
        let key = [
            params.length.to_bits(),
            params.radius.to_bits(),
            params.clearance.to_bits(),
        ];
        let skip_below = match self.threshold {
            Some((k, v)) if k == key => v,
            _ => {
                let v = self.skip_below(params.length / (2.0 * params.radius), params.clearance);
                self.threshold = Some((key, v));
                v
            }
        };
        let r2 = (s.xi * s.xi + s.yi * s.yi).max(s.xj * s.xj + s.yj * s.yj);
        // NaN compares false: looked up.
        let below = r2 < skip_below;
        !below
    }

    /// The squared end radius (m²) below which a state in a bearing of aspect `bd` and
    /// clearance `c` (m) cannot raise the maximum: `lim² (1 − 1e-12)`, `lim = (ε_lim −
    /// margin) c`; `−∞` where nothing is skipped (no look-up at this aspect yet, or
    /// unusable `bd`, `c`).
    // Out of line: worked out only when the geometry changes.
    #[inline(never)]
    fn skip_below(&self, bd: f64, c: f64) -> f64 {
        if !(bd > 0.0 && bd.is_finite() && c > 0.0 && c.is_finite()) {
            return f64::NEG_INFINITY;
        }
        let Some(k) = (0..self.len).find(|&k| self.bd_bits[k] == bd.to_bits()) else {
            return f64::NEG_INFINITY;
        };
        let lim = (self.e_max[k].min(MAP_LAST_ECC) - SKIP_MARGIN) * c;
        if lim <= 0.0 {
            return f64::NEG_INFINITY;
        }
        lim * lim * (1.0 - 1e-12)
    }

    /// Records a looked-up eccentricity `e` for aspect `bd`.
    fn seen(&mut self, bd: f64, e: f64) {
        self.threshold = None;
        let bits = bd.to_bits();
        if let Some(k) = (0..self.len).find(|&k| self.bd_bits[k] == bits) {
            self.e_max[k] = self.e_max[k].max(e);
        } else if self.len < SHORT_SEEN_SLOTS {
            self.bd_bits[self.len] = bits;
            self.e_max[self.len] = e;
            self.len += 1;
        }
    }
}

impl SimplificationTally {
    /// Applies the squeeze drop to `state` where allowed and tallies the checks.
    // The common case inlined into the film pass (counters and the skip test), the
    // look-up and the reductions' checks out of line: as one call the tally saved and
    // restored its registers on every state, ~90 instructions a state on grid9 where
    // ~30 remain (issue 28's thirteenth pass). The same checks in the same order.
    #[inline(always)]
    pub fn observe(
        &mut self,
        spec: &SimplificationSpec,
        params: &BearingParams,
        state: &mut BearingState,
    ) {
        self.states += 1;
        if crate::backend::effective_model(params, state) == crate::bearing::FilmModel::Finite {
            self.finite_states += 1;
        } else {
            self.short_states += 1;
            // The look-up (two `hypot`s and a bilinear map) was 7 % of a rotor run's
            // instructions (BENCHMARKS.md "Issue 28, eighth pass"); a state less eccentric
            // than one already looked up at the same B/D cannot raise the maximum.
            if self.short_seen.may_raise(params, state) {
                self.look_up_short_error(params, state);
            }
        }
        if spec.near_aligned.enabled || spec.squeeze_drop.enabled {
            self.observe_reductions(spec, params, state);
        }
    }

    /// The short model's mapped error at `state`, kept if it is the largest so far.
    #[inline(never)]
    fn look_up_short_error(&mut self, params: &BearingParams, state: &BearingState) {
        let bd = params.length / (2.0 * params.radius);
        let (ei, ej) = state.eccentricity_ratios(params.clearance);
        let e = crate::bearing::finite::short_model_error(bd, ei.max(ej));
        self.short_seen.seen(bd, ei.max(ej));
        if e.load.abs() >= self.short_error_max {
            self.short_error_max = e.load.abs();
            self.short_attitude_at_max = e.attitude_deg;
            self.short_error_at = (bd, ei.max(ej));
            self.short_error_extrapolated = e.extrapolated;
        }
    }

    /// The near-aligned check and the squeeze drop, where `spec` enables them.
    #[inline(never)]
    fn observe_reductions(
        &mut self,
        spec: &SimplificationSpec,
        params: &BearingParams,
        state: &mut BearingState,
    ) {
        if spec.near_aligned.enabled {
            let t = tilt_measure(params, state);
            self.tilt_max = self.tilt_max.max(t);
            if t < spec.near_aligned.tilt_bound {
                self.near_aligned += 1;
            }
        }
        if spec.squeeze_drop.enabled {
            let est = squeeze_error_estimate(params, state);
            if est == 0.0 {
                // No squeeze term: nothing to drop.
                self.squeeze_absent += 1;
            } else if est <= spec.squeeze_drop.bound {
                *state = without_squeeze(state);
                self.squeeze_dropped += 1;
                self.squeeze_max_estimate = self.squeeze_max_estimate.max(est);
            } else {
                self.squeeze_declined += 1;
            }
        }
    }
}

/// One reduction's line in a report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimplificationEntry {
    /// Reduction name.
    pub name: String,
    /// `"exact"` or `"bounded"`.
    pub kind: String,
    /// States (or calls, see `unit`) it was applied to.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub applied_to: Option<u64>,
    /// Of how many.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub of: Option<u64>,
    /// What `applied_to` counts.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
    /// The error bound in force (relative).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub bound: Option<f64>,
    /// The largest estimated or measured error (relative).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<f64>,
    /// Why it was applied or declined, and its effect.
    pub why: String,
}

/// What a run applied and declined.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimplificationReport {
    /// `--full-model` was given.
    pub full_model: bool,
    /// Applied reductions.
    pub applied: Vec<SimplificationEntry>,
    /// Declined reductions.
    pub declined: Vec<SimplificationEntry>,
    /// The film model's own error: how far the short-bearing film may be from the
    /// finite-length Reynolds equation at the eccentricity this run reached (from the
    /// model-error map, docs/finite-film.md). Not a reduction `--full-model` turns off:
    /// the bearing's `"model"` chooses the film.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub film_model_error: Option<SimplificationEntry>,
}

fn entry(name: &str, kind: &str, why: impl Into<String>) -> SimplificationEntry {
    SimplificationEntry {
        name: name.into(),
        kind: kind.into(),
        applied_to: None,
        of: None,
        unit: None,
        bound: None,
        error: None,
        why: why.into(),
    }
}

/// The per-variant part: squeeze, tilt and friction. `friction_dev`: the largest relative
/// deviation of the exact friction coefficient from its value at the end of the settling
/// window (held spin), `None` where the check does not apply.
pub fn variant_report(
    spec: &SimplificationSpec,
    full_model: bool,
    tally: &SimplificationTally,
    held_spin: bool,
    friction_dev: Option<f64>,
) -> SimplificationReport {
    let mut r = SimplificationReport {
        full_model,
        ..Default::default()
    };
    let off = |what: &str| {
        if full_model {
            "full model (--full-model, or every reduction off in the scene)".to_string()
        } else {
            format!("not enabled in the scene (reductions.{what}.enabled)")
        }
    };
    // Squeeze drop.
    if spec.squeeze_drop.enabled {
        let mut e = entry(
            "squeeze_drop",
            "bounded",
            format!(
                "squeeze term dropped where the estimate {SQUEEZE_GAIN} ρ/(1−ε²) <= bound \
                 ({} states kept the full model, {} had no squeeze term); effect: no squeeze damping in those \
                 evaluations, so the dynamics differ even where each load is within the bound",
                tally.squeeze_declined, tally.squeeze_absent
            ),
        );
        e.applied_to = Some(tally.squeeze_dropped);
        e.of = Some(tally.states);
        e.unit = Some("film states".into());
        e.bound = Some(spec.squeeze_drop.bound);
        e.error = Some(tally.squeeze_max_estimate);
        if tally.squeeze_dropped > 0 {
            r.applied.push(e);
        } else {
            e.why = format!(
                "enabled, but no state met the bound ({} states checked)",
                tally.squeeze_declined
            );
            r.declined.push(e);
        }
    } else {
        r.declined.push(entry(
            "squeeze_drop",
            "bounded",
            format!(
                "{}; default off: it removes squeeze damping",
                off("squeeze_drop")
            ),
        ));
    }
    // Near-aligned tilt.
    let mut e = entry("near_aligned_tilt", "bounded", TILT_DECLINE_REASON);
    if spec.near_aligned.enabled {
        e.applied_to = Some(0);
        e.of = Some(tally.states);
        e.unit = Some(format!(
            "film states ({} had tilt below the bound; largest tilt {:.3e})",
            tally.near_aligned, tally.tilt_max
        ));
        e.bound = Some(spec.near_aligned.tilt_bound);
    } else {
        e.why = format!("{}; and {}", off("near_aligned"), TILT_DECLINE_REASON);
    }
    r.declined.push(e);
    // Constant friction.
    let mut e = entry("constant_friction", "bounded", FRICTION_DECLINE_REASON);
    if spec.constant_friction.enabled {
        e.bound = Some(spec.constant_friction.bound);
        match (held_spin, friction_dev) {
            (false, _) => e.why = format!("free spin: the paper's condition (constant speed) does not hold; {FRICTION_DECLINE_REASON}"),
            (true, None) => e.why = format!("no samples after the settling window; {FRICTION_DECLINE_REASON}"),
            (true, Some(d)) => {
                e.error = Some(d);
                e.why = format!(
                    "{}; a frozen f would have been {} the bound",
                    FRICTION_DECLINE_REASON,
                    if d <= spec.constant_friction.bound { "within" } else { "outside" }
                );
            }
        }
    } else {
        e.why = format!(
            "{}; and {}",
            off("constant_friction"),
            FRICTION_DECLINE_REASON
        );
    }
    r.declined.push(e);
    r.push_short_model(tally);
    r
}

impl SimplificationReport {
    /// The short-bearing film as a model reduction of the full Reynolds equation: the
    /// error it exposes the run to, from the model-error map at each bearing's `B/D` and
    /// the eccentricity the run reached (docs/finite-film.md "Model-error map").
    fn push_short_model(&mut self, tally: &SimplificationTally) {
        if tally.short_states + tally.finite_states == 0 {
            return;
        }
        let (bd, ecc) = tally.short_error_at;
        let mut e = entry(
            "short_bearing_model",
            "bounded",
            if tally.short_states > 0 {
                format!(
                    "short-bearing (Ocvirk) film instead of the finite-length Reynolds equation: \
                     model-error map (aligned, steady) at B/D = {bd:.3} and the largest \
                     eccentricity reached, ε = {ecc:.3}: load magnitude {:+.1} %, attitude \
                     {:+.2}°{}; `\"model\": \"finite\"` or `\"auto\"` in the bearing removes it",
                    100.0 * tally.short_error_max,
                    tally.short_attitude_at_max,
                    if tally.short_error_extrapolated {
                        " (outside the map: its edge value)"
                    } else {
                        ""
                    }
                )
            } else {
                "every film state was evaluated with the finite-length Reynolds equation".into()
            },
        );
        e.applied_to = Some(tally.short_states);
        e.of = Some(tally.short_states + tally.finite_states);
        e.unit = Some("film states evaluated with the short-bearing model".into());
        if tally.short_states > 0 {
            e.error = Some(tally.short_error_max);
        }
        self.film_model_error = Some(e);
    }
}

/// The evaluator-level part: dedupe and small-batch CPU routing.
pub fn evaluator_report(
    options: &EvaluatorOptions,
    stats: &EvalStats,
    gpu: bool,
    full_model: bool,
) -> SimplificationReport {
    let mut r = SimplificationReport {
        full_model,
        ..Default::default()
    };
    let mut e = entry(
        "dedupe",
        "exact",
        "identical kernel inputs (identical bearings in identical states) integrated once per call",
    );
    e.applied_to = Some(stats.deduplicated);
    e.of = Some(stats.states);
    e.unit = Some("states served from an identical state's integrals".into());
    e.error = Some(0.0);
    if options.dedupe {
        r.applied.push(e);
    } else {
        e.why = if full_model {
            "--full-model".into()
        } else {
            "reductions.dedupe is false".into()
        };
        r.declined.push(e);
    }
    let mut e = entry(
        "small_batch_cpu",
        "exact",
        format!(
            "calls with fewer than {} distinct states run the same rule on the CPU instead of a GPU round trip",
            options.cpu_below
        ),
    );
    e.applied_to = Some(stats.small_batch_cpu_calls);
    e.of = Some(stats.calls);
    e.unit = Some(format!(
        "evaluator calls ({} states)",
        stats.small_batch_cpu_states
    ));
    e.error = Some(0.0);
    if gpu && options.cpu_below > 0 {
        r.applied.push(e);
    } else {
        e.why = if !gpu {
            "the backend is the CPU".into()
        } else if full_model {
            "--full-model".into()
        } else {
            "reductions.small_batch_cpu_below is 0".into()
        };
        r.declined.push(e);
    }
    r.applied.push(entry(
        "aligned_one_slice",
        "exact",
        "aligned journals (ε and r equal at both ends) use the exact z-integral of eq. (3) with one slice (always on: exact)",
    ));
    r
}
