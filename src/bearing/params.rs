//! Bearing geometry and lubricant (MODEL.md section 1), with validation.

use serde::{Deserialize, Serialize};

use super::finite::{FilmModel, FiniteSettings};
use super::groove::{Arcs, FilmLayout, Grooves};

/// Which relative clearance the friction law of eqs. (10)-(11) uses (MODEL.md section 5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ClearanceConvention {
    /// `φ = δ / (2 r0)`, as printed in the paper; needed to reproduce its Fig. 4. Default.
    #[default]
    Paper,
    /// `ψ = δ / r0`, the relative clearance of Vogelpohl's law; its `S < 1` torque is
    /// 0.95 × Petroff's, where the paper's is 1.91 ×.
    Vogelpohl,
}

impl ClearanceConvention {
    /// Relative clearance used by the friction law, dimensionless.
    pub fn relative_clearance(self, clearance_m: f64, radius_m: f64) -> f64 {
        match self {
            ClearanceConvention::Paper => clearance_m / (2.0 * radius_m),
            ClearanceConvention::Vogelpohl => clearance_m / radius_m,
        }
    }

    /// Name written into every output that reports friction.
    pub fn name(self) -> &'static str {
        match self {
            ClearanceConvention::Paper => "paper",
            ClearanceConvention::Vogelpohl => "vogelpohl",
        }
    }
}

/// Constant inputs of one hydrodynamic journal bearing. SI units; no field has a
/// default except `clearance_convention`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingParams {
    /// Journal radius `r0`, m (paper's Table 2: 0.02).
    pub radius: f64,
    /// Bearing length `B` along the bore axis, m (Table 2: 0.02).
    pub length: f64,
    /// Radial clearance `δ`, m (Table 2: 0.0003).
    pub clearance: f64,
    /// Lubricant dynamic viscosity `μ`, Pa·s (Table 2: 0.0242).
    pub viscosity: f64,
    /// Relative clearance in the friction law; default `"paper"`.
    #[serde(default)]
    pub clearance_convention: ClearanceConvention,
    /// Film model: `"short"` (default), `"finite"` or `"auto"` (docs/finite-film.md).
    #[serde(default)]
    pub model: FilmModel,
    /// Grid, tolerance and `auto` threshold of the finite model; all fields default.
    #[serde(default)]
    pub finite: FiniteSettings,
    /// Axial oil-supply grooves (docs/grooves.md): a list of at most
    /// [`super::groove::MAX_GROOVES`] objects `{"angle", "width", "supply_pressure",
    /// "length"}` (degrees, degrees, Pa gauge, m). Default: none. Needs `"model":
    /// "finite"`; replaces the finite film's `max_film` inlet line.
    #[serde(default, skip_serializing_if = "Grooves::is_empty")]
    pub grooves: Grooves,
    /// Lands of a partial-arc bearing: a list of at most [`super::groove::MAX_ARCS`]
    /// objects `{"start", "extent"}` (degrees); outside every arc there is no film
    /// (ambient pressure). Default: none, the full 360° land. Needs `"model": "finite"`.
    #[serde(default, skip_serializing_if = "Arcs::is_empty")]
    pub arcs: Arcs,
}

/// A bearing parameter that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("bearing parameter `{field}` = {value}: {reason}")]
pub struct ParamError {
    /// The offending field's JSON name.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// Why it is rejected.
    pub reason: &'static str,
}

impl BearingParams {
    /// The paper's Table 2 bearing: r0 = 0.02 m, B = 0.02 m, δ = 0.3 mm, μ = 0.0242 Pa·s.
    pub fn paper_table2() -> Self {
        BearingParams {
            radius: 0.02,
            length: 0.02,
            clearance: 0.0003,
            viscosity: 0.0242,
            clearance_convention: ClearanceConvention::Paper,
            model: FilmModel::Short,
            finite: FiniteSettings::default(),
            grooves: Grooves::default(),
            arcs: Arcs::default(),
        }
    }

    /// Every field finite and positive, and the clearance smaller than the radius.
    pub fn validate(&self) -> Result<(), ParamError> {
        let fields = [
            ("radius", self.radius),
            ("length", self.length),
            ("clearance", self.clearance),
            ("viscosity", self.viscosity),
        ];
        for (field, value) in fields {
            if !value.is_finite() {
                return Err(ParamError {
                    field,
                    value,
                    reason: "must be finite",
                });
            }
            if value <= 0.0 {
                return Err(ParamError {
                    field,
                    value,
                    reason: "must be positive",
                });
            }
        }
        if let Err(e) = self.finite.validate() {
            return Err(ParamError {
                field: e.field,
                value: e.value,
                reason: e.reason,
            });
        }
        if let Err(e) = super::groove::validate(&self.grooves, &self.arcs, self.length) {
            return Err(ParamError {
                field: e.field,
                value: e.value,
                reason: e.reason,
            });
        }
        if self.model != FilmModel::Finite {
            let (field, count) = if self.grooves.is_empty() {
                ("arcs", self.arcs.as_slice().len())
            } else {
                ("grooves", self.grooves.as_slice().len())
            };
            if count > 0 {
                return Err(ParamError {
                    field,
                    value: count as f64,
                    reason: "grooves and arcs need \"model\": \"finite\" (the short-bearing rule \
                             integrates each slice's loaded half-turn in closed form; docs/grooves.md)",
                });
            }
        }
        if self.clearance >= self.radius {
            return Err(ParamError {
                field: "clearance",
                value: self.clearance,
                reason: "must be smaller than the journal radius",
            });
        }
        Ok(())
    }

    /// The held bands of the grooves and arcs (empty for the plain 360° bearing).
    pub fn film_layout(&self) -> FilmLayout {
        FilmLayout::new(&self.grooves, &self.arcs, self.length)
    }

    /// Rate, 1/s, at which the largest groove supply pressure is the film's pressure
    /// scale: `p_s δ² / (μ B²)` (0 without a supply pressure). [`super::pack_state`]
    /// takes the larger of it and the kinematic rate, so a supplied film at rest carries
    /// its hydrostatic load.
    pub fn supply_rate(&self) -> f64 {
        if self.grooves.is_empty() {
            return 0.0;
        }
        let ps = self
            .grooves
            .as_slice()
            .iter()
            .fold(0.0_f64, |m, g| m.max(g.supply_pressure));
        ps * self.clearance * self.clearance / (self.viscosity * self.length * self.length)
    }

    /// Scale of every film load: `3 μ r0 B³ / δ²`, N·s (times a rate in 1/s gives N).
    pub fn force_scale(&self) -> f64 {
        3.0 * self.viscosity * self.radius * self.length.powi(3) / (self.clearance * self.clearance)
    }
}
