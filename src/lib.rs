//! bearing-sweep: rigid rotors in hydrodynamic journal bearings (Stefanelli, Valentini,
//! Vita, DETC2005-84858), the nonlinear film model evaluated in batches on CPU and GPU.
//! The physics contract is `docs/model.md` (the model, its frames, signs and closed forms);
//! conventions there hold here.

pub mod allocator;
pub mod app;
pub mod backend;
pub mod bearing;
pub mod bench;
pub mod budget;
pub mod cli;
pub mod integrate;
pub mod json;
pub mod numerics;
pub mod plot;
pub mod rotor;
#[cfg(feature = "service")]
pub mod service;
pub mod stability;
pub mod sweep;
