//! From a dimensional bearing state to the kernel's packed input, and from the kernel's
//! film integrals back to loads, friction and film thickness.

use serde::Serialize;

use super::film_flow::{short_film_flow, FilmFlow, FrictionLaw};
use super::friction::FrictionConstants;
use super::rule::{FilmIntegrals, FilmRule, PackedState};
use super::{BearingParams, BearingState, StateFault};

/// Everything the film exerts on the journal for one state (MODEL.md sections 4-6). SI.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Loads {
    /// Film force on the journal along x, N.
    pub wx: f64,
    /// Film force on the journal along y, N.
    pub wy: f64,
    /// Film moment on the journal about x, about the bore centre of the face `z = 0`, N·m.
    pub mx: f64,
    /// Film moment about y, N·m.
    pub my: f64,
    /// Friction torque about `+z`, N·m (opposes the relative spin).
    pub mz: f64,
    /// Friction coefficient; `null` where infinite or undefined (MODEL.md section 5).
    pub friction_coefficient: Option<f64>,
    /// Sommerfeld number; `null` where infinite (`ω0 = 0`).
    pub sommerfeld: Option<f64>,
    /// Minimum film thickness, m.
    pub h_min: f64,
    /// Friction power loss `|M_z ω0|`, W.
    pub power_loss: f64,
    /// Which law produced `mz`, `friction_coefficient` and `power_loss`: `"paper"`
    /// (eqs. 10-11, the default and today the only one these fields take; the film's own
    /// friction is in `film`).
    pub friction_model: FrictionLaw,
    /// Film friction (shear stress over the film) and flow: side flow at both ends and
    /// the inlet flow (issue 24; [`crate::bearing::film_flow`]). Short film: closed forms;
    /// finite film: from the converged pressure field.
    pub film: FilmFlow,
}

impl Loads {
    /// The load vector `(W_x, W_y, M_x/B, M_y/B)` in which accuracy is measured.
    pub fn load_vector(&self, length_m: f64) -> [f64; 4] {
        [self.wx, self.wy, self.mx / length_m, self.my / length_m]
    }

    /// `self` if every number in it is finite, else the overflow fault naming the first
    /// non-finite output (finite inputs cannot give NaN; enormous ones can overflow).
    pub fn finite_or_fault(self) -> Result<Loads, StateFault> {
        match self.fault() {
            None => Ok(self),
            Some(fault) => Err(fault),
        }
    }

    /// [`Loads::finite_or_fault`]'s verdict without moving the loads: `None` if every
    /// number is finite, else the overflow fault naming the first non-finite output.
    // Inlined into the evaluator's loop (issue 28's ninth pass), the named list kept out
    // of line.
    #[inline]
    pub fn fault(&self) -> Option<StateFault> {
        // `0 · x` is ±0 for a finite `x` and NaN for ±∞ or NaN, so the sum is 0 exactly
        // when all are finite: one branch for the common case (every load of a rotor run),
        // the fields named only for a failing load (building the named list first cost
        // ~60 more instructions a load, BENCHMARKS.md "Issue 28, eighth pass").
        let film = &self.film;
        let zero = 0.0 * self.wx
            + 0.0 * self.wy
            + 0.0 * self.mx
            + 0.0 * self.my
            + 0.0 * self.mz
            + 0.0 * self.friction_coefficient.unwrap_or(0.0)
            + 0.0 * self.sommerfeld.unwrap_or(0.0)
            + 0.0 * self.h_min
            + 0.0 * self.power_loss
            + 0.0 * film.friction_torque_nm
            + 0.0 * film.power_loss_w
            + 0.0 * film.friction_variable.unwrap_or(0.0)
            + 0.0 * film.side_flow_m3_per_s
            + 0.0 * film.inlet_flow_m3_per_s;
        if zero == 0.0 {
            return None;
        }
        self.first_non_finite()
    }

