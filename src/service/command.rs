//! `bearing-sweep serve`: a thin wrapper over [`super::serve_blocking`].

use super::{serve_blocking, ServeError, ServiceConfig};
use crate::app::{AppError, TOKEN_ENV};

/// Runs the service until SIGTERM or Ctrl-C; notices go to `notice` (never the token).
pub fn serve_command(
    mut config: ServiceConfig,
    notice: &mut dyn FnMut(String),
) -> Result<(), AppError> {
    if config.token.is_none() {
        config.token = std::env::var(TOKEN_ENV).ok().filter(|t| !t.is_empty());
    }
    serve_blocking(config, notice).map_err(|e| match e {
        ServeError::Config(m) => AppError::input("--bind", m),
        ServeError::Busy(m) => AppError::input("--data", m),
        other => AppError::input("serve", other.to_string()),
    })
}
