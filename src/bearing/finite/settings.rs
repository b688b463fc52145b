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
    /// pressure zone's both boundaries are free (the pressure zone may start upstream of
    /// the maximum film: at ε = 0.1, B/D = 0.5 the attitude angle is 1.3° above the
    /// classical tables).
    None,
    /// Ambient pressure held along the line of maximum film thickness (at each `z` the
    /// grid column nearest it; in accuracy mode the grid has a node on it): the 360°
    /// bearing of Raimondi and Boyd (1958) and Butenschoen (1976), fed at the maximum
    /// film, with Swift–Stieber (Reynolds) cavitation downstream. Default (issue 20:
    /// within 0.2 % in S and 0.02° in attitude of Butenschoen's B/d = 1/2 table).
    #[default]
    MaxFilm,
}

/// Cavitation model of the finite film (JSON `"finite": {"cavitation": ...}`; issue 27).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Cavitation {
    /// Swift–Stieber (Reynolds) condition: `p ≥ 0` as a complementarity problem; not
    /// mass-conserving at film reformation. Default (unchanged since issue 16).
    #[default]
    Reynolds,
    /// Jakobsson–Floberg–Olsson, mass-conserving: pressure `p ≥ 0` and film fraction
    /// `φ ∈ [0, 1]` with `p (1 − φ) = 0`, the cavitated zone transporting `φ h` with the
    /// surface (Elrod–Adams), solved by [`super::jfo`]. Needs a film supply (the
    /// `max_film` inlet, grooves or arcs).
    Jfo,
}

impl Cavitation {
    /// Name written into outputs.
    pub fn name(self) -> &'static str {
        match self {
            Cavitation::Reynolds => "reynolds",
            Cavitation::Jfo => "jfo",
        }
    }

    /// Whether this is the default (serialisation skips it, so outputs that echo the
    /// settings stay as they were).
    pub fn is_reynolds(&self) -> bool {
        *self == Cavitation::Reynolds
    }
}

/// Accuracy, grid and tolerance of the finite-length film (JSON `"finite"` in a bearing's
/// object). Every field has a default.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiniteSettings {
    /// Requested relative discretisation error of the load vector `(W_x, W_y, M_x/B,
    /// M_y/B)` (norm of the error over the norm of the vector): the solver refines the
    /// grid per state until the Richardson estimate from its nested multigrid solutions
    /// is at most this (docs/finite-film.md "Accuracy"). In [1e-6, 0.1]. Default
    /// [`DEFAULT_ACCURACY`]. Ignored when `n_theta` or `n_z` is given.
    #[serde(default = "default_accuracy")]
    pub accuracy: f64,
    /// Explicit grid (overrides `accuracy`): intervals around the circumference (θ,
    /// periodic); even, 8..=1024. When only `n_z` is given, 64.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_theta: Option<u32>,
    /// Explicit grid (overrides `accuracy`): intervals along the bearing length (z,
    /// `p = 0` at both ends); 2..=512. When only `n_theta` is given, 16.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_z: Option<u32>,
    /// Relative tolerance of the multigrid iteration on each grid (estimated iteration
    /// error of the field over its maximum), in (0, 0.1]. Default 1e-8.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// For `"model": "auto"`: largest short-bearing model error (relative, from the
    /// model-error map) accepted before the finite model is used. Default 0.05 (5 %).
    #[serde(default = "default_auto_tolerance")]
    pub auto_tolerance: f64,
    /// Film inlet: `"max_film"` (default) or `"none"` (see [`Inlet`]). Not used when the
    /// bearing has `grooves` or `arcs`: the film is then fed at the grooves and arc ends
    /// (docs/grooves.md).
    #[serde(default)]
    pub inlet: Inlet,
    /// Cavitation model: `"reynolds"` (Swift–Stieber, default) or `"jfo"` (mass-conserving,
    /// see [`Cavitation`] and docs/jfo.md).
    #[serde(default, skip_serializing_if = "Cavitation::is_reynolds")]
    pub cavitation: Cavitation,
    /// Internal, not JSON (issue 20): in accuracy mode, a grid `[n_theta, n_z]` of the
    /// accuracy ladder held for every evaluation of one linearisation or equilibrium
    /// (the stability tools set it, see [`FiniteSettings::held`]). Each state is then
    /// solved on the ladder up to this grid, node 0 on its own mid-plane maximum film as
    /// in accuracy mode (so the loads are smooth in the state: no snapped inlet column,
    /// no grid change between states), and the held grid is iterated until its load
    /// vector's estimated iteration error is below `tolerance`. `None` (default): the
    /// grid is chosen per state.
    #[serde(skip)]
    pub held_grid: Option<[u32; 2]>,
}

