//! The GPU backend of a build without the `gpu` feature: a type with no values, whose
//! constructors answer as a machine without an adapter does, so `gpu` is refused with a
//! clear message and `auto` falls back to the CPU.

use std::time::Duration;

use super::gpu_kernel::{GpuOptions, GpuTiming};
use super::{BackendError, BackendInfo, FilmBackend, Precision};
use crate::bearing::{Accuracy, FilmIntegrals, PackedState, RuleSettings};

/// Why no GPU backend can be built.
const ABSENT: &str = "this binary was built without the `gpu` feature";

/// The WGSL kernel on one wgpu device: never constructed in this build.
pub enum GpuBackend {}

impl GpuBackend {
    /// Always [`BackendError::NoAdapter`] in this build.
    pub fn new(_accuracy: Accuracy, _options: GpuOptions) -> Result<Self, BackendError> {
        Err(BackendError::NoAdapter(ABSENT.into()))
    }

    /// Always [`BackendError::NoAdapter`] in this build.
    pub fn with_settings(
        _settings: RuleSettings,
        _options: GpuOptions,
    ) -> Result<Self, BackendError> {
        Err(BackendError::NoAdapter(ABSENT.into()))
    }

    /// Precision the kernel computes in.
    pub fn precision(&self) -> Precision {
        match *self {}
    }

    /// Whether the adapter is a software rasteriser.
    pub fn is_software(&self) -> bool {
        match *self {}
    }

    /// Most states per dispatch.
    pub fn max_chunk(&self) -> usize {
        match *self {}
    }

    /// Invocations per state of the short-film kernel.
    pub fn lanes(&self) -> u32 {
        match *self {}
    }

    /// Dispatch slots a shared dispatcher keeps in flight.
    pub fn slots(&self) -> usize {
        match *self {}
    }

    /// Timing of the last call.
    pub fn last_timing(&self) -> GpuTiming {
        match *self {}
    }

    /// A notice raised while building.
    pub fn take_notice(&mut self) -> Option<String> {
        match *self {}
    }

    /// Destroys the device (testing only).
    #[doc(hidden)]
    pub fn simulate_device_loss(&mut self) {
        match *self {}
    }

    /// Sets the per-chunk wait (testing only).
    #[doc(hidden)]
    pub fn set_timeout(&mut self, _timeout: Duration) {
        match *self {}
    }
}

impl FilmBackend for GpuBackend {
    fn info(&self) -> BackendInfo {
        match *self {}
    }
    fn settings(&self) -> RuleSettings {
        match *self {}
    }
    fn integrate(
        &mut self,
        _states: &[PackedState],
        _out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        match *self {}
    }
}
