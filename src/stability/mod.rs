//! Linearised bearing coefficients (4×4 `K` and `C` with tilt) and rotor stability:
//! static equilibria, eigenvalues as whirl modes, threshold speeds, Campbell diagrams and
//! the sweeps' `stability` analysis, all on the batched film loads.

mod analysis;
mod coefficients;
mod equilibrium;
mod error;
mod linear;
mod modes;
mod plots;
mod sweep_sim;

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
    bearing_state, linearise_batch, BearingPoint, Frame, LinearRotor, RotorDescription, M4,
};
pub use modes::{max_growth, modes, Mode, Shape};
pub use plots::{campbell_svg, damping_svg};
pub use sweep_sim::{StabilitySimulator, SCAN_HIGH, SCAN_LOW, SCAN_POINTS};

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
