//! Benchmarks behind `bearing-sweep bench`: work-precision measurements written as JSON,
//! a markdown table and an SVG diagram. Timing lives here only, never in tests.

mod loads;

pub use loads::{
    bench_loads, bench_loads_markdown, bench_states, BenchLoadsOptions, BenchLoadsReport, BenchRow,
};
