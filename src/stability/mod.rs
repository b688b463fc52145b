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
    analyse_points, geometric_grid, thresholds, SpeedAnalysis, Threshold, THRESHOLD_RTOL,
};
pub use coefficients::{
    aligned_state, coefficients_batch, mid_plane_loads, perturb, BearingCoefficients,
    CoefficientJob, DiffOptions, Steps, ORDER,
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
