//! Design-space sweeps: a JSON spec (a base scene plus axes over any of its parameters),
//! its expansion into variants (grid, zip, Latin hypercube), per-variant reductions of the
//! simulated signals, a resumable and shardable runner streaming JSON Lines, shard
//! merging, and friction maps (Fig. 4) that need no dynamics.
//!
//! Everything here is generic over the simulation: the runner takes a
//! [`runner::BatchSimulator`]; [`synthetic`] is an analytic stand-in with known answers.

pub mod expand;
pub mod folder_sink;
pub mod friction_map;
pub mod job;
pub mod json_path;
pub mod merge;
pub mod options;
pub mod plots;
pub mod progress;
pub mod reduce;
pub mod reduction_options;
pub mod rotor_sim;
pub mod runner;
pub mod schema;
pub mod simulator;
pub mod sink;
pub mod spec;
pub mod stability_sim;
pub mod stream;
pub mod synthetic;
pub mod whirl;
pub mod wording;

pub use expand::Expansion;
pub use options::{RequestedAccuracy, SweepOptions};
pub use spec::{parse_spec, Axis, AxisMode, AxisValues, SweepKind, SweepSpec};

/// A sweep failure: bad spec (with the JSON path), bad variant, I/O, resume or merge.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The spec document is malformed: JSON path inside it and the reason.
    #[error("{path}: {reason}")]
    Spec {
        /// JSON path, e.g. `axes[1].logspace[0]`.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// One expanded variant's scene is rejected by the scene validator.
    #[error("variant {id} ({assignment}): {path}: {reason}")]
    Variant {
        /// Variant id (index in the full expansion).
        id: u64,
        /// The axis values that made it, `path = value, ...`.
        assignment: String,
        /// JSON path inside the variant's scene.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// An existing output cannot be resumed or shards cannot be merged.
    #[error("{0}")]
    Output(String),
}

impl SweepError {
    /// A spec error at `path`.
    pub fn spec(path: impl Into<String>, reason: impl Into<String>) -> Self {
        SweepError::Spec {
            path: path.into(),
            reason: reason.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        SweepError::Io {
            path: path.display().to_string(),
            source,
        }
    }
}
