//! The command line: clap's argument structs ([`Cli`]) and each command's call into the
//! library; `main.rs` parses the arguments and calls [`run`].

mod args;
mod commands;

pub use args::Cli;
pub use commands::run;
