//! Benchmarks behind `bearing-sweep bench`: work-precision measurements written as JSON,
//! a markdown table and an SVG diagram. Timing lives here only, never in tests.

mod all;
mod loads;

pub use all::{
    bench_all, machine_description, BenchAllOptions, BenchAllReport, STIFF_VISCOSITY_PA_S,
};
pub use loads::{
    bench_loads, bench_loads_markdown, bench_states, gpu_timing_batch, BenchLoadsOptions,
    BenchLoadsReport, BenchRow, DEFAULT_GPU_BATCH,
};
