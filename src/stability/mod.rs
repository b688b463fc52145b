//! Linearised bearing coefficients (4×4 `K` and `C` with tilt) and rotor stability:
//! static equilibria, eigenvalues as whirl modes, threshold speeds, Campbell diagrams and
//! the threshold scan, all on the batched film loads (the sweeps' `stability` kind is
//! `sweep::stability_sim`).

mod analysis;
mod coefficients;
mod equilibrium;
mod error;
mod linear;
mod modes;
mod plots;
mod thermal;

pub use analysis::{
    analyse_points, geometric_grid, thresholds, FailedSpeed, SpeedAnalysis, Threshold,
    THRESHOLD_RTOL,
};
pub use coefficients::{
    aligned_state, coefficients_batch, difference_grid, load_noise, mid_plane_loads, perturb,
    pin_grid, BearingCoefficients, CoefficientJob, DiffOptions, Steps, ORDER,
};
pub use equilibrium::{
    bearing_equilibria, closed_form_position, equilibrium_state, ocvirk_capacity,
    ocvirk_eccentricity, BearingEquilibrium,
};
pub use error::StabilityError;
pub use linear::{
    bearing_state, equilibria_batch, linearise_batch, BearingPoint, Frame, LinearRotor,
    RotorDescription, M4,
};
pub use modes::{mac, max_growth, modes, track_modes, Mode, Shape, TRACK_MIN_MAC};
pub use plots::{campbell_figure, campbell_svg, damping_figure, damping_svg, LOG_DEC_MARGIN};
pub use thermal::{is_thermal, thermal_rotor, SWEEP_TOLERANCE_FACTOR};

/// An evaluator for finite differences: an f32 backend (rounding ~1e-7 relative, so
/// differences over steps of ~1e-4 of the clearance would keep ~3 digits) is replaced by
/// the CPU backend at the same accuracy, with a notice saying so.
pub fn difference_evaluator(
    backend: Box<dyn crate::backend::FilmBackend>,
    accuracy: crate::bearing::Accuracy,
) -> (crate::backend::LoadEvaluator, Option<String>) {
    if backend.info().precision == crate::backend::Precision::F32 {
        (
            crate::backend::LoadEvaluator::new(Box::new(crate::backend::CpuBackend::new(
                accuracy, None,
            ))),
            Some(
                "notice: the GPU kernel runs in f32, too coarse for finite differences; using the CPU backend"
                    .into(),
            ),
        )
    } else {
        (crate::backend::LoadEvaluator::new(backend), None)
    }
}
