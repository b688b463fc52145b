//! Finite-length Reynolds film (issue 16): the full (θ, z) Reynolds equation with
//! Swift–Stieber cavitation, solved by projected full multigrid with the grid chosen for a
//! requested accuracy (issue 20); settings, solvers, loads,
//! the short-bearing model-error map and the `auto` model choice. See docs/finite-film.md.

mod calibrate;
mod error_map;
mod flow;
mod jfo;
mod lanes;
mod map;
mod multigrid;
mod pages;
mod settings;
mod solver;

pub use error_map::{
    compute_short_model_error, effective_model, error_map_settings, short_model_error,
    ShortModelError, ERROR_MAP_ASPECTS, ERROR_MAP_ECC,
};
pub use flow::{
    apply_finite_flow, film_flow_of, flow_integrals, ladder_theta0, solution_grid, solution_theta0,
    FlowIntegrals,
};
pub(crate) use jfo::apply_jfo_flow;
// For the GPU JFO driver (src/backend/finite_jfo.rs): the CPU's discrete problem.
pub use jfo::{jfo_balance, jfo_flow_integrals, JfoBalance, JfoHistory, JfoSolver};
#[cfg(feature = "gpu")]
pub(crate) use jfo::{JfoLadder, JfoProblem, KernelStop, JFO_NODE_STRIDE};
pub use map::{compute_error_map, error_map_markdown, error_map_svg, ErrorMap, MAP_LEVELS};
// For the GPU multigrid driver (src/backend/finite_mg.rs): the same hierarchy and stop rule.
#[cfg(feature = "gpu")]
pub(crate) use multigrid::{coarser, Coarsen};
pub use multigrid::{CycleLog, WorkRole, WorkShare};
pub use settings::{Cavitation, FilmModel, FiniteSettings, FiniteSettingsError, Inlet};
#[cfg(feature = "gpu")]
pub(crate) use solver::ALGEBRAIC_FRACTION;
pub use solver::{
    accuracy_ladder, banded_estimate, finite_integrals, finite_loads, finite_solution,
    ladder_estimate, ladder_extends, ladder_integrals_on, richardson_estimate, simpson_estimate,
    simpson_reported, simpson_stop_bound, CoarsestSolve, FiniteGrid, FiniteJob, FiniteSolution,
    FiniteSolver, LadderRule, LadderStep, MgCycle, SolveReport, LADDER_CUBIC_START, LADDER_FLOOR,
    LADDER_LOOSE, LADDER_MEASURED_LAST, LADDER_PAIR_RATIO, LADDER_POST_SWEEPS,
};

/// The instruction set the multigrid's passes run on in this process (chosen on first use:
/// the faster of AVX-512F and AVX2 where the CPU has both, by a few milliseconds of timed
/// solves; see `BEARING_SWEEP_LANES`). Probes call it before their clock, as the program's
/// start pays it once.
pub fn multigrid_lanes() -> crate::bearing::LaneIsa {
    lanes::isa()
}
