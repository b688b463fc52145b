//! Lockstep batched ODE integrators: N variants advance together, each with its own time,
//! step size, error control and status, and every stage of all active variants goes to
//! the right-hand side in ONE call ([`BatchSystem::eval`]), so a film-load backend sees
//! one large batch per stage. Methods: adaptive Dormand-Prince 5(4) with PI step control
//! and 4th-order dense output ([`Method::Dopri5`]), the L-stable implicit Radau IIA of
//! order 5 with simplified Newton and batched finite-difference Jacobians
//! ([`Method::Radau5`]), fixed-step classical Runge-Kutta ([`Method::Rk4`]), and the
//! adaptive Dormand-Prince 8(5,3) with 7th-order dense output ([`Method::Dop853`]), and the
//! variable-order BDF with one right-hand side per Newton iteration ([`Method::Bdf`]).
//! Output goes to [`BatchSystem::record`] at uniform sample times from dense output,
//! independent of the steps taken. Entry point: [`run_batch`].

mod bdf;
mod common;
mod dop853;
mod dopri;
mod jacobian;
mod linalg;
mod newton;
mod radau;
mod reduced;
mod rk4;
mod system;
mod tableau;

pub use common::sample_count;
pub use system::{run_batch, BatchSystem, Method, Settings, Stats, Status};
