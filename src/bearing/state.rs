//! One bearing state (MODEL.md section 1) and its validation.

use serde::{Deserialize, Serialize};

/// Journal kinematics relative to the housing, in the bearing frame: centre at the end
/// face `z = 0` (`i`) and at `z = B` (`j`), their velocities, and the relative spin.
/// Positions in m, velocities in m/s, spin in rad/s (any sign).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingState {
    /// Journal centre x at the first end face `z = 0`, m.
    pub xi: f64,
    /// Journal centre y at the first end face, m.
    pub yi: f64,
    /// Journal centre x at the second end face `z = B`, m.
    pub xj: f64,
    /// Journal centre y at the second end face, m.
    pub yj: f64,
    /// d(xi)/dt, m/s.
    pub vxi: f64,
    /// d(yi)/dt, m/s.
    pub vyi: f64,
    /// d(xj)/dt, m/s.
    pub vxj: f64,
    /// d(yj)/dt, m/s.
    pub vyj: f64,
    /// Relative spin `ω0` of the journal about `+z`, rad/s.
    pub omega: f64,
}

/// End face of a bearing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum End {
    /// `z = 0`.
    I,
    /// `z = B`.
    J,
}

/// Why a bearing state has no film loads.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum StateFault {
    /// An input is NaN or infinite.
    #[error("state field `{field}` is not finite")]
    NonFinite {
        /// JSON name of the field.
        field: &'static str,
    },
    /// The journal touches or passes through the bore wall at an end face: `ε >= 1`.
    #[error(
        "eccentricity ratio {} >= 1 at end {}: journal through the wall",
        if .ratio.is_finite() { crate::json::num(*.ratio) } else { "too large to represent".into() },
        .end.name()
    )]
    ThroughWall {
        /// Which end face.
        end: End,
        /// `|e| / δ` at that end.
        ratio: f64,
    },
    /// Finite inputs so large that a load overflows `f64` (e.g. a spin of 1e200 rad/s,
    /// whose power loss `|M_z ω0|` exceeds 1.8e308 W).
    #[error("`{quantity}` overflows (inputs too large to represent the result)")]
    Overflow {
        /// Output (JSON name) that overflowed.
        quantity: &'static str,
    },
    /// The backend produced a non-finite result and no fallback could recompute it.
    #[error("backend returned non-finite loads")]
    BackendNonFinite,
    /// The bearing this state refers to is unusable (or does not exist).
    #[error("bearing parameters unusable: `{field}` {reason}")]
    InvalidBearing {
        /// The offending field.
        field: &'static str,
        /// Why.
        reason: &'static str,
    },
}

impl End {
    /// `i` (`z = 0`) or `j` (`z = B`), as in the state's field names.
    pub fn name(self) -> &'static str {
        match self {
            End::I => "i (z = 0)",
            End::J => "j (z = B)",
        }
    }
}

impl StateFault {
    /// Short machine-readable status code written into JSON outputs.
    pub fn code(&self) -> &'static str {
        match self {
            StateFault::NonFinite { .. } => "non_finite_input",
            StateFault::ThroughWall { .. } => "through_wall",
            StateFault::Overflow { .. } => "overflow",
            StateFault::BackendNonFinite => "backend_non_finite",
            StateFault::InvalidBearing { .. } => "invalid_bearing",
        }
    }
}

