//! Numerical building blocks free of physics: Gauss rules and adaptive quadrature.

mod adaptive;
mod gauss;

pub use adaptive::{adaptive_gauss_kronrod, AdaptiveResult};
pub use gauss::{gauss_legendre_unit, GaussRule};
