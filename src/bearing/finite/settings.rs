//! Which film model a bearing uses and the finite model's grid and tolerance.

use serde::{Deserialize, Serialize};

/// Film model of one bearing (JSON `"model"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FilmModel {
    /// The short-bearing (Ocvirk) slice model of MODEL.md sections 2-4, half-Sommerfeld
    /// cavitation. Default.
    #[default]
    Short,
    /// The finite-length Reynolds equation on the (θ, z) grid with Swift–Stieber
    /// cavitation (`p ≥ 0` as a complementarity problem).
    Finite,
    /// Per state: `short` where the short model's error from the model-error map at the
    /// bearing's `B/D` and the state's eccentricity is below `finite.auto_tolerance`, else
    /// `finite`.
    Auto,
}

impl FilmModel {
    /// Name written into outputs.
    pub fn name(self) -> &'static str {
        match self {
            FilmModel::Short => "short",
            FilmModel::Finite => "finite",
            FilmModel::Auto => "auto",
        }
    }
}

/// Where the film is fed (JSON `"finite": {"inlet": ...}`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Inlet {
    /// No inlet: pure Swift–Stieber complementarity over the whole 360° film; the
    /// pressure zone's both boundaries are free. Default.
    #[default]
    None,
    /// Ambient pressure held along the line of maximum film thickness (at each `z` the
    /// grid column nearest it): the 360° bearing of Raimondi and Boyd (1958), fed at the
    /// maximum film, with Swift–Stieber (Reynolds) cavitation downstream.
    MaxFilm,
}

/// Grid and tolerance of the finite-length film (JSON `"finite"` in a bearing's object).
/// Every field has a default.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiniteSettings {
    /// Grid intervals around the circumference (θ, periodic); even, 8..=1024.
    /// Default 64 (Δθ = 5.6°).
    #[serde(default = "default_n_theta")]
    pub n_theta: u32,
    /// Grid intervals along the bearing length (z, `p = 0` at both ends); 2..=512.
    /// Default 16.
    #[serde(default = "default_n_z")]
    pub n_z: u32,
    /// Relative tolerance of the projected-SOR iteration (estimated iteration error of the
    /// field over its maximum), in (0, 0.1]. Default 1e-8.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// For `"model": "auto"`: largest short-bearing model error (relative, from the
    /// model-error map) accepted before the finite model is used. Default 0.05 (5 %).
    #[serde(default = "default_auto_tolerance")]
    pub auto_tolerance: f64,
    /// Film inlet: `"none"` (default) or `"max_film"` (see [`Inlet`]).
    #[serde(default)]
    pub inlet: Inlet,
}

fn default_n_theta() -> u32 {
    64
}
fn default_n_z() -> u32 {
    16
}
fn default_tolerance() -> f64 {
    1e-8
}
fn default_auto_tolerance() -> f64 {
    0.05
}

impl Default for FiniteSettings {
    fn default() -> Self {
        FiniteSettings {
            n_theta: default_n_theta(),
            n_z: default_n_z(),
            tolerance: default_tolerance(),
            auto_tolerance: default_auto_tolerance(),
            inlet: Inlet::None,
        }
    }
}

/// A finite-film setting that cannot be used; `field` is the JSON path below the bearing.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("finite-film setting `{field}` = {value}: {reason}")]
pub struct FiniteSettingsError {
    /// JSON path below the bearing object, e.g. `finite.n_theta`.
    pub field: &'static str,
    /// The offending value.
    pub value: f64,
    /// Why it is rejected.
    pub reason: &'static str,
}

/// Largest grid accepted in either direction: 1024 × 512 nodes is ~4 MB of f64 per state.
const MAX_N_THETA: u32 = 1024;
const MAX_N_Z: u32 = 512;

impl FiniteSettings {
    /// Checks ranges (see each field).
    pub fn validate(&self) -> Result<(), FiniteSettingsError> {
        let err = |field, value: f64, reason| {
            Err(FiniteSettingsError {
                field,
                value,
                reason,
            })
        };
        if self.n_theta < 8 || self.n_theta > MAX_N_THETA || !self.n_theta.is_multiple_of(2) {
            return err(
                "finite.n_theta",
                self.n_theta as f64,
                "must be an even number in 8..=1024",
            );
        }
        if self.n_z < 2 || self.n_z > MAX_N_Z {
            return err("finite.n_z", self.n_z as f64, "must be in 2..=512");
        }
        if !(self.tolerance > 0.0 && self.tolerance <= 0.1) {
            return err(
                "finite.tolerance",
                self.tolerance,
                "must be a number in (0, 0.1]",
            );
        }
        if !(self.auto_tolerance > 0.0 && self.auto_tolerance.is_finite()) {
            return err(
                "finite.auto_tolerance",
                self.auto_tolerance,
                "must be a positive finite number",
            );
        }
        Ok(())
    }

    /// The grid with half the intervals in both directions (the coarse grid of the
    /// Richardson error estimate); `None` when it would be below the minimum.
    pub fn coarse(&self) -> Option<FiniteSettings> {
        let c = FiniteSettings {
            n_theta: self.n_theta / 2,
            n_z: self.n_z / 2,
            ..*self
        };
        let halvable = self.n_theta.is_multiple_of(4) && self.n_z.is_multiple_of(2);
        (halvable && c.n_theta >= 8 && c.n_z >= 2).then_some(c)
    }
}
