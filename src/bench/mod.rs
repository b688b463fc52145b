//! Benchmarks behind `bearing-sweep bench`: work-precision measurements written as JSON,
//! a markdown table and an SVG diagram. Timing lives here only, never in tests.

mod all;
pub mod backend;
mod backend_report;
pub mod finite;
mod loads;
#[cfg(feature = "postgres")]
mod queue;
mod rotor;
#[cfg(feature = "service")]
mod serve;

pub use all::{
    bench_all, machine_description, BenchAllOptions, BenchAllReport, STIFF_VISCOSITY_PA_S,
};
pub use backend_report::bench_backend;
pub use loads::{
    bench_loads, bench_loads_markdown, bench_states, gpu_timing_batch, BenchLoadsOptions,
    BenchLoadsReport, LoadsRow, DEFAULT_GPU_BATCH,
};
#[cfg(feature = "postgres")]
pub use queue::{bench_queue, QueueBenchOptions};
pub use rotor::{
    bench_rotor, bench_rotor_batch, BenchRotorOptions, BenchRotorReport, RotorBenchRow,
    ROTOR_BATCH_TABLE_HEADER,
};
#[cfg(feature = "service")]
pub use serve::{bench_serve, spawn_background, LoadOptions, LoadRow};
