//! The short-bearing model's error against the finite-length film: aligned journal,
//! steady rotation, over `B/D` and eccentricity `ε` (docs/finite-film.md "Model-error map").

use super::{finite_loads, FiniteSettings};
use crate::bearing::{film_loads, Accuracy, BearingParams, BearingState, FilmRule};

/// `B/D` values of the stored map (rows).
pub const ERROR_MAP_ASPECTS: [f64; 10] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];
/// Eccentricity ratios of the stored map (columns).
pub const ERROR_MAP_ECC: [f64; 10] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.95];

/// How far the short model is from the finite one at one `(B/D, ε)`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ShortModelError {
    /// `|W_short|/|W_finite| − 1`: relative load-magnitude error of the short model
    /// (positive: the short model overestimates the load).
    pub load: f64,
    /// Attitude angle of the short model minus the finite model's, degrees.
    pub attitude_deg: f64,
    /// Whether `(B/D, ε)` lies outside the stored map (values clamped to its edge;
    /// below `B/D = 0.1` scaled by `(B/D / 0.1)²`, the known order).
    pub extrapolated: bool,
}

/// The grid the stored map was computed on (`n_theta` 128, `n_z` 32; Richardson error of
/// the finite loads below 0.3 % over the map, docs/finite-film.md).
pub fn error_map_settings() -> FiniteSettings {
    FiniteSettings {
        n_theta: 128,
        n_z: 32,
        tolerance: 1e-9,
        ..FiniteSettings::default()
    }
}

/// Computes one map entry directly: aligned journal at `x = εδ`, `ω0 = 1` rad/s, short
/// rule at 1e-10 against the finite model on `settings`.
pub fn compute_short_model_error(
    b_over_d: f64,
    ecc: f64,
    settings: &FiniteSettings,
) -> ShortModelError {
    let params = BearingParams {
        radius: 0.5,
        length: b_over_d,
        clearance: 1e-3,
        viscosity: 1.0,
        ..BearingParams::paper_table2()
    };
    // ε = 0 carries no load: take the limit from a small eccentricity.
    let e = ecc.max(1e-3);
    let state = BearingState {
        xi: e * params.clearance,
        xj: e * params.clearance,
        omega: 1.0,
        ..BearingState::default()
    };
    let rule = FilmRule::new(
        Accuracy::new(1e-10)
            .expect("1e-10 is a valid accuracy")
            .settings(),
    );
    let (s, f) = match (
        film_loads(&params, &state, &rule),
        finite_loads(&params, &state, settings),
    ) {
        (Ok(s), Ok(f)) => (s, f),
        _ => {
            return ShortModelError {
                load: f64::NAN,
                attitude_deg: f64::NAN,
                extrapolated: false,
            }
        }
    };
    // Attitude angle: between the line of centres (+x) and the load line (−W).
    let att = |wx: f64, wy: f64| (-wy).atan2(-wx).to_degrees().abs();
    ShortModelError {
        load: s.wx.hypot(s.wy) / f.wx.hypot(f.wy) - 1.0,
        attitude_deg: att(s.wx, s.wy) - att(f.wx, f.wy),
        extrapolated: false,
    }
}
