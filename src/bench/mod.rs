//! Benchmarks behind `bearing-sweep bench`: work-precision measurements written as JSON,
//! a markdown table and an SVG diagram. Timing lives here only, never in tests.

mod all;
pub mod backend;
mod backend_report;
pub mod finite;
mod loads;
mod rotor;

pub use all::{
    bench_all, machine_description, BenchAllOptions, BenchAllReport, STIFF_VISCOSITY_PA_S,
};
pub use backend_report::bench_backend;
pub use loads::{
    bench_loads, bench_loads_markdown, bench_states, gpu_timing_batch, BenchLoadsOptions,
    BenchLoadsReport, BenchRow, DEFAULT_GPU_BATCH,
};
pub use rotor::{
    bench_rotor, bench_rotor_batch, BenchRotorOptions, BenchRotorReport, RotorBenchRow,
};
