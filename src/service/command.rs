//! `bearing-sweep serve`: a thin wrapper over [`super::serve_blocking`].

use super::{serve_blocking, ServeError, ServiceConfig};
use crate::app::{CliError, TOKEN_ENV};

/// Runs the service until SIGTERM or Ctrl-C; notices go to `notice` (never the token).
pub fn serve_command(
    mut config: ServiceConfig,
    notice: &mut dyn FnMut(String),
) -> Result<(), CliError> {
    if config.token.is_none() {
        config.token = std::env::var(TOKEN_ENV).ok().filter(|t| !t.is_empty());
    }
    serve_blocking(config, notice).map_err(|e| match e {
        ServeError::Config(m) => CliError::input("--bind", m),
        ServeError::Busy(m) => CliError::input("--data", m),
        other => CliError::input("serve", other.to_string()),
    })
}