    /// The overflow fault naming the first non-finite output, `None` if all are finite.
    #[cold]
    #[inline(never)]
    fn first_non_finite(&self) -> Option<StateFault> {
        let fields = [
            ("wx", self.wx),
            ("wy", self.wy),
            ("mx", self.mx),
            ("my", self.my),
            ("mz", self.mz),
            (
                "friction_coefficient",
                self.friction_coefficient.unwrap_or(0.0),
            ),
            ("sommerfeld", self.sommerfeld.unwrap_or(0.0)),
            ("h_min", self.h_min),
            ("power_loss", self.power_loss),
            ("film.friction_torque_nm", self.film.friction_torque_nm),
            ("film.power_loss_w", self.film.power_loss_w),
            (
                "film.friction_variable",
                self.film.friction_variable.unwrap_or(0.0),
            ),
            ("film.side_flow_m3_per_s", self.film.side_flow_m3_per_s),
            ("film.inlet_flow_m3_per_s", self.film.inlet_flow_m3_per_s),
        ];
        fields
            .iter()
            .find(|(_, v)| !v.is_finite())
            .map(|&(quantity, _)| StateFault::Overflow { quantity })
    }

    /// Generalised end-point forces (MODEL.md section 4): `(F_i, F_j)`, each `[x, y]`, N.
    pub fn end_forces(&self, length_m: f64) -> ([f64; 2], [f64; 2]) {
        let fj = [self.my / length_m, -self.mx / length_m];
        ([self.wx - fj[0], self.wy - fj[1]], fj)
    }
}

/// A validated state ready for a backend: its packed form and the rate scale (1/s) that
/// multiplies the kernel's integrals back. A zero scale means no pressure anywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Packed {
    /// Kernel input.
    pub state: PackedState,
    /// Rate scale, 1/s.
    pub rate_scale: f64,
}

/// Validates `state` and nondimensionalises it for the kernel.
// Inlined into the evaluator's loop: as a call it returned its 80-byte result through
// memory and saved and restored registers, ~18 instructions a state of the ~136 (issue
// 28's thirteenth pass).
#[inline(always)]
pub fn pack_state(params: &BearingParams, state: &BearingState) -> Result<Packed, StateFault> {
    state.validate(params.clearance)?;
    let d = params.clearance;
    let w = state.omega;
    let ecc = [state.xi / d, state.yi / d, state.xj / d, state.yj / d];
    let rate = [
        w * ecc[0] - 2.0 * state.vyi / d,
        w * ecc[1] + 2.0 * state.vxi / d,
        w * ecc[2] - 2.0 * state.vyj / d,
        w * ecc[3] + 2.0 * state.vxj / d,
    ];
    // A groove supply pressure sets a scale of its own (0 without grooves: unchanged).
    let rate_scale = rate
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
        .max(params.supply_rate());
    if !rate_scale.is_finite() {
        // Finite but enormous inputs overflowed: name the input whose term did.
        let terms = [
            ("omega", w * ecc.iter().fold(0.0_f64, |m, e| m.max(e.abs()))),
            ("vxi", 2.0 * state.vxi / d),
            ("vyi", 2.0 * state.vyi / d),
            ("vxj", 2.0 * state.vxj / d),
            ("vyj", 2.0 * state.vyj / d),
        ];
        let quantity = terms
            .iter()
            .find(|(_, t)| !t.is_finite())
            .map_or("omega", |&(name, _)| name);
        return Err(StateFault::Overflow { quantity });
    }
    let inv = if rate_scale > 0.0 {
        1.0 / rate_scale
    } else {
        0.0
    };
    // A subnormal rate scale (a spin of 1e-310 rad/s, positions of 1e-320 m) has no finite
    // reciprocal: divide instead (|r| <= rate_scale, so every quotient is in [-1, 1]).
    // Normal scales keep the reciprocal, so their packed states are bit-for-bit unchanged.
    let rate = if inv.is_finite() {
        rate.map(|r| r * inv)
    } else {
        rate.map(|r| r / rate_scale)
    };
    Ok(Packed {
        state: PackedState { ecc, rate },
        rate_scale,
    })
}

