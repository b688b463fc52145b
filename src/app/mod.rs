//! Command implementations behind the thin `bearing-sweep` binary: JSON in, JSON out,
//! errors that name the JSON path and the reason.

mod coefficient_format;
mod coefficients;
mod eval;
mod finite;
mod output;
mod run;
mod stability;
#[cfg(feature = "service")]
mod submit;
mod sweep;
mod warnings;

pub use coefficient_format::CoefficientFormat;
pub use coefficients::{
    coefficients_json, coefficients_json_with, ross_csv, ross_toml, CoefficientOptions,
    RossVersion, ROSS_COLUMNS, ROSS_TILT_NOTICE, ROSS_TOML_TABLE,
};
pub use eval::{
    eval_file, eval_json, eval_json_pooled, eval_stream, EvalOptions, EvaluatorPool, EVAL_CHUNK,
};
pub use finite::{error_map_files, error_map_grid};
pub use output::{print_lines, print_text, StdoutWriter};
pub use run::{figures, run_scene_file, RunReport, SceneRunOptions};
pub use stability::{stability_scene_file, StabilityOptions, DEFAULT_SPEEDS};
#[cfg(feature = "service")]
pub use submit::{submit_command, SubmitOptions, TOKEN_ENV};
pub use sweep::{is_sweep_spec, merge_command, run_command, SweepRunOptions};
pub use warnings::{bearing_warnings, scene_file_warnings, sweep_warnings};

/// A use case's failure, shown to the user: the CLI prints it and exits with status 2, the
/// service maps it to its `ApiError`, the benchmarks pass it up.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// Input JSON that cannot be used: the path inside the document and why.
    #[error("{path}: {reason}")]
    Input {
        /// JSON path, e.g. `states[3].omega`.
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
    /// The backend could not be created.
    #[error(transparent)]
    Backend(#[from] crate::backend::BackendError),
    /// A sweep failed (spec, variant, output, merge).
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
    /// Writing to standard output failed (a closed pipe or a full disk).
    #[error("writing to standard output: {0}")]
    Stdout(std::io::Error),
}

impl AppError {
    /// Standard output was closed by its reader (`… | head`): the command stops quietly.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, AppError::Stdout(e) if e.kind() == std::io::ErrorKind::BrokenPipe)
    }

    /// An input error at `path`.
    pub fn input(path: impl Into<String>, reason: impl Into<String>) -> Self {
        // Paths and reasons may quote user input: keep them short (a 100 MB string must
        // not come back in the message).
        AppError::Input {
            path: crate::json::shorten(&path.into(), crate::json::MAX_ECHO_CHARS * 2),
            reason: crate::json::shorten(&reason.into(), crate::json::MAX_MESSAGE_CHARS),
        }
    }
}

/// The calibrated film accuracy level for `--accuracy rtol`, or the refusal naming the
/// flag (the wording is [`crate::sweep::options::refusal`], one for every command).
pub fn accuracy(rtol: f64) -> Result<crate::bearing::Accuracy, AppError> {
    crate::sweep::options::accuracy_level(rtol).map_err(|r| AppError::input("--accuracy", r))
}

/// Reads a whole file, `-` meaning standard input.
pub fn read_input(path: &str) -> Result<String, AppError> {
    use std::io::Read;
    let mut text = String::new();
    let result = if path == "-" {
        std::io::stdin().read_to_string(&mut text).map(|_| ())
    } else {
        std::fs::read_to_string(path).map(|t| text = t)
    };
    result.map_err(|source| AppError::Io {
        path: path.to_string(),
        source,
    })?;
    Ok(text)
}

/// Deserialises `value` as `T`, turning serde's message into an error at `path`.
pub fn from_value<T: serde::de::DeserializeOwned>(
    value: &serde_json::Value,
    path: &str,
) -> Result<T, AppError> {
    crate::json::deserialize_at(value)
        .map_err(|(at, reason)| AppError::input(crate::json::join_path(path, &at), reason))
}
