//! Friction from the Sommerfeld number (paper eqs. 10-11, MODEL.md section 5).

use super::BearingParams;

/// Friction torque and the numbers it comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Friction {
    /// Friction torque on the journal about `+z`, N·m; opposes the relative spin.
    pub mz: f64,
    /// Friction coefficient `f`; `None` where it is infinite (`|W| = 0`, `ω0 ≠ 0`) or
    /// undefined (`|W| = 0`, `ω0 = 0`).
    pub coefficient: Option<f64>,
    /// Sommerfeld number `S`; `None` where it is infinite or undefined (`ω0 = 0`).
    pub sommerfeld: Option<f64>,
}

/// The parts of [`friction`] that depend on the bearing alone, worked out once per
/// bearing by callers that finish many states of the same bearings (the evaluator's
/// planned calls, BENCHMARKS.md "Issue 28, thirteenth pass"). Each is the same product,
/// in the same order, as [`friction`] formed per state before, so every result is bit
/// for bit unchanged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrictionConstants {
    /// Relative clearance `φ` of the bearing's convention.
    phi: f64,
    /// `2 r0 B`, m²: the mean pressure is `|W|` over it.
    area_m2: f64,
    /// `6 r0² B μ` (as `6 · r0 · r0 · B · μ`), N·m·s: the load-independent torque is this
    /// times `|ω0| / φ`.
    torque_factor: f64,
    /// Journal radius `r0`, m.
    radius_m: f64,
    /// Dynamic viscosity `μ`, Pa·s.
    viscosity_pa_s: f64,
}

impl FrictionConstants {
    /// The constants of bearing `params`.
    #[inline]
    pub fn of(params: &BearingParams) -> Self {
        FrictionConstants {
            phi: params
                .clearance_convention
                .relative_clearance(params.clearance, params.radius),
            area_m2: 2.0 * params.radius * params.length,
            torque_factor: 6.0 * params.radius * params.radius * params.length * params.viscosity,
            radius_m: params.radius,
            viscosity_pa_s: params.viscosity,
        }
    }

    /// [`friction`] of the bearing these constants are of.
    #[inline(always)]
    pub fn friction(&self, w_abs: f64, omega: f64) -> Friction {
        let phi = self.phi;
        if omega == 0.0 {
            return Friction {
                mz: 0.0,
                coefficient: if w_abs > 0.0 { Some(0.0) } else { None },
                sommerfeld: None,
            };
        }
        let mean_pressure = w_abs / self.area_m2;
        let denominator = self.viscosity_pa_s * omega.abs();
        let s = if denominator >= f64::MIN_POSITIVE {
            mean_pressure * phi * phi / denominator
        } else {
            // μ |ω0| is subnormal or underflows to zero (ω0 ~ 1e-320 rad/s): divide one at
            // a time so that S keeps its precision and 0 / 0 cannot arise.
            mean_pressure * phi * phi / self.viscosity_pa_s / omega.abs()
        };
        let (coefficient, mz_abs) = if s < 1.0 {
            // Load-independent torque 6 r0² B μ |ω0| / φ: finite as W -> 0.
            let torque = self.torque_factor * omega.abs() / phi;
            // A tiny load (|W| ~ 1e-318 N) gives a finite S whose 3 φ / S overflows:
            // infinite, so `None` like |W| = 0.
            let f = 3.0 * phi / s;
            ((s > 0.0 && f.is_finite()).then_some(f), torque)
        } else {
            let f = 3.0 * phi / s.sqrt();
            (Some(f), f * self.radius_m * w_abs)
        };
        Friction {
            mz: -omega.signum() * mz_abs,
            coefficient,
            // A tiny spin (ω0 ~ 1e-310 rad/s) can overflow S: infinite, so `None` like
            // ω0 = 0 (and then f = 3 φ / √S = 0, M_z = 0: the ω0 -> 0 limit).
            sommerfeld: s.is_finite().then_some(s),
        }
    }
}

/// Friction for a bearing carrying load `|W|` (N) at relative spin `ω0` (rad/s).
#[inline]
pub fn friction(params: &BearingParams, w_abs: f64, omega: f64) -> Friction {
    FrictionConstants::of(params).friction(w_abs, omega)
}