/// Default of [`FiniteSettings::accuracy`]: chosen so that the default run's load vector
/// is within 1e-3 of the converged solution for ε ≤ 0.95, aligned and tilted
/// (tests/finite_accuracy.rs; the estimate is honest within a factor 3).
pub const DEFAULT_ACCURACY: f64 = 5e-4;
/// Grid used for the missing direction when only one of `n_theta`, `n_z` is given.
const DEFAULT_N_THETA: u32 = 64;
const DEFAULT_N_Z: u32 = 16;

fn default_accuracy() -> f64 {
    DEFAULT_ACCURACY
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
            accuracy: default_accuracy(),
            n_theta: None,
            n_z: None,
            tolerance: default_tolerance(),
            auto_tolerance: default_auto_tolerance(),
            inlet: Inlet::MaxFilm,
            cavitation: Cavitation::Reynolds,
            held_grid: None,
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
        if !(self.accuracy >= 1e-6 && self.accuracy <= 0.1) {
            return err(
                "finite.accuracy",
                self.accuracy,
                "must be a number in [1e-6, 0.1]",
            );
        }
        if let Some(n) = self.n_theta {
            if !(8..=MAX_N_THETA).contains(&n) || !n.is_multiple_of(2) {
                return err(
                    "finite.n_theta",
                    n as f64,
                    "must be an even number in 8..=1024",
                );
            }
        }
        if let Some(n) = self.n_z {
            if !(2..=MAX_N_Z).contains(&n) {
                return err("finite.n_z", n as f64, "must be in 2..=512");
            }
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

    /// Settings with the explicit grid `n_theta × n_z`.
    pub fn with_grid(n_theta: u32, n_z: u32) -> FiniteSettings {
        FiniteSettings {
            n_theta: Some(n_theta),
            n_z: Some(n_z),
            ..FiniteSettings::default()
        }
    }

    /// The explicit grid `(n_theta, n_z)` when either is given (the other at its
    /// default), `None` in accuracy mode.
    pub fn fixed_grid(&self) -> Option<(u32, u32)> {
        match (self.n_theta, self.n_z) {
            (None, None) => None,
            (t, z) => Some((t.unwrap_or(DEFAULT_N_THETA), z.unwrap_or(DEFAULT_N_Z))),
        }
    }

    /// Accuracy mode with the ladder grid `[n_theta, n_z]` held (see
    /// [`FiniteSettings::held_grid`]); explicit grids are returned unchanged (they are
    /// held already).
    pub fn held(&self, grid: [u32; 2]) -> FiniteSettings {
        if self.fixed_grid().is_some() {
            return *self;
        }
        FiniteSettings {
            held_grid: Some(grid),
            ..*self
        }
    }

    /// The half grid (both directions halved) of an explicit or held grid, the coarse
    /// grid of a Richardson estimate; `None` in plain accuracy mode or below the minimum
    /// (explicit: 8 × 2; held: 16 × 2, the ladder's smallest).
    pub fn half_grid(&self) -> Option<FiniteSettings> {
        if let Some([t, z]) = self.held_grid.filter(|_| self.fixed_grid().is_none()) {
            let halvable = t.is_multiple_of(2) && z.is_multiple_of(2);
            // The ladder's smallest grid has 16 intervals around and 2 along
            // (`super::accuracy_ladder`).
            return (halvable && t / 2 >= 16 && z / 2 >= 2).then_some(FiniteSettings {
                held_grid: Some([t / 2, z / 2]),
                ..*self
            });
        }
        self.coarse()
    }

    /// The explicit grid with half the intervals in both directions (the coarse grid of
    /// the Richardson error estimate); `None` in accuracy mode or when it would be below
    /// the minimum.
    pub fn coarse(&self) -> Option<FiniteSettings> {
        let (nt, nz) = self.fixed_grid()?;
        let halvable = nt.is_multiple_of(4) && nz.is_multiple_of(2);
        (halvable && nt / 2 >= 8 && nz / 2 >= 2).then_some(FiniteSettings {
            n_theta: Some(nt / 2),
            n_z: Some(nz / 2),
            ..*self
        })
    }
}
