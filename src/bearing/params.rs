//! Bearing geometry and lubricant (MODEL.md section 1), with validation.

use serde::{Deserialize, Serialize};

use super::finite::{FilmModel, FiniteSettings};
use super::groove::{Arcs, FilmLayout, Grooves};
use super::lubricant::Lubricant;
use super::thermal::ThermalSettings;

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

/// Constant inputs of one hydrodynamic journal bearing. SI units. The lubricant is given
/// either as `viscosity` or as `lubricant` with `supply_temperature` (exactly one of the
/// two ways; docs/thermal.md); with a lubricant, `viscosity` holds `μ` at the supply
/// temperature after parsing, and steady runs replace it by `μ(T_eff)` from the thermal
/// balance ([`super::thermal`]). The kernels only ever read `viscosity`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, remote = "Self")]
pub struct BearingParams {
    /// Journal radius `r0`, m (paper's Table 2: 0.02).
    pub radius: f64,
    /// Bearing length `B` along the bore axis, m (Table 2: 0.02).
    pub length: f64,
    /// Radial clearance `δ`, m (Table 2: 0.0003).
    pub clearance: f64,
    /// Lubricant dynamic viscosity `μ`, Pa·s (Table 2: 0.0242). Required unless
    /// `lubricant` is given (then absent in JSON, resolved at the supply temperature).
    #[serde(default = "unset_viscosity")]
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
    /// Lubricant: `"ISO VG 22"` ... `"ISO VG 220"` or `{"nu40", "nu100", "density",
    /// "expansion", "specific_heat"}` (docs/thermal.md). Default none (`viscosity` given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lubricant: Option<Lubricant>,
    /// Oil supply temperature, °C; required with `lubricant`, refused without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supply_temperature: Option<f64>,
    /// Thermal balance settings (effective-temperature factor, housing conductance,
    /// thermal capacity, tolerance); used with `lubricant` only; all fields default.
    #[serde(default, skip_serializing_if = "is_default_thermal")]
    pub thermal: ThermalSettings,
}

/// `viscosity` absent from the JSON (JSON has no NaN, so NaN marks it).
fn unset_viscosity() -> f64 {
    f64::NAN
}

fn is_default_thermal(t: &ThermalSettings) -> bool {
    *t == ThermalSettings::default()
}

/// Supply temperatures accepted, °C: mineral oils are pumpable and below their flash
/// points (~200 °C and up) in this range.
const SUPPLY_RANGE_C: (f64, f64) = (-30.0, 200.0);

impl Serialize for BearingParams {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::Error;
        let mut v = BearingParams::serialize(self, serde_json::value::Serializer)
            .map_err(S::Error::custom)?;
        // With a lubricant the viscosity is derived: written back, it would be refused.
        if self.lubricant.is_some() {
            if let Some(m) = v.as_object_mut() {
                m.remove("viscosity");
            }
        }
        v.serialize(s)
    }
}

impl<'de> Deserialize<'de> for BearingParams {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut p = BearingParams::deserialize(d)?;
        p.resolve_lubricant().map_err(D::Error::custom)?;
        Ok(p)
    }
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
            lubricant: None,
            supply_temperature: None,
            thermal: ThermalSettings::default(),
        }
    }

    /// Checks the lubricant fields (exactly one of `viscosity` and `lubricant` +
    /// `supply_temperature`) and sets `viscosity` to `μ(T_supply)` when a lubricant is
    /// given. The message names the fields.
    pub fn resolve_lubricant(&mut self) -> Result<(), String> {
        let given = !self.viscosity.is_nan();
        match (self.lubricant, self.supply_temperature) {
            (Some(_), _) if given => Err(
                "give either `viscosity` or `lubricant` with `supply_temperature`, not both"
                    .into(),
            ),
            (Some(_), None) => Err(
                "`lubricant` needs `supply_temperature` (the oil's supply temperature, °C)"
                    .into(),
            ),
            (Some(l), Some(t)) => {
                let (lo, hi) = SUPPLY_RANGE_C;
                if !(t.is_finite() && (lo..=hi).contains(&t)) {
                    return Err(format!(
                        "`supply_temperature` must be in {lo}..={hi} °C (got {t})"
                    ));
                }
                self.viscosity = l.dynamic_viscosity(t);
                Ok(())
            }
            (None, Some(_)) => Err(
                "`supply_temperature` needs `lubricant` (e.g. \"ISO VG 46\"); with a plain `viscosity` there is no temperature"
                    .into(),
            ),
            (None, None) if !given => Err(
                "missing field `viscosity` (or give `lubricant` and `supply_temperature`)".into(),
            ),
            (None, None) => Ok(()),
        }
    }

    /// This bearing with `viscosity` taken at `celsius` from its lubricant (unchanged
    /// without one).
    pub fn at_temperature(&self, celsius: f64) -> Self {
        match self.lubricant {
            Some(l) => BearingParams {
                viscosity: l.dynamic_viscosity(celsius),
                ..*self
            },
            None => *self,
        }
    }

    /// `true` when the thermal balance applies (a lubricant with a supply temperature).
    pub fn is_thermal(&self) -> bool {
        self.lubricant.is_some() && self.supply_temperature.is_some()
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
        if let Err((field, value, reason)) = self.thermal.validate() {
            let field = match field {
                "effective_factor" => "thermal.effective_factor",
                "housing_conductance" => "thermal.housing_conductance",
                "thermal_capacity" => "thermal.thermal_capacity",
                _ => "thermal.tolerance",
            };
            return Err(ParamError {
                field,
                value,
                reason,
            });
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
        if self.finite.cavitation == super::finite::Cavitation::Jfo
            && self.finite.inlet == super::finite::Inlet::None
            && self.film_layout().is_empty()
        {
            // Issue 27: without a supply the mass-conserving film has no steady state
            // (any liquid content carried round the ring at P = 0 is one).
            return Err(ParamError {
                field: "finite.cavitation",
                value: 1.0,
                reason:
                    "\"jfo\" needs a film supply: \"inlet\": \"max_film\", grooves or arcs \
                         (with \"inlet\": \"none\" and neither, a mass-conserving film has no feed)",
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