/// Loads from the kernel's integrals for a state packed by [`pack_state`].
pub fn finish_loads(
    params: &BearingParams,
    state: &BearingState,
    integrals: &FilmIntegrals,
    rate_scale: f64,
) -> Loads {
    finish_loads_with(params, state, integrals, rate_scale, true)
}

/// The parts of [`finish_loads_with`] that depend on the bearing alone: its force scale
/// ([`BearingParams::force_scale`]) and friction constants, worked out once per bearing
/// where many states of the same bearings are finished (the evaluator's planned calls:
/// the backend's `BearingPlan`, a level above). The same numbers as the per-state forms,
/// so loads finished with them are bit for bit those of [`finish_loads_with`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadConstants {
    /// `3 μ r0 B³ / δ²`, N·s.
    force_scale: f64,
    friction: FrictionConstants,
}

impl LoadConstants {
    /// The constants of bearing `params`.
    #[inline]
    pub fn of(params: &BearingParams) -> Self {
        LoadConstants {
            force_scale: params.force_scale(),
            friction: FrictionConstants::of(params),
        }
    }
}

/// [`finish_loads`], with the film friction and flow outputs ([`Loads::film`]) computed
/// only if `film_outputs`; without them `film` is [`FilmFlow::default`] (zeros, `null`
/// coefficients) and every other field is bit for bit the same. For callers that never
/// read `film` (the rotor's stage evaluations, where those closed forms were ~21 % of
/// the instructions: BENCHMARKS.md "Issue 28, third pass").
// Inlined so that the evaluator builds the loads in their place in its output (a call
// returned them through a stack temporary and two `memcpy`s of 176 bytes, ~58
// instructions a state; `#[inline]` alone was not taken).
#[inline(always)]
pub fn finish_loads_with(
    params: &BearingParams,
    state: &BearingState,
    integrals: &FilmIntegrals,
    rate_scale: f64,
    film_outputs: bool,
) -> Loads {
    finish_loads_using(
        params,
        &LoadConstants::of(params),
        state,
        integrals,
        rate_scale,
        film_outputs,
    )
}

/// [`finish_loads_with`] with `params`' constants worked out beforehand
/// (`constants` must be [`LoadConstants::of`] `params`).
#[inline(always)]
pub fn finish_loads_using(
    params: &BearingParams,
    constants: &LoadConstants,
    state: &BearingState,
    integrals: &FilmIntegrals,
    rate_scale: f64,
    film_outputs: bool,
) -> Loads {
    let f = constants.force_scale * rate_scale;
    let (wx, wy) = (f * integrals[0], f * integrals[1]);
    let mx = -f * params.length * integrals[3];
    let my = f * params.length * integrals[2];
    // `|W|` as `√(W_x² + W_y²)` where no square can overflow or underflow (within 2 ulp
    // of the libm `hypot` used before issue 28's ninth pass; `planar_length`).
    let fr = constants
        .friction
        .friction(super::state::planar_length(wx, wy), state.omega);
    let film = if film_outputs {
        short_film_flow(params, state, [wx, wy], [mx, my])
    } else {
        FilmFlow::default()
    };
    Loads {
        wx,
        wy,
        mx,
        my,
        mz: fr.mz,
        friction_coefficient: fr.coefficient,
        sommerfeld: fr.sommerfeld,
        h_min: state.h_min(params.clearance),
        power_loss: (fr.mz * state.omega).abs(),
        friction_model: FrictionLaw::Paper,
        film,
    }
}

/// Loads of one state with the default rule on the calling thread.
pub fn film_loads(
    params: &BearingParams,
    state: &BearingState,
    rule: &FilmRule,
) -> Result<Loads, StateFault> {
    let packed = pack_state(params, state)?;
    let integrals = if packed.rate_scale > 0.0 {
        rule.integrate(&packed.state).0
    } else {
        [0.0; 4]
    };
    finish_loads(params, state, &integrals, packed.rate_scale).finite_or_fault()
}
