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
        // The farther end by its squared distance, one `hypot` (a libm call, ~60
        // instructions) instead of two, where the squares are clearly apart: computed
        // squares within 4e-16 relative of the true ones (no overflow or underflow in
        // [1e-300, 1e300]) and apart by 1e-12 put the true lengths apart by 4.9e-13, far
        // beyond `hypot`'s 1 ulp, so the other `hypot` could not have been the larger and
        // the result is the same bits. Otherwise (near-equal ends, extreme or non-finite
        // values) both, as before.
        let si = self.xi * self.xi + self.yi * self.yi;
        let sj = self.xj * self.xj + self.yj * self.yj;
        // Relative gap between the squares beyond any rounding of theirs or of `hypot`.
        const APART: f64 = 1.0 + 1e-12;
        // Range in which the squares neither overflow nor lose precision to underflow.
        let normal = |s: f64| (1e-300..1e300).contains(&s);
        let far = if normal(si) && si > sj * APART {
            self.xi.hypot(self.yi)
        } else if normal(sj) && sj > si * APART {
            self.xj.hypot(self.yj)
        } else {
            self.xi.hypot(self.yi).max(self.xj.hypot(self.yj))
        };
        clearance_m - far
    }

    /// Finite inputs and the journal inside the bore at both ends.
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
            for (field, value) in self.fields() {
                if !value.is_finite() {
                    return Err(StateFault::NonFinite { field });
                }
            }
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
