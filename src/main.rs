//! The `bearing-sweep` command line: the arguments are parsed here and run by the library
//! (`bearing_sweep::cli`, the argument structs and each command's call into the app).

use std::process::ExitCode;

use clap::Parser;

#[global_allocator]
static ALLOCATOR: bearing_sweep::allocator::Allocator = bearing_sweep::allocator::Allocator;

fn main() -> ExitCode {
    // Before any thread: the Vulkan loader would print an XDG_RUNTIME_DIR error otherwise.
    bearing_sweep::backend::ensure_xdg_runtime_dir();
    bearing_sweep::cli::run(bearing_sweep::cli::Cli::parse())
}
