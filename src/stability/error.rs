//! Errors of the linear analysis, with the physical context of each failure.

use crate::bearing::StateFault;

/// Why a coefficient set, an equilibrium or a stability analysis has no result.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StabilityError {
    /// Unusable input: the JSON path (or option) and why.
    #[error("{path}: {reason}")]
    Input {
        /// JSON path, e.g. `bearing.clearance` or `load[1]`.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// The film loads of a bearing could not be evaluated at a state the analysis needs.
    #[error("film loads of bearings[{bearing}] failed ({context}): {fault}")]
    Film {
        /// Index of the bearing (0 for a single bearing).
        bearing: usize,
        /// Where in the analysis (base state, perturbed state, Newton iterate).
        context: String,
        /// The film's own reason.
        fault: StateFault,
    },
    /// No static equilibrium was found.
    #[error("no static equilibrium at {speed_rad_s} rad/s: {reason}")]
    NoEquilibrium {
        /// Speed, rad/s.
        speed_rad_s: f64,
        /// Why (load beyond the film's capacity, Newton did not converge, ...).
        reason: String,
    },
}

impl StabilityError {
    /// An input error at `path`.
    pub fn input(path: impl Into<String>, reason: impl Into<String>) -> Self {
        StabilityError::Input {
            path: path.into(),
            reason: reason.into(),
        }
    }

    /// Short machine-readable status for sweep outputs.
    pub fn code(&self) -> &'static str {
        match self {
            StabilityError::Input { .. } => "invalid_input",
            StabilityError::Film { fault, .. } => fault.code(),
            StabilityError::NoEquilibrium { .. } => "no_equilibrium",
        }
    }
}
