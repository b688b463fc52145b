//! Rigid rotors in hydrodynamic journal bearings or ideal revolute joints (MODEL.md
//! section 8): scene files ([`Scene`], [`load_scene`]), the rigid-body model
//! ([`RotorModel`]: quaternion attitude, gyroscopic terms, exact end-point film torques
//! about `G`), and lockstep batched simulation ([`simulate_batch`] → [`SimResult`]).

mod jacobian;
mod model;
mod scene;
pub mod simplifications;
mod simulate;

pub use model::{RotorModel, DIM, JAC_DIM};
pub use scene::{
    load_scene, load_scene_within, BearingSpec, ContactSpec, FilmSpec, InitialSpec, IntegratorSpec,
    ModelKind, RotorSpec, Scene, SceneError, SpinMode,
};
pub use simulate::simulate_batch_streaming_cancellable;
pub use simulate::{numbers_per_sample, sample_cap, simulate_batch_capped};
pub use simulate::{
    settings_of, simulate_batch, simulate_batch_streaming, BearingSeries, FilmEvent, RotorFault,
    SimResult, SimStats, SimStatus, TimeSeries,
};
pub use simulate::{simulate_batch_observed, BearingSample, Sample, SampleObserver, SeriesStore};
pub use simulate::{FilmSample, FilmSeries, ThermalSample, ThermalSeries};