impl BearingState {
    /// Field names and values, in the JSON order.
    pub fn fields(&self) -> [(&'static str, f64); 9] {
        [
            ("xi", self.xi),
            ("yi", self.yi),
            ("xj", self.xj),
            ("yj", self.yj),
            ("vxi", self.vxi),
            ("vyi", self.vyi),
            ("vxj", self.vxj),
            ("vyj", self.vyj),
            ("omega", self.omega),
        ]
    }

    /// Eccentricity ratios `|e| / δ` at the two end faces.
    pub fn eccentricity_ratios(&self, clearance_m: f64) -> (f64, f64) {
        (
            self.xi.hypot(self.yi) / clearance_m,
            self.xj.hypot(self.yj) / clearance_m,
        )
    }

    /// Minimum film thickness `δ − max(|e_i|, |e_j|)`, m (the film is thinnest at an end face).
    pub fn h_min(&self, clearance_m: f64) -> f64 {
        clearance_m - self.far_end_offset()
    }

    /// The larger end-centre offset `max(|e_i|, |e_j|)`, m: [`BearingState::h_min`]'s, and
    /// the larger eccentricity ratio times the clearance (within 2 ulp of the two
    /// `hypot`s of [`BearingState::eccentricity_ratios`]).
    #[inline]
    pub fn far_end_offset(&self) -> f64 {
        // The farther end's length as `√` of the larger squared length where that square
        // lies in [`PLANAR_RANGE`] (`√` is monotone, so this is the larger of the two
        // `√(x² + y²)`, each within 2 ulp of `hypot`: [`planar_length`]); a libm `hypot`
        // (~60 instructions) per end otherwise (extreme or non-finite values). Issue 28's
        // ninth pass: the last bit can differ from the two `hypot`s used before
        // (tests/bearing_state_validate.rs checks 2 ulp of the length).
        let si = self.xi * self.xi + self.yi * self.yi;
        let sj = self.xj * self.xj + self.yj * self.yj;
        let s = si.max(sj);
        // `max` ignores a NaN: both compared with it (false for a NaN) so that a
        // non-finite end goes to `hypot`. The nearer end's square may be 0 or subnormal.
        if PLANAR_RANGE.contains(&s) && si <= s && sj <= s {
            s.sqrt()
        } else {
            self.xi.hypot(self.yi).max(self.xj.hypot(self.yj))
        }
    }

    /// Finite inputs and the journal inside the bore at both ends.
    #[inline]
    pub fn validate(&self, clearance_m: f64) -> Result<(), StateFault> {
        // All finite exactly when this sum of `0 · x` is 0 (NaN otherwise): one test for
        // the common case, the field named only for a failing state.
        let zero = 0.0 * self.xi
            + 0.0 * self.yi
            + 0.0 * self.xj
            + 0.0 * self.yj
            + 0.0 * self.vxi
            + 0.0 * self.vyi
            + 0.0 * self.vxj
            + 0.0 * self.vyj
            + 0.0 * self.omega;
        if zero != 0.0 {
            self.first_non_finite()?;
        }
        // Fast path: both ends clearly inside the bore (`x² + y² < (0.99 δ)²`, whose
        // rounding, a few ulp, cannot reach the 2 % margin), so `hypot` cannot reach 1;
        // the same verdict as the exact test below, without its two `hypot`s (2 % of a
        // rotor run's instructions, BENCHMARKS.md "Issue 28, fifth pass").
        let inside = (0.99 * clearance_m) * (0.99 * clearance_m);
        if self.xi * self.xi + self.yi * self.yi < inside
            && self.xj * self.xj + self.yj * self.yj < inside
        {
            return Ok(());
        }
        self.wall_test(clearance_m)
    }

    /// The non-finite field named, in the JSON order (`validate` for a state whose sum of
    /// `0 · x` is not 0; out of line so that `validate` inlines).
    #[cold]
    #[inline(never)]
    fn first_non_finite(&self) -> Result<(), StateFault> {
        for (field, value) in self.fields() {
            if !value.is_finite() {
                return Err(StateFault::NonFinite { field });
            }
        }
        Ok(())
    }

    /// `validate`'s exact wall test past its fast path.
    #[inline(never)]
    fn wall_test(&self, clearance_m: f64) -> Result<(), StateFault> {
        let (ei, ej) = self.eccentricity_ratios(clearance_m);
        if ei >= 1.0 {
            return Err(StateFault::ThroughWall {
                end: End::I,
                ratio: ei,
            });
        }
        if ej >= 1.0 {
            return Err(StateFault::ThroughWall {
                end: End::J,
                ratio: ej,
            });
        }
        Ok(())
    }
}

/// Squared lengths within which [`planar_length`] takes `√(x² + y²)`: no square can overflow
/// (below 1e300), and the larger square is a normal number (at least half the sum), so a
/// smaller square's loss to underflow (below 5e-324) is under 1e-23 of the sum, far below
/// its rounding.
pub const PLANAR_RANGE: std::ops::Range<f64> = 1e-300..1e300;

/// `√(x² + y²)` (m, N or any unit) as `sqrt(x * x + y * y)` where that sum lies in
/// [`PLANAR_RANGE`], else libm's `hypot`. Each of the two squares, their sum and the root
/// is rounded once, so the result is within about 1.5 ulp of the true length, and within
/// 2 ulp of `hypot` (tests/bearing_state_validate.rs, over 1e-170 to 1e170); ~8
/// instructions instead of a libm call of ~60 (the friction law's `|W|` and `h_min` on
/// every load of a rotor run; BENCHMARKS.md "Issue 28, ninth pass"). Non-finite inputs go
/// to `hypot` (the sum is then NaN or infinite, outside the range).
#[inline]
pub fn planar_length(x: f64, y: f64) -> f64 {
    let s = x * x + y * y;
    if PLANAR_RANGE.contains(&s) {
        s.sqrt()
    } else {
        x.hypot(y)
    }
}
